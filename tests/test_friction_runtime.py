"""The rough plane through the runtime (the ``rough`` model, crt_friction.h), each check
against something computed another way.

* Closed forms, whole runs of ``derive.simulate``: a sphere whose point sits at its centre
  (W = diag(k_t, k_t, 1/(m+M)), k_t = 1/(m+M) + R^2/J) lands sliding and spinning.  The
  impact: P_n = (1 + e)(m+M)|v_z| under every restitution law, the slip reduced by
  mu P_n k_t along itself or stopped (P_t = -v_t/k_t); then (e = 0) it slides with its slip
  decaying at mu g (1 + (m+M) R^2/J) to the closed-form stick time, and rolls with the
  velocity it had there, omega_z untouched (no drilling friction).  A homogeneous ball
  rolls at 5/7 of its speed.
* The runtime's impact (Darboux-Keller in C) against derive/darboux_keller.py (SciPy's
  DOP853 on the derived rates) on random Delassus matrices and velocities: slip, stick and
  re-sliding, each restitution law.
* The runtime's sliding and sticking contact, W and the velocity of S against the
  independent Newton-Euler formulation of tests/newton_euler_friction.py on random states
  of random scenes (ellipsoids with offset centres, moving points).
* Statuses: restitution newton runs where mu_f |W_tn| = 0 (the sphere above) and is refused
  elsewhere; friction = 0 runs the smooth models, bit for bit.
"""
from __future__ import annotations

import ctypes

import numpy as np
import pytest

import newton_euler_friction as ne
from cases import rotation_from_quaternion
from derive import abi
from derive import darboux_keller as dk
from derive.runtime.build import DP, library
from derive.runtime.driver import prepare, simulate
from derive.runtime.session import Session

G = 9.81


def sphere_doc(M, m, J, R, z0, V, omega_body, quat, mu, e, law="energetic", duration=2.0,
               rtol=1e-12):
    return {"name": "sphere", "body": {"mass": M, "inertia": [J, J, J], "shape": "sphere",
                                       "radius": R},
            "point": {"mass": m, "law": ["0", "0", "0"]},
            "plane": {"restitution": e, "friction": mu, "restitution_model": law},
            "initial": {"com": [0.2, -0.1, z0], "com_velocity": list(V),
                        "omega": list(omega_body), "quaternion": list(quat)},
            "run": {"duration": duration, "method": "dop853", "rtol": rtol, "atol": 1e-13,
                    "outputs": ["pose", "impacts"]}}


def _landing(rng, mu, e, law="energetic", duration=2.0):
    """A random sphere about to land: (doc, the closed-form numbers at the impact)."""
    M, m, R = rng.uniform(0.5, 3), rng.uniform(0.05, 1), rng.uniform(0.1, 0.6)
    J = rng.uniform(0.2, 0.7) * (M + m) * R * R
    quat = rng.normal(size=4)
    A = rotation_from_quaternion(quat)
    omega_fixed = rng.normal(0, 4, 3)
    V = np.r_[2.0 * rng.normal(size=2), -rng.uniform(0.0, 1.0)]
    z0 = R + rng.uniform(0.05, 0.5)
    doc = sphere_doc(M, m, J, R, z0, V, A.T @ omega_fixed, quat, mu, e, law, duration)
    vz = np.sqrt(V[2] ** 2 + 2 * G * (z0 - R))          # free fall to S on the plane
    t_hit = (V[2] + vz) / G
    # the sphere turns about its centre at the constant omega (isotropic J, no torque)
    slip = V[:2] + np.cross(omega_fixed, [0.0, 0.0, -R])[:2]
    return doc, dict(M=M, m=m, R=R, J=J, vz=vz, t_hit=t_hit, slip=slip, V=V,
                     omega=omega_fixed, k_t=1 / (M + m) + R * R / J)


