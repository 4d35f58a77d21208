"""Persistent contact checked against an independent Newton–Euler formulation.

The simulator is a black box here (``Session.contact``, ``derive.simulate``); the
reference is ``tests/newton_euler_contact.py``: Newton for the carrier and for the point,
Euler for the carrier about O, the point's relative motion prescribed, and the second
derivative of h(S) = 0 (with S moving over the surface), solved as one 10 x 10 linear
system.  The formulation is first checked on its own (closed forms, the constraint and
the momentum theorems along its own integration), then compared with the simulator on
random constrained states and along contact phases of simulated runs.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from derive.runtime.driver import prepare, simulate
from derive.runtime.session import Session
from newton_euler_contact import Body, gap, kinetic_moment_C, on_plane, solve

G = 9.81


def scene_dict(M, m, J, shape, size, center, law, e=0.5, duration=1.0, g=G, **run):
    body = {"mass": M, "inertia": list(J), "shape": shape, "center": list(center)}
    body["radius" if shape == "sphere" else "semi_axes"] = size
    return {"name": "ne-check", "body": body, "point": {"mass": m, "law": list(law)},
            "plane": {"restitution": e},
            "initial": {"time": 0.0, "com": [0.0, 0.0, 20.0], "com_velocity": [0.0, 0.0, 0.0],
                        "omega": [0.0, 0.0, 0.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
            "run": {"duration": duration, "model": "general", "g": g, **run}}


def body_of(d) -> Body:
    b = d["body"]
    size = b.get("radius", b.get("semi_axes"))
    axes = np.full(3, float(size)) if b["shape"] == "sphere" else np.asarray(size, float)
    return Body(b["mass"], d["point"]["mass"], np.asarray(b["inertia"], float),
                d["run"]["g"], np.asarray(b["center"], float), axes)


class Simulator:
    """One Session of the general model, re-initialised per scene."""

    def __init__(self):
        self.session = None

    def load(self, d):
        prep = prepare(d)
        assert prep.kind == "general"
        if self.session is None:
            self.session = Session(prep.library)
        s = self.session
        s.set_law(prep.scene.law)
        s.init(prep.options, prep.parameters, prep.scene.t0, prep.start.q0)
        return prep

    def contact(self, t, q):
        return self.session.contact(t, q)


@pytest.fixture(scope="module")
def sim():
    return Simulator()


def random_case(rng, shape):
    M = float(np.exp(rng.uniform(np.log(0.2), np.log(5.0))))
    m = float(np.exp(rng.uniform(np.log(0.02), np.log(3.0))))
    B = rng.uniform(0.005, 0.3, 3)              # second moments of some mass distribution
    J = [B[1] + B[2], B[0] + B[2], B[0] + B[1]]  # so J_x <= J_y + J_z etc. hold
    if shape == "sphere":
        size = float(rng.uniform(0.2, 1.0))
    else:
        size = [float(v) for v in rng.uniform(0.15, 1.0, 3)]
    center = [float(v) for v in rng.uniform(-0.25, 0.25, 3)]
    law = []
    for _ in range(3):
        c, a1, a2 = rng.uniform(-0.2, 0.2), rng.uniform(0, 0.25), rng.uniform(0, 0.1)
        w1, w2, p1 = rng.uniform(0.5, 6), rng.uniform(0.5, 4), rng.uniform(0, 2 * np.pi)
        law.append(f"{c!r} + {a1!r}*sin({w1!r}*t + {p1!r}) + {a2!r}*cos({w2!r}*t)")
    return scene_dict(M, m, J, shape, size, center, law)


def group_errors(dq, N, a, ref, body):
    """Relative errors by group: velocities, V_C', omega', A', N, a_free."""
    dq_r, N_r, a_r = ref
    mg = (body.m + body.M) * body.g
    out = {}
    for name, sl, floor in (("V", slice(0, 3), 1.0), ("V'", slice(3, 6), body.g),
                            ("omega'", slice(6, 9), 1.0), ("A'", slice(9, 18), 1.0)):
        out[name] = np.abs(dq[sl] - dq_r[sl]).max() / max(np.abs(dq_r[sl]).max(), floor)
    out["N"] = abs(N - N_r) / max(abs(N_r), mg)
    out["a_free"] = abs(a - a_r) / max(abs(a_r), body.g)
    return out