def _impact_closed_form(c, mu, e):
    P_n = (1 + e) * (c["M"] + c["m"]) * c["vz"]
    reduce = mu * P_n * c["k_t"]
    rho = np.linalg.norm(c["slip"])
    if rho > reduce:
        return P_n, -mu * P_n * c["slip"] / rho, c["slip"] * (1 - reduce / rho), 0
    return P_n, -c["slip"] / c["k_t"], np.zeros(2), 1


@pytest.mark.parametrize("law", ["energetic", "poisson", "newton"])
def test_a_spinning_sphere_lands_as_the_closed_form_says(law):
    """The first impact of a run under each restitution law (e > 0): the impulse, the slip
    after, what happened inside, the work of friction (E_t = -mu P_n (|v_t| + |v_t+|)/2
    while slipping to the end), the time."""
    rng = np.random.default_rng(11)
    stages = set()
    for _ in range(12):
        mu, e = rng.uniform(0.05, 0.8), rng.uniform(0.1, 1.0)
        doc, c = _landing(rng, mu, e, law, duration=0.4)
        res = simulate(doc)
        assert res.model == "rough" and res.status == "done"
        first = next(ev for ev in res.events if ev["kind"] == "impact")
        P_n, P_t, slip_plus, stage = _impact_closed_form(c, mu, e)
        scale = max(c["vz"], np.linalg.norm(c["slip"]))
        assert first["t"] == pytest.approx(doc["initial"].get("time", 0.0) + c["t_hit"],
                                           abs=1e-12)
        assert first["value"] == pytest.approx(P_n, rel=1e-10)
        assert np.abs([first["P_X"], first["P_Y"]] - P_t).max() < 1e-10 * P_n
        assert np.abs([first["slip_X_minus"], first["slip_Y_minus"]] - c["slip"]).max() \
            < 1e-10 * scale
        assert np.abs([first["slip_X_plus"], first["slip_Y_plus"]] - slip_plus).max() \
            < 1e-10 * scale
        assert first["v_plus"] == pytest.approx(e * c["vz"], rel=1e-9)
        assert first["stage"] == ("slip", "stick")[stage]
        if stage == 0:
            w_t = -mu * P_n * (np.linalg.norm(c["slip"]) + np.linalg.norm(slip_plus)) / 2
            assert first["work_friction"] == pytest.approx(w_t, rel=1e-9)
        assert first["work_friction"] <= 0.0
        stages.add(stage)
    assert stages == {0, 1}


def test_a_sphere_lands_slides_and_rolls_at_the_closed_form_times():
    """e = 0: the impact, then sliding to the stick at t* = |v_t+|/(mu g (1 + (m+M) R^2/J))
    with C decelerating at mu g along the slip, then rolling at that velocity to the end,
    omega_z (about the vertical) untouched throughout."""
    rng = np.random.default_rng(5)
    ran = 0
    for _ in range(8):
        mu = rng.uniform(0.1, 0.6)
        doc, c = _landing(rng, mu, 0.0, duration=1.5)
        P_n, P_t, slip_plus, stage = _impact_closed_form(c, mu, 0.0)
        rate = mu * G * (1 + (c["M"] + c["m"]) * c["R"] ** 2 / c["J"])
        t_star = np.linalg.norm(slip_plus) / rate
        if stage == 1 or c["t_hit"] + t_star > 1.2:
            continue
        res = simulate(doc)
        assert res.status == "done"
        kinds = [ev["kind"] for ev in res.events]
        assert kinds == ["impact", "contact", "stick"], kinds
        contact, stick = res.events[1], res.events[2]
        assert contact["mode"] == "sliding" and stick["mode"] == "sticking"
        assert stick["t"] == pytest.approx(c["t_hit"] + t_star, abs=1e-9)
        assert contact["value"] == pytest.approx((c["M"] + c["m"]) * G, rel=1e-9)   # N
        sigma = slip_plus / np.linalg.norm(slip_plus)
        V_roll = c["V"][:2] + P_t / (c["M"] + c["m"]) - mu * G * t_star * sigma
        q_end = res.q[-1]
        scale = np.abs(c["V"]).max() + 1.0
        assert np.abs(q_end[3:5] - V_roll).max() < 1e-9 * scale
        assert abs(q_end[5]) < 1e-9 * scale
        A = q_end[9:18].reshape(3, 3)
        w_end = A @ q_end[6:9]
        assert w_end[2] == pytest.approx(c["omega"][2], abs=1e-9 * scale / c["R"])
        # rolling: omega_t = e_Z x V / R, the slip zero on every row after the stick
        assert np.abs(np.cross([0.0, 0.0, 1.0], np.r_[V_roll, 0.0])[:2] / c["R"]
                      - w_end[:2]).max() < 1e-8 * scale / c["R"]
        after = res.t > stick["t"]
        assert np.abs(res.slip[after]).max() < 1e-9 * scale
        assert set(res.modes[after]) == {3}
        ran += 1
    assert ran >= 4


def test_a_homogeneous_ball_rolls_at_five_sevenths():
    """J = 2/5 (m+M) R^2, thrown sliding without spin (resting on the plane): rolls at 5/7
    of its speed from t = 2 v0/(7 mu g)."""
    M, m, R, mu, v0 = 1.0, 0.3, 0.11, 0.25, 2.0
    J = 0.4 * (M + m) * R * R
    doc = sphere_doc(M, m, J, R, R, [v0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0, 0, 0], mu,
                     0.0, duration=1.0)
    res = simulate(doc)
    assert res.status == "done"
    stick = next(ev for ev in res.events if ev["kind"] == "stick")
    # S starts touching: the runtime meets the plane within round-off of t = 0
    assert stick["t"] == pytest.approx(2 * v0 / (7 * mu * G), abs=1e-8)
    assert res.q[-1][3] == pytest.approx(5 / 7 * v0, rel=1e-9)
    assert abs(res.q[-1][4]) < 1e-12


# ---- the runtime's pieces against the references -------------------------------------------
def _session(doc) -> tuple[Session, object]:
    prep = prepare(doc)
    s = Session(library(prep.kind), chunk=16)
    s.set_law(prep.scene.law)
    s.init(prep.options, prep.parameters, prep.scene.t0, prep.start.q0)
    return s, prep


def _set_friction(s: Session, prep, mu: float, e: float, law: int) -> None:
    from derive import abi
    prm = prep.parameters.copy()
    prm[abi.PRM["friction"]], prm[abi.PRM["e"]] = mu, e
    prm[abi.PRM["restitution_model"]] = law
    s.init(prep.options, prm, prep.scene.t0, prep.start.q0)


def test_the_runtimes_impact_is_the_reference_integrators():
    """crt_eval_impact against derive/darboux_keller.integrate on random positive definite
    W and velocities: every stage and law (newton where W_tn = 0, the end of its restitution
    found inside a curving slip); the impulse to 1e-8, the works to 1e-8."""
    doc = sphere_doc(1.0, 0.2, 0.004, 0.1, 0.5, [0, 0, 0], [0, 0, 0], [1, 0, 0, 0], 0.3, 0.5)
    s, prep = _session(doc)
    rng = np.random.default_rng(17)
    stages, worst = set(), 0.0
    for k in range(240):
        law = abi.RESTITUTION_MODELS[k % 3].name
        B = rng.normal(size=(3, 3))
        W = B @ B.T + rng.uniform(0.05, 1.0) * np.eye(3)
        if law == "newton":                 # where it is energy-consistent: W_tn = 0, the
            W[:2, 2] = W[2, :2] = 0.0       # slip curving in an anisotropic W_tt
        v0 = rng.normal(size=3)
        v0[2] = -abs(v0[2]) - 0.1
        mu, e = rng.uniform(0.0, 1.5), rng.uniform(0.0, 1.0)
        if k % 7 == 0:
            v0[:2] = 0.0                               # no slip: stick or re-slide at once
        _set_friction(s, prep, mu, e, k % 3)
        status, out = s.impact(W, v0)
        try:
            ref = dk.integrate(W, v0, mu, e, law)
        except dk.ImpactJam:
            assert status == "painleve"
            continue
        assert status == "ok"
        scale = np.abs(ref.impulse).max()
        err = max(np.abs(out["impulse"] - ref.impulse).max() / scale,
                  np.abs(out["v_plus"] - ref.v_plus).max() / np.abs(v0).max(),
                  abs(out["work_normal"] - ref.work_normal) / (scale * np.abs(v0).max()),
                  abs(out["work_friction"] - ref.work_friction) / (scale * np.abs(v0).max()))
        worst = max(worst, err)
        assert out["work_friction"] <= 1e-15 * scale * np.abs(v0).max()
        what = [w for _, w in ref.events]
        stages.add(out["stage"])
        if "stick" in what:
            assert out["stage"] == 1
        elif "re-slide" in what:
            assert out["stage"] == 2
    print(f"worst {worst:.1e}; stages {sorted(stages)}")
    assert worst < 1e-8
    assert stages == {0, 1, 2}