# -- the formulation on its own -------------------------------------------------------------

def test_formulation_closed_forms():
    """Resting body, P fixed: N = (m+M) g and nothing accelerates.  P moving on the
    vertical through O and S, the carrier at rest: N = (m+M)(g + rho f'') and
    Z_C'' = rho f''.  Sphere (any attitude) and ellipsoid (n along a principal axis)."""
    rng = np.random.default_rng(7)
    for k in range(40):
        A = Rotation.random(random_state=rng).as_matrix()
        n = A[2]
        M, m, R = rng.uniform(0.5, 3), rng.uniform(0.05, 2), rng.uniform(0.2, 1)
        kappa, b, a, W, t = rng.uniform(-0.1, 0.1), *rng.uniform(-0.1, 0.1, 2), \
            rng.uniform(1, 8), rng.uniform(0, 5)
        body = Body(M, m, np.array([0.2, 0.25, 0.3]), G, kappa * n, np.full(3, R))
        f, fdd = b + a * np.sin(W * t), -a * W ** 2 * np.sin(W * t)
        fd = a * W * np.cos(W * t)
        u = np.ravel(np.column_stack([f * n, fd * n, fdd * n]))
        q = on_plane(body, A, np.zeros(3), u)
        dq, N, hdd = solve(body, q, u)
        rho = m / (m + M)
        assert N == pytest.approx((m + M) * (G + rho * fdd), rel=1e-13)
        assert np.allclose(dq[3:6], [0, 0, rho * fdd], atol=1e-12)
        assert np.allclose(dq[6:18], 0, atol=1e-12) and abs(hdd) < 1e-12
        # P fixed, the ellipsoid standing on its z axis with C above S
        body = Body(M, m, np.array([0.2, 0.25, 0.3]), G, np.array([0, 0, kappa]),
                    rng.uniform(0.2, 1, 3))
        u = np.array([0, 0, 0, 0, 0, 0, b, 0, 0.0])
        q = on_plane(body, np.eye(3), np.zeros(3), u)
        dq, N, _ = solve(body, q, u)
        assert N == pytest.approx((m + M) * G, rel=1e-13)
        assert np.allclose(dq[3:18], 0, atol=1e-12)


def test_formulation_keeps_the_constraint_and_obeys_the_momentum_theorems():
    """Along its own integration (ellipsoid, offset centre, fast tumbling): h and v_n
    stay 0 (so h'' includes the motion of S over the surface), X_C'' = Y_C'' = 0, and
    dK_C/dt = CS x N e_Z (K_C from the two bodies' momenta), so K_Z is constant."""
    body = Body(1.2, 0.7, np.array([0.14, 0.2, 0.26]), G, np.array([0.06, -0.04, 0.03]),
                np.array([0.5, 0.35, 0.25]))

    def law(t):
        return np.array([0.1 * np.sin(3 * t), 0.3 * np.cos(3 * t), -0.9 * np.sin(3 * t),
                         0.05 + 0.08 * np.cos(2 * t), -0.16 * np.sin(2 * t),
                         -0.32 * np.cos(2 * t), 0.07 * np.sin(t), 0.07 * np.cos(t),
                         -0.07 * np.sin(t)])

    A0 = Rotation.from_rotvec([0.4, -0.7, 0.2]).as_matrix()
    q0 = on_plane(body, A0, np.array([1.5, -2.0, 3.0]), law(0.0), VXY=(0.3, -0.1))
    sol = solve_ivp(lambda t, y: solve(body, y, law(t))[0], (0, 1.0), q0, method="DOP853",
                    rtol=1e-12, atol=1e-13, dense_output=True)
    K0 = kinetic_moment_C(body, q0, law(0.0))
    for t in np.linspace(0.05, 0.95, 10):
        y = sol.sol(t)
        h, vn = gap(body, y, law(t))
        assert abs(h) < 1e-10 and abs(vn) < 1e-9
        dq, N, _ = solve(body, y, law(t))
        assert np.allclose(dq[3:5], 0, atol=1e-10)
        assert np.allclose(y[3:5], [0.3, -0.1], atol=1e-10)
        eps = 1e-4
        dK = (kinetic_moment_C(body, sol.sol(t + eps), law(t + eps))
              - kinetic_moment_C(body, sol.sol(t - eps), law(t - eps))) / (2 * eps)
        A = y[9:18].reshape(3, 3)
        s, _ = body.lowest(A[2])
        CS = A @ (s - body.rho * law(t)[[0, 3, 6]])
        torque = np.cross(CS, [0, 0, N])
        assert np.allclose(dK, torque, atol=1e-6 * max(1.0, np.abs(torque).max()))
        assert kinetic_moment_C(body, y, law(t))[2] == pytest.approx(K0[2], abs=1e-10)


# -- the simulator against it, state by state -------------------------------------------------

N_RANDOM = 150          # per shape


@pytest.mark.parametrize("shape", ["sphere", "ellipsoid"])
def test_contact_matches_newton_euler_on_random_states(sim, shape):
    rng = np.random.default_rng(2024 if shape == "sphere" else 4202)
    worst = {}
    negative = 0
    for k in range(N_RANDOM):
        d = random_case(rng, shape)
        prep = sim.load(d)
        body = body_of(d)
        A = Rotation.random(random_state=rng).as_matrix()
        w = rng.normal(size=3) * rng.uniform(0, 4)
        t = float(rng.uniform(0, 10))
        u = prep.scene.law.jets(np.array([t]))[:, 0]
        q = on_plane(body, A, w, u, XY=rng.normal(size=2), VXY=rng.normal(size=2))
        h, vn = gap(body, q, u)
        assert abs(h) < 1e-14 and abs(vn) < 1e-13
        dq, N, a_free = sim.contact(t, q)
        rows = sim.session.contact_rows(np.array([t, t + 0.1]), np.array([q, q]))
        assert np.array_equal(rows[0][0], dq) and rows[1][0] == N and rows[2][0] == a_free
        ref = solve(body, q, u)
        _, _, a_ref = solve(body, q, u, with_reaction=False)
        errs = group_errors(dq, N, a_free, (ref[0], ref[1], a_ref), body)
        for key, v in errs.items():
            worst[key] = max(worst.get(key, 0.0), v)
        negative += ref[1] < 0
        assert max(errs.values()) < 1e-9, (k, d, t, q.tolist(), errs)
        # the reaction is what cancels the free normal acceleration of S
        assert abs(ref[2]) < 1e-11 * max(1.0, abs(a_ref))
    print(f"\n{shape}: {N_RANDOM} states ({negative} with N < 0), worst relative errors: "
          + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))