def _random_rough_doc(rng):
    axes = rng.uniform(0.2, 0.6, 3)
    M = rng.uniform(0.5, 3.0)
    second = rng.uniform(0.02, 0.3, 3) * M
    J = [second[1] + second[2], second[0] + second[2], second[0] + second[1]]
    law = [f"{rng.uniform(-0.1, 0.1):.4f}*sin({rng.uniform(1, 9):.3f}*t + {k})"
           for k in range(3)]
    return {"body": {"mass": M, "inertia": J, "shape": "ellipsoid",
                     "semi_axes": [float(a) for a in axes],
                     "center": [float(c) for c in rng.uniform(-0.1, 0.1, 3)]},
            "point": {"mass": rng.uniform(0.1, 1.0), "law": law},
            "plane": {"restitution": 0.5, "friction": rng.uniform(0.1, 1.0)},
            "initial": {"com": [0.0, 0.0, 2.0]}, "run": {"duration": 1.0}}


def _ellipsoid_s(n, omega, axes, center):
    """The lowest point of an ellipsoid for the vertical n (body axes) and its rate as the
    body turns (n' = n x omega): s = c - D^2 n/|D n|, written here from its definition."""
    D2 = np.diag(np.asarray(axes) ** 2)
    root = np.sqrt(n @ D2 @ n)
    s = np.asarray(center) - D2 @ n / root
    nd = np.cross(n, omega)
    sd = -D2 @ nd / root + D2 @ n * (n @ D2 @ nd) / root ** 3
    return s, sd


def test_the_runtimes_contact_is_the_newton_euler_formulation():
    """crt_eval_rough_rows (sliding along the slip, sticking), crt_eval_delassus and the
    velocity of S against tests/newton_euler_friction.py: 40 random scenes x 10 random
    states at random times."""
    rng = np.random.default_rng(23)
    worst = {"dq slide": 0.0, "R slide": 0.0, "dq stick": 0.0, "R stick": 0.0, "W": 0.0,
             "v_S": 0.0}
    for _ in range(40):
        doc = _random_rough_doc(rng)
        s, prep = _session(doc)
        sc = prep.scene
        params = np.array([sc.M, sc.m, *sc.J, sc.g])
        mu = sc.friction
        u = np.zeros(9)
        for _ in range(10):
            t = rng.uniform(0.0, 1.0)
            s.library.lib.crt_law_at(s.handle, t, u.ctypes.data_as(DP))
            A = rotation_from_quaternion(rng.normal(size=4))
            q = np.concatenate([rng.normal(size=3), rng.normal(size=3), rng.normal(0, 2, 3),
                                A.ravel()])
            S, Sd = _ellipsoid_s(A[2], q[6:9], sc.size, sc.center)
            F = (sc.M + sc.m) * sc.g
            dq, R, v = s.rough_rows([t, t], np.array([q, q]), [2, 3])
            v_ne = ne.velocity_of_S(q, u, S, params)
            worst["v_S"] = max(worst["v_S"], np.abs(v[0] - v_ne).max() / np.abs(v_ne).max())
            sigma = v_ne[:2] / np.linalg.norm(v_ne[:2])
            dq_ne, N_ne, _ = ne.sliding(q, u, S, Sd, params, mu, sigma)
            R_ne = N_ne * np.array([-mu * sigma[0], -mu * sigma[1], 1.0])
            worst["dq slide"] = max(worst["dq slide"],
                                    np.abs(dq[0] - dq_ne).max() / np.abs(dq_ne).max())
            worst["R slide"] = max(worst["R slide"], np.abs(R[0] - R_ne).max()
                                   / max(np.abs(R_ne).max(), F))
            dq_ne, R_ne, _ = ne.sticking(q, u, S, Sd, params)
            worst["dq stick"] = max(worst["dq stick"],
                                    np.abs(dq[1] - dq_ne).max() / np.abs(dq_ne).max())
            worst["R stick"] = max(worst["R stick"], np.abs(R[1] - R_ne).max()
                                   / max(np.abs(R_ne).max(), F))
            W, v_S = s.delassus(t, q)
            W_ne = ne.inverse_inertia_at_S(q, u, S, params)
            worst["W"] = max(worst["W"], np.abs(W - W_ne).max() / np.abs(W_ne).max())
    print({k: f"{v:.1e}" for k, v in worst.items()})
    assert max(worst.values()) < 1e-11