def test_contact_reaction_closed_forms(sim):
    """The simulator's N: at rest with P fixed, N = (m+M) g; P oscillating on the
    vertical through O and S (sphere centred on that line, any attitude):
    N = (m+M)(g + m/(m+M) z''), the carrier not accelerating."""
    rng = np.random.default_rng(11)
    for k in range(20):
        A = Rotation.random(random_state=rng).as_matrix()
        n = A[2]
        M, m, R = rng.uniform(0.5, 3), rng.uniform(0.05, 2), rng.uniform(0.2, 1)
        kappa, b, a, W = rng.uniform(-0.1, 0.1), *rng.uniform(-0.1, 0.1, 2), rng.uniform(1, 8)
        law = [f"({float(n[i])!r})*({float(b)!r} + {float(a)!r}*sin({float(W)!r}*t))"
               for i in range(3)]
        d = scene_dict(M, m, [0.2, 0.25, 0.3], "sphere", R, list(kappa * n), law)
        prep = sim.load(d)
        body = body_of(d)
        t = float(rng.uniform(0, 5))
        u = prep.scene.law.jets(np.array([t]))[:, 0]
        q = on_plane(body, A, np.zeros(3), u)
        dq, N, _ = sim.contact(t, q)
        zdd = -a * W ** 2 * np.sin(W * t)
        rho = m / (m + M)
        assert N == pytest.approx((m + M) * (G + rho * zdd), rel=1e-12)
        assert np.allclose(dq[3:6], [0, 0, rho * zdd], atol=1e-11)
        assert np.allclose(dq[6:18], 0, atol=1e-11)
    # at rest, P fixed: ellipsoid on its z axis, C above S
    d = scene_dict(2.0, 0.5, [0.2, 0.25, 0.3], "ellipsoid", [0.6, 0.5, 0.4], [0, 0, 0.05],
                   ["0", "0", "0.1"])
    sim.load(d)
    body = body_of(d)
    u = np.array([0, 0, 0, 0, 0, 0, 0.1, 0, 0])
    q = on_plane(body, np.eye(3), np.zeros(3), u)
    dq, N, a_free = sim.contact(0.3, q)
    assert N == pytest.approx(2.5 * G, rel=1e-13)
    assert a_free == pytest.approx(-G, rel=1e-13)
    assert np.allclose(dq[3:18], 0, atol=1e-12)


# -- trajectories: the simulator's contact phases against our integration ---------------------

W_CHATTER = 25.0
CHATTER = scene_dict(1.0, 0.25, [0.02, 0.025, 0.03], "sphere", 0.3, [0.01, 0.0, 0.0],
                     ["0.02*sin(2*t)", "0.0", f"0.1*sin({W_CHATTER}*t)"], e=0.3,
                     duration=2.0, method="dop853", rtol=1e-11, atol=1e-13,
                     outputs=["pose"])
CHATTER["initial"].update(com=[0.0, 0.0, 0.32], omega=[0.0, 0.0, 2.0])


def chatter_law(t):
    W = W_CHATTER
    s2, c2, sW, cW = math.sin(2 * t), math.cos(2 * t), math.sin(W * t), math.cos(W * t)
    return np.array([0.02 * s2, 0.04 * c2, -0.08 * s2, 0, 0, 0,
                     0.1 * sW, 0.1 * W * cW, -0.1 * W * W * sW])


def contact_phases(result):
    ev = [e for e in result.events if e["kind"] in ("contact", "lift_off")]
    phases = []
    for k, e in enumerate(ev):
        if e["kind"] == "contact":
            nxt = ev[k + 1]["t"] if k + 1 < len(ev) and ev[k + 1]["kind"] == "lift_off" \
                else None
            phases.append((e, nxt))
    return phases