def test_newton_restitution_runs_where_it_is_energy_consistent_and_is_refused_elsewhere():
    rng = np.random.default_rng(29)
    doc, _ = _landing(rng, 0.4, 0.7, "newton", duration=0.3)
    assert simulate(doc).status == "done"                 # W_tn = 0: the sphere's centre
    doc["body"]["center"] = [0.05, 0.0, 0.02]             # now mu |W_tn| > 0 at the impact
    res = simulate(doc)
    assert res.status == "restitution_refused"
    assert not any(ev["kind"] == "impact" for ev in res.events)


def test_friction_zero_runs_the_smooth_model_bit_for_bit():
    """[plane].friction = 0 (given, or absent) and any restitution_model: the model the
    paper's plane runs, and the same numbers."""
    from derive.scene import builtin_doc
    base = simulate(builtin_doc())
    for law in ("energetic", "poisson", "newton"):
        doc = builtin_doc()
        doc["plane"].update(friction=0.0, restitution_model=law)
        res = simulate(doc)
        assert res.model == base.model and res.model != "rough"
        assert np.array_equal(res.t, base.t) and np.array_equal(res.q, base.q)
        assert np.array_equal(res.event_rows, base.event_rows)


def test_rough_sessions_are_independent():
    """Two sessions of the rough model interleaved give what each gives alone (no state
    outside the session)."""
    rng = np.random.default_rng(31)
    doc = _random_rough_doc(rng)
    doc["run"].update(duration=1.5)
    alone = simulate(doc)
    s1, p1 = _session(doc)
    raw = s1.run(p1.scene.t0, p1.scene.duration, p1.start.q0, p1.options, p1.parameters)
    assert np.array_equal(raw.q, alone.model_q)
    assert ctypes.sizeof(ctypes.c_double) == 8