def test_contact_phases_of_a_chattering_ball_follow_newton_euler():
    """A ball (centre off O) whose point oscillates (Gamma = 1.27, e = 0.3) and spins:
    impacts accumulate, it rests, lifts off, ... .  From the simulator's state at each
    entry into contact, our formulation is integrated (DOP853, rtol 1e-11) until its N
    crosses zero; states at the simulator's rows and the lift-off times must agree."""
    res = simulate(CHATTER)
    assert res.status == "done"
    body = body_of(CHATTER)
    prep = prepare(CHATTER)
    ts = np.linspace(0, 2, 7)
    assert np.allclose(prep.scene.law.jets(ts), np.array([chatter_law(t) for t in ts]).T,
                       atol=1e-13)
    phases = contact_phases(res)
    assert len(phases) >= 3 and sum(p[1] is not None for p in phases) >= 3

    def rhs(t, y):
        return solve(body, y, chatter_law(t))[0]

    def reaction(t, y):
        return solve(body, y, chatter_law(t))[1]
    reaction.terminal, reaction.direction = True, -1

    worst_state, worst_lift, worst_N = 0.0, 0.0, 0.0
    for entry, t_lift in phases:
        tc = entry["t"]
        rows = np.nonzero(res.t == tc)[0]
        y0 = res.q[rows[-1]]
        h, vn = gap(body, y0, chatter_law(tc))
        assert abs(h) < 1e-12 and abs(vn) < 1e-12
        N0 = solve(body, y0, chatter_law(tc))[1]
        worst_N = max(worst_N, abs(N0 - entry["value"]) / (1.25 * G))
        t_end = t_lift + 0.05 if t_lift is not None else res.t[-1]
        sol = solve_ivp(rhs, (tc, t_end), y0, method="DOP853", rtol=1e-11, atol=1e-13,
                        dense_output=True, events=reaction,
                        max_step=2 * np.pi / W_CHATTER / 20)
        if t_lift is not None:
            assert len(sol.t_events[0]) == 1
            t_ours = sol.t_events[0][0]
            worst_lift = max(worst_lift, abs(t_ours - t_lift))
            assert abs(t_ours - t_lift) < 1e-9, (tc, t_lift, t_ours)
        else:
            t_ours = t_end
        inside = np.nonzero((res.t > tc) & (res.t < min(t_ours, t_end)))[0]
        assert len(inside) > 3
        ours = sol.sol(res.t[inside]).T
        err = np.abs(ours - res.q[inside]).max()
        worst_state = max(worst_state, err)
        assert err < 1e-8, (tc, err)
    print(f"\nchatter: {len(phases)} contact phases, max state difference "
          f"{worst_state:.1e}, lift-off times within {worst_lift:.1e} s, N at entry "
          f"within {worst_N:.1e} (m+M)g")


def test_liftoffs_of_a_vertically_driven_ball_match_the_closed_form():
    """Sphere centred at O, P on the body z axis, z = a sin(W t), axis vertical, no spin:
    in contact O stays at height R and N = (m+M)(g - rho a W^2 sin(W t)), which turns
    negative at W t = asin(1/Gamma) + 2 pi k, Gamma = rho a W^2 / g."""
    a, W, M, m, R = 0.1, 25.0, 1.0, 0.25, 0.3
    rho = m / (m + M)
    Gamma = rho * a * W ** 2 / G
    d = scene_dict(M, m, [0.02, 0.02, 0.03], "sphere", R, [0, 0, 0],
                   ["0", "0", f"{a}*sin({W}*t)"], e=0.3, duration=1.5, method="dop853",
                   rtol=1e-11, atol=1e-13, outputs=["pose"])
    d["initial"].update(com=[0.0, 0.0, R + 0.01])
    res = simulate(d)
    body = body_of(d)
    lifts = [e["t"] for e in res.events if e["kind"] == "lift_off"]
    assert len(lifts) >= 3
    worst = 0.0
    for t in lifts:
        k = round((W * t - math.asin(1 / Gamma)) / (2 * math.pi))
        worst = max(worst, abs(t - (math.asin(1 / Gamma) + 2 * math.pi * k) / W))
    assert worst < 1e-9
    phases = contact_phases(res)
    assert len(phases) >= 3
    print(f"\nvertical ball: {len(lifts)} lift-offs within {worst:.1e} s of the closed form")
    for entry, t_lift in phases:
        inside = (res.t > entry["t"]) & (res.t < (t_lift or res.t[-1]))
        t, q = res.t[inside], res.q[inside]
        assert np.allclose(q[:, 2], R + rho * a * np.sin(W * t), atol=1e-10)
        for ti, qi in zip(t[::7], q[::7]):
            u = np.array([0, 0, 0, 0, 0, 0, a * np.sin(W * ti), a * W * np.cos(W * ti),
                          -a * W * W * np.sin(W * ti)])
            N = solve(body, qi, u)[1]
            assert N == pytest.approx((m + M) * (G - rho * a * W ** 2 * np.sin(W * ti)),
                                      rel=1e-10, abs=1e-10)