# ---- the rattleback -------------------------------------------------------------------------
def _rattleback(spin, T):
    """A rattleback after Garcia and Hubbard (Proc. R. Soc. A 418, 1988): a long flat
    ellipsoid (0.2, 0.03, 0.02 m) whose mass centre sits 1 cm below the shape's centre; the
    skew of its principal axes (about 0.025 rad) comes from the point, fixed off both axes
    in the xy plane.  Resting on a rough plane (mu_f = 1: it rolls without slipping),
    spinning about the vertical, a small rocking started."""
    axes, center, rp = [0.2, 0.03, 0.02], [0.0, 0.0, 0.01], [0.1, 0.01, 0.0]
    M, m, J = 1.0, 0.05, [2e-4, 1.6e-3, 1.7e-3]
    params = np.array([M, m, *J, G])
    u = np.r_[rp, np.zeros(6)]
    omega = np.array([0.0, 0.02, spin])
    q = np.r_[np.zeros(6), omega, np.eye(3).ravel()]
    D2 = np.diag(np.square(axes))
    s = np.asarray(center) - D2[:, 2] / axes[2]                 # the lowest point, n = e_z
    q[2] = -(s - m / (M + m) * np.asarray(rp))[2]               # S on the plane
    q[3:6] = -ne.velocity_of_S(q, u, s, params)                 # and at rest
    return {"body": {"mass": M, "inertia": J, "shape": "ellipsoid", "semi_axes": axes,
                     "center": center},
            "point": {"mass": m, "law": [repr(x) for x in rp]},
            "plane": {"restitution": 0.0, "friction": 1.0},
            "initial": {"com": [float(x) for x in q[0:3]],
                        "com_velocity": [float(x) for x in q[3:6]], "omega": list(omega)},
            "run": {"duration": T, "method": "lie", "rtol": 1e-10, "atol": 1e-12,
                    "output_dt": 0.01}}


def test_the_rattleback_reverses_its_spin():
    """Spun one way it starts to rock and reverses within 2.5 s (Garcia and Hubbard's
    experiments and theory: a few seconds); spun the other way it keeps its spin for
    several seconds.  It rolls (sticking contact, no slip, no lift-off), so friction does
    no work: the energy stays constant (the point is at rest in the body)."""
    from derive.runtime.motion import energy_balance, motion
    times = {}
    for spin in (-3.0, 3.0):
        res = simulate(_rattleback(spin, 6.0))
        assert res.status == "done"
        assert [ev["kind"] for ev in res.events] == ["impact", "contact"]
        assert res.events[1]["mode"] == "sticking"
        assert res.summary["max_friction_ratio"] < 1.0 and res.min_normal > 0.0
        A = res.q[:, 9:18].reshape(-1, 3, 3)
        w_z = np.einsum("nij,nj->ni", A, res.q[:, 6:9])[:, 2]
        flipped = np.flatnonzero(np.sign(w_z) != np.sign(spin))
        times[spin] = res.t[flipped[0]] if len(flipped) else np.inf
        mo = motion(res)
        sticking = res.modes == 3
        E = mo.E[sticking]
        assert np.abs(E - E[0]).max() < 1e-7 * abs(E[0])
        energy = energy_balance(res, mo)
        assert abs(energy["work_of_friction"]) < 1e-9 * abs(energy["start"])
    print(times)
    assert times[-3.0] < 2.5
    assert times[3.0] > 5.0


# ---- the README's examples -------------------------------------------------------------------
def _example(name):
    from importlib import resources
    return str(resources.files("derive.scene") / "examples" / f"{name}.toml")


def test_the_examples_do_what_the_readme_says():
    """The spherical robot sticks after a few milliseconds and rolls forward (more than 2 m
    in 8 s); the hopper's first impact sticks inside, and it lifts off, lands, slides and
    sticks again.  Both: friction's work negative, the balance closed."""
    from derive.runtime.motion import energy_balance, motion
    robot = simulate(_example("spherical-robot"))
    assert robot.status == "done" and robot.model == "rough"
    stick = next(ev for ev in robot.events if ev["kind"] == "stick")
    assert stick["t"] < 0.02 and set(robot.modes[robot.t > stick["t"]]) == {3}
    assert robot.q[-1][0] > 2.0
    hopper = simulate(_example("hopper"))
    kinds = [ev["kind"] for ev in hopper.events]
    first = next(ev for ev in hopper.events if ev["kind"] == "impact")
    assert first["stage"] == "stick" and first["P_X"] < 0.0
    assert {"lift_off", "stick", "slip"} <= set(kinds) and kinds.count("impact") >= 3
    for res in (robot, hopper):
        balance = energy_balance(res, motion(res))
        assert balance["work_of_friction"] < 0.0
        assert abs(balance["residual"]) < 1e-8 * abs(balance["start"])
