"""Whole runs of several points and rotors (the moments models, issue 32) against things
computed another way.

* An independent SciPy integration of the Newton–Euler formulation
  (tests/newton_euler_moments.py: the carrier, each point under its own force, each rotor
  under its own torque, its transverse moment arbitrary) with its own lowest point of the
  sphere or ellipsoid: random scenes of 0–6 points and 0–3 rotors, flights with impacts
  (impact times and the final state) and persistent contact (the rows of a contact
  phase).
* K about C in fixed axes from the bodies' momenta (Newton–Euler's, the rotors' spin
  included) constant in every flight; the energy balance closed with each drive's work,
  and each drive's power that of Newton–Euler's force or torque.
* Pinocchio: a free flyer with prismatic joints per point and a revolute joint per rotor,
  driven along their laws, integrated by SciPy over a whole flight.
* Closed forms derived here, through derive.simulate, to 1e-9: a body spun up and down by
  two masses on a radial guide, and a body turned in free flight by a rotor.
* One point forced through the moments model agrees with the general model to 1e-12; the
  C's sums of the moments are NumPy's; the bodies' parameters are checked against the
  law; a controller's law is refused on such a law and a push acts on it.
* The rough plane: random scenes judged as ``derive verify robustness`` judges its own
  (no penetration, the friction cone, honest statuses, friction's work never positive,
  no energy gain beyond the drives').
"""
from __future__ import annotations

import copy

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import quad, solve_ivp

import newton_euler_moments as ne
from derive import abi, layout
from derive.runtime import bodies as bm
from derive.runtime.build import DP, library
from derive import simulate as run_scene
from derive.runtime.driver import prepare, simulate
from derive.runtime.events import phases
from derive.runtime.loop import Loop, Segments
from derive.runtime.motion import energy_balance, motion
from derive.runtime.session import Session
from derive.scene import SceneError, builtin_doc, parse_scene
from derive.verify.generators import random_bodies_scene
from derive.verify.judges import judge_run
from test_moments import pinocchio_model

G = layout.GENERAL
E_Z = np.array([0.0, 0.0, 1.0])


# ---- Newton–Euler, whole runs -------------------------------------------------------------
def ne_system(scene, t: float, transverse: float = 0.6) -> ne.System:
    """The bodies at t from the scene's law (the NumPy twin of crt_law.h); each rotor's
    transverse moment ``transverse`` times its axial one (the motion must not depend on
    it)."""
    u = scene.runtime_law.u([t])[:, 0]
    n = len(scene.points)
    points = [ne.Point(m=p.mass, r=u[9 * j:9 * j + 3], v=u[9 * j + 3:9 * j + 6],
                       a=u[9 * j + 6:9 * j + 9]) for j, p in enumerate(scene.points)]
    rotors = [ne.Rotor(axis=np.array(r.axis), I=r.inertia, It=transverse * r.inertia,
                       rate=u[9 * n + 3 * k + 1], acc=u[9 * n + 3 * k + 2])
              for k, r in enumerate(scene.rotors)]
    return ne.System(M=scene.M, J=np.array(scene.J), g=scene.g, points=points, rotors=rotors)


def lowest(scene, n, omega):
    """OS and its rate as the body turns (body axes), of a sphere or an ellipsoid,
    written here: OS = c - D n / sqrt(n D n), D = diag(semi-axes^2), n' = n x omega."""
    D = np.asarray(scene.size, dtype=float) ** 2 * np.ones(3)
    c = np.asarray(scene.center, dtype=float)
    nd, k = D * n, np.sqrt(n @ (D * n))
    dn = np.cross(n, omega)
    return c - nd / k, -(D * dn) / k + nd * (n @ (D * dn)) / k ** 3


def ne_gap(scene, t, q) -> float:
    sys_ = ne_system(scene, t)
    A = q[9:18].reshape(3, 3)
    s, _ = lowest(scene, A[2], q[6:9])
    return q[2] + (A @ (s - sys_.oc()[0]))[2]


def ne_bouncing(scene, q0, t0, t1, rtol=1e-12) -> tuple[list, np.ndarray]:
    """Flights and impacts (Newton's restitution) from (t0, q0) to t1: the impact times
    and the final state."""
    def rhs(t, q):
        return ne.flight(ne_system(scene, t), q)

    def hit(t, q):
        return ne_gap(scene, t, q)
    hit.terminal, hit.direction = True, -1
    t, q, times = t0, np.array(q0, dtype=float), []
    while t < t1:
        sol = solve_ivp(rhs, (t, t1), q, method="DOP853", rtol=rtol, atol=1e-13,
                        events=hit)
        if sol.status != 1:
            return times, sol.y[:, -1]
        t, q = float(sol.t_events[0][0]), sol.y_events[0][0]
        sys_ = ne_system(scene, t)
        s, _ = lowest(scene, q[9:18].reshape(3, 3)[2], q[6:9])
        q, _ = ne.impact(sys_, q, s, scene.e)
        times.append(t)
    return times, q


def bouncing_scene(rng, n_points, n_rotors) -> dict:
    doc = random_bodies_scene(rng, 1.2, method="lie", n_points=n_points, n_rotors=n_rotors)
    doc["plane"] = {"restitution": float(rng.uniform(0.6, 0.9))}
    doc["initial"]["com"][2] = 0.2 + float(doc["initial"]["com"][2]) * 0.5
    doc["run"].update(duration=1.2, rtol=1e-12, atol=1e-14)
    return doc


# seeds whose runs bounce 3 to 6 times, no two impacts closer than 0.06 s (random scenes
# whose impacts accumulate are the contact test's)
@pytest.mark.parametrize("n_points,n_rotors,seed", [(0, 3, 3), (2, 1, 3), (6, 0, 4),
                                                     (3, 3, 2)])
def test_bouncing_runs_match_newton_euler(n_points, n_rotors, seed):
    rng = np.random.default_rng(seed)
    doc = bouncing_scene(rng, n_points, n_rotors)
    res = simulate(doc)
    assert res.model == "moments" and res.status == "done"
    sc = res.scene
    times, q_end = ne_bouncing(sc, res.q[0], sc.t0, sc.t0 + sc.duration)
    assert len(times) == len(res.impacts) >= 1, (times, res.impacts[:, 0])
    assert np.max(np.abs(np.array(times) - res.impacts[:, 0])) < 1e-8
    scale = np.abs(q_end).max() + 1.0
    assert np.max(np.abs(q_end - res.q[-1])) < 1e-7 * scale


def test_contact_phase_matches_newton_euler():
    """A body that lands (e = 0) and rests while its points and rotors move: the rows of
    its contact phase against Newton–Euler's contact (N at S, the normal acceleration of
    the material point at S zero) integrated from the phase's first row."""
    rng = np.random.default_rng(8)
    doc = random_bodies_scene(rng, 1.5, method="dop853", n_points=3, n_rotors=2)
    doc["plane"] = {"restitution": 0.0}
    doc["initial"]["com"][2] = 0.2 + float(doc["initial"]["com"][2]) * 0.4
    doc["run"].update(duration=1.5, rtol=1e-12, atol=1e-14)
    res = simulate(doc)
    sc = res.scene
    kinds = [ev["kind"] for ev in res.events]
    assert "contact" in kinds, kinds
    start = next(ev["t"] for ev in res.events if ev["kind"] == "contact")
    end = next((ev["t"] for ev in res.events if ev["kind"] == "lift_off" and ev["t"] > start),
               sc.t0 + sc.duration)
    rows = np.flatnonzero((res.t > start) & (res.t < end)
                          & (res.row_kind == abi.ROW_KIND["step"]))
    assert len(rows) > 5
    first = int(np.flatnonzero(res.t == start)[-1])          # the row after the event

    def rhs(t, q):
        sys_ = ne_system(sc, t)
        s, sdot = lowest(sc, q[9:18].reshape(3, 3)[2], q[6:9])
        return ne.contact(sys_, q, s, sdot)[0]
    sol = solve_ivp(rhs, (start, res.t[rows[-1]]), res.q[first], method="DOP853", rtol=1e-12,
                    atol=1e-13, dense_output=True)
    got = sol.sol(res.t[rows]).T
    scale = np.abs(res.q[rows]).max() + 1.0
    assert np.max(np.abs(got - res.q[rows])) < 1e-8 * scale
    N = [ne.contact(ne_system(sc, t), q, *lowest(sc, q[9:18].reshape(3, 3)[2], q[6:9]))[1]
         for t, q in zip(res.t[rows], res.q[rows])]
    assert min(N) > 0.0


def test_fixed_frame_momentum_is_constant_in_every_flight():
    """K about C in fixed axes, from Newton–Euler's sum over the bodies (the rotors' spin
    included), between events: to round-off with the Lie method, to the tolerance with
    DOP853."""
    rng = np.random.default_rng(21)
    for method, bound in (("lie", 1e-12), ("dop853", 1e-8)):
        doc = bouncing_scene(rng, 3, 2)
        doc["run"].update(method=method, rtol=1e-10, atol=1e-12)
        res = simulate(doc)
        worst = 0.0
        for a, b, state in phases(res):
            K = np.array([ne.kinetic_moment_fixed(ne_system(res.scene, t), q)
                          for t, q in zip(res.t[a:b], res.q[a:b])])
            if state == "flight" and len(K) > 1:
                worst = max(worst, np.abs(K - K[0]).max() / np.linalg.norm(K[0]))
        assert worst < bound, (method, worst)
        # and the runtime's own reading of it (derive.runtime.bodies) is the same K
        K_run = res.momentum["K_fixed"]
        K_ne = np.array([ne.kinetic_moment_fixed(ne_system(res.scene, t), q)
                         for t, q in zip(res.t, res.q)])
        assert np.abs(K_run - K_ne).max() < 1e-12 * np.abs(K_ne).max()


# ---- energy --------------------------------------------------------------------------------
def ne_forces(sys_: ne.System, q) -> tuple[np.ndarray, np.ndarray]:
    """Newton–Euler's forces on the points and torques on the rotors in flight."""
    K, _, b = ne._system(sys_, q)
    x = np.linalg.solve(K, b)
    n = len(sys_.points)
    return x[6:6 + 3 * n].reshape(-1, 3), x[6 + 3 * n:].reshape(-1, 3)


def test_each_drives_power_is_newton_eulers_force_times_its_rate():
    rng = np.random.default_rng(4)
    doc = random_bodies_scene(rng, 1.0, n_points=4, n_rotors=3)
    doc.pop("plane")
    res = simulate(doc)
    mo = motion(res)
    P = bm.drive_powers(res.scene, mo.bodies, mo.omega,
                        bm.omega_rate_in_flight(res.scene, mo.bodies, mo.omega))
    for i in range(0, len(res.t), max(1, len(res.t) // 12)):
        sys_ = ne_system(res.scene, res.t[i])
        F, T = ne_forces(sys_, res.q[i])
        want = [f @ p.v for f, p in zip(F, sys_.points)] + \
            [tk @ (r.rate * r.axis) for tk, r in zip(T, sys_.rotors)]
        assert np.allclose(P[:, i], want, rtol=1e-10, atol=1e-10 * np.abs(want).max())


@pytest.mark.parametrize("seed,e", [(5, 0.7), (6, 0.0)])
def test_energy_balance_closes_with_each_drives_work(seed, e):
    """Flights, impacts and (e = 0) resting contact: the energy's change is the
    impacts' jumps plus each drive's work, to the integration's tolerance; the split per
    body adds up."""
    rng = np.random.default_rng(seed)
    doc = random_bodies_scene(rng, 2.0, method="lie", n_points=3, n_rotors=2)
    doc["plane"] = {"restitution": e}
    doc["run"].update(duration=2.0, rtol=1e-11, atol=1e-13)
    res = simulate(doc)
    mo = motion(res)
    bal = energy_balance(res, mo)
    scale = float(np.max(np.abs(mo.E)))
    assert abs(bal["residual"]) < 1e-8 * scale, bal
    drives = bal["drive_work_by_body"]
    assert list(drives) == [b.name for b in (*res.scene.points, *res.scene.rotors)]
    total = bal["drive_work_in_flight"] + bal["drive_work_in_contact"] \
        + bal["drive_work_at_impacts"]
    assert abs(sum(drives.values()) - total) < 1e-12 * scale
    split = bal["kinetic_by_body"]
    assert abs(sum(v[0] for v in split.values()) - bal["kinetic_start"]) < 1e-12 * scale
    if e == 0.0:
        assert res.stats["contacts"] >= 1 and bal["drive_work_in_contact"] != 0.0


# ---- Pinocchio --------------------------------------------------------------------------
def test_free_flights_match_pinocchio():
    """The base of a Pinocchio model (free flyer, prismatic joints per point, a revolute
    joint per rotor) integrated by SciPy with the joints driven along their laws: the
    attitude and C at the end of a 1 s flight, to 1e-9."""
    rng = np.random.default_rng(31)
    for n_points, n_rotors in ((3, 0), (2, 2)):
        doc = random_bodies_scene(rng, 1.0, method="lie", n_points=n_points,
                                  n_rotors=n_rotors)
        doc.pop("plane")
        doc["run"].update(duration=1.0, rtol=1e-12, atol=1e-14)
        res = simulate(doc)
        sc = res.scene
        model = pinocchio_model(ne_system(sc, sc.t0))
        data = model.createData()

        def joints(t):
            sys_ = ne_system(sc, t)
            u = sc.runtime_law.u([t])[:, 0]
            psi = [u[layout.rotor_slice(len(sc.points), k)][0] for k in range(len(sc.rotors))]
            return (np.r_[[x for p in sys_.points for x in p.r], psi],
                    np.r_[[x for p in sys_.points for x in p.v], [r.rate for r in sys_.rotors]],
                    np.r_[[x for p in sys_.points for x in p.a], [r.acc for r in sys_.rotors]])

        def rhs(t, y):
            R = y[3:12].reshape(3, 3)
            qj, vj, aj = joints(t)
            qp = np.r_[y[:3], pin.Quaternion(R).coeffs(), qj]
            vp = np.r_[y[12:18], vj]
            Mq = pin.crba(model, data, qp)
            Mq = np.triu(Mq) + np.triu(Mq, 1).T
            h = pin.rnea(model, data, qp, vp, np.zeros(model.nv))
            ab = np.linalg.solve(Mq[:6, :6], -(h[:6] + Mq[:6, 6:] @ aj))
            w = y[15:18]
            return np.r_[R @ y[12:15], (R @ ne.skew(w)).ravel(), ab]
        q0 = res.q[0]
        sys0 = ne_system(sc, sc.t0)
        A0 = q0[9:18].reshape(3, 3)
        y0 = np.r_[q0[:3] - A0 @ sys0.oc()[0], A0.ravel(), sys0.velocity_of_O(q0), q0[6:9]]
        sol = solve_ivp(rhs, (sc.t0, sc.t0 + sc.duration), y0, method="DOP853", rtol=1e-12,
                        atol=1e-13)
        y = sol.y[:, -1]
        R = y[3:12].reshape(3, 3)
        C = y[:3] + R @ ne_system(sc, sc.t0 + sc.duration).oc()[0]
        q1 = res.q[-1]
        assert np.abs(R - q1[9:18].reshape(3, 3)).max() < 1e-9
        assert np.abs(C - q1[:3]).max() < 1e-9 * (1 + np.abs(q1[:3]).max())


# ---- closed forms through the runtime -----------------------------------------------------
def _free(doc_points=(), doc_rotors=(), omega=(0.0, 0.0, 2.0), duration=2.0):
    return {"name": "closed-form", "body": {"mass": 2.0, "inertia": [0.4, 0.5, 0.6],
                                            "shape": "none"},
            **({"point": list(doc_points)} if doc_points else {}),
            **({"rotor": list(doc_rotors)} if doc_rotors else {}),
            "initial": {"com": [0.0, 0.0, 10.0], "com_velocity": [0.3, 0.0, 1.0],
                        "omega": list(omega)},
            "run": {"duration": duration, "rtol": 1e-12, "atol": 1e-14, "output_dt": 0.1}}


def _turn(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_spin_up_by_two_masses_on_a_radial_guide():
    """Two masses m at +-r(t) e_x, r = r0 + b sin(nu t), the body turning about its
    principal z axis: s = 0, h = 0, Theta_zz = 2 m r^2, so K_z = (J_z + 2 m r^2) omega_z
    is constant, omega_z = K_z/(J_z + 2 m r(t)^2) and the body turns about z by the
    integral of omega_z; C on its parabola."""
    m, r0, b, nu, w0, Jz = 0.3, 0.5, 0.3, 3.0, 2.0, 0.6
    law = f"{r0} + {b}*sin({nu}*t)"
    doc = _free([{"mass": m, "law": [law, "0", "0"]},
                 {"mass": m, "law": [f"-({law})", "0", "0"]}], omega=(0.0, 0.0, w0))
    res = simulate(doc)
    assert res.model == "moments" and res.status == "done"

    def r(t):
        return r0 + b * np.sin(nu * t)
    Kz = (Jz + 2 * m * r(0.0) ** 2) * w0
    worst = 0.0
    for t, q in zip(res.t, res.q):
        phi = quad(lambda s: Kz / (Jz + 2 * m * r(s) ** 2), 0.0, t, epsabs=1e-13,
                   epsrel=1e-13)[0]
        want_c = [0.3 * t, 0.0, 10.0 + t - 4.905 * t * t, 0.3, 0.0, 1.0 - 9.81 * t]
        worst = max(worst, abs(q[8] - Kz / (Jz + 2 * m * r(t) ** 2)), *np.abs(q[6:8]),
                    np.abs(q[9:18] - _turn(phi).ravel()).max(), np.abs(q[:6] - want_c).max())
    assert worst < 1e-9, worst


def test_a_rotor_turns_the_body_in_free_flight():
    """A rotor of axial moment I on the principal z axis, psi = Omega t + c sin(nu t):
    K_z = J_z omega_z + I psi' is constant (J_z with the rotor locked), omega_z = (K_z - I
    psi')/J_z and the body turns by phi = (K_z t - I (psi(t) - psi(0)))/J_z."""
    I, Omega, c, nu, w0, Jz = 0.04, 40.0, 3.0, 5.0, 0.7, 0.6
    doc = _free(doc_rotors=[{"axis": [0.0, 0.0, 1.0], "inertia": I,
                             "law": f"{Omega}*t + {c}*sin({nu}*t)"}], omega=(0.0, 0.0, w0))
    res = simulate(doc)
    assert res.model == "moments" and res.status == "done"

    def psi(t):
        return Omega * t + c * np.sin(nu * t), Omega + c * nu * np.cos(nu * t)
    Kz = Jz * w0 + I * psi(0.0)[1]
    worst = 0.0
    for t, q in zip(res.t, res.q):
        phi = (Kz * t - I * (psi(t)[0] - psi(0.0)[0])) / Jz
        worst = max(worst, abs(q[8] - (Kz - I * psi(t)[1]) / Jz), *np.abs(q[6:8]),
                    np.abs(q[9:18] - _turn(phi).ravel()).max())
    assert worst < 1e-9, worst


# ---- one point, and the runtime's own checks -------------------------------------------
@pytest.mark.parametrize("method", ["lie", "rk4"])
def test_one_point_through_the_moments_model_is_the_general_model(method):
    doc = builtin_doc()
    doc["run"].update(method=method, output_dt=0.01)
    a = simulate(doc)
    doc["run"]["model"] = "moments"
    b = simulate(doc)
    assert (a.model, b.model) == ("general", "moments") and b.why.startswith("forced")
    assert len(a.t) == len(b.t) and np.array_equal(a.row_kind, b.row_kind)
    assert np.abs(a.t - b.t).max() < 1e-12 * a.t[-1]
    assert np.abs(a.q - b.q).max() < 1e-12 * np.abs(a.q).max()
    assert np.abs(a.event_rows - b.event_rows).max() < 1e-12 * np.abs(a.event_rows).max()


def test_the_c_sums_the_moments_as_numpy_and_checks_the_bodies():
    rng = np.random.default_rng(9)
    doc = random_bodies_scene(rng, 1.0, n_points=5, n_rotors=3)
    prep = prepare(doc)
    s = Session(library("moments"))
    s.set_law(prep.scene.runtime_law)
    s.init(prep.options, prep.parameters, prep.scene.t0, prep.start.q0)
    t = np.linspace(0.0, 1.0, 7)
    u = np.zeros((len(t), s.library.lib.crt_u_width()))
    s.library.lib.crt_eval_u_rows(s.handle, len(t), t.ctypes.data_as(DP), u.ctypes.data_as(DP))
    want = bm.moments(bm.along(prep.scene, t)).vector()
    assert u.shape == (len(t), layout.MOMENTS.nq)
    assert np.abs(u - want).max() < 1e-13 * np.abs(want).max()
    P = abi.PRM
    for name, value, named in (("m", prep.parameters[P["m"]] * 1.01, "m"),
                               ("n_points", 4.0, "n_points"), ("n_rotors", 2.0, "n_rotors"),
                               ("a_2_y", prep.parameters[P["a_2_y"]] + 0.01, "a_2_x"),
                               ("I_1", -1.0, "I_1"), ("m_3", -0.5, "m_3")):
        prm = prep.parameters.copy()
        prm[P[name]] = value
        with pytest.raises(SceneError, match=rf"the parameter {named} = .*the law's bodies"):
            s.init(prep.options, prm, prep.scene.t0, prep.start.q0)


def test_a_controller_is_refused_and_a_push_acts_on_several_bodies():
    rng = np.random.default_rng(10)
    doc = random_bodies_scene(rng, 1.0, n_points=2, n_rotors=1)
    prep = prepare(doc)
    s = Session(library(prep.kind))
    s.set_law(prep.scene.runtime_law)

    def controller(call):
        return Segments(np.array([call.t, call.t + 1.0]), np.zeros((1, 3, 4)))
    with pytest.raises(ValueError, match="refused: bodies"):
        s.run(prep.scene.t0, 1.0, prep.start.q0, prep.options, prep.parameters,
              loop=Loop(controller))
    pushed = copy.deepcopy(doc)
    pushed["disturbance"] = {"pushes": [{"time": 0.2, "impulse": [0.0, 0.3, 0.1],
                                         "at": [0.05, 0.0, 0.0]}]}
    res = run_scene(pushed)
    assert res.model == prep.kind and res.stats["pushes"] == 1
    with pytest.raises(SceneError, match=r"^\[control\]: closes its loop"):
        parse_scene({**doc, "control": {"mode": "hop"}})


def test_a_study_of_several_bodies_runs_as_its_variants_one_by_one():
    """simulate_many over a scene of several bodies (its variants read in bulk, run by
    crt_run_many on the bodies' law) gives each variant's own run."""
    from derive.runtime.batch import simulate_many
    rng = np.random.default_rng(13)
    doc = bouncing_scene(rng, 2, 1)
    variants = [{"plane.restitution": e, "body.mass": M} for e in (0.5, 0.8)
                for M in (doc["body"]["mass"], 1.5)]
    out = simulate_many(doc, variants)
    assert len(out.rows) == 4
    for row, change in zip(out.rows, variants):
        one = copy.deepcopy(doc)
        one["plane"]["restitution"] = change["plane.restitution"]
        one["body"]["mass"] = change["body.mass"]
        res = simulate(one)
        assert (row["model"], row["status"]) == ("moments", "done")
        assert (row["impacts"], row["steps"]) == (res.stats["impacts"], res.stats["steps"])


# ---- the rough plane: properties over random scenes ---------------------------------------
def test_random_scenes_on_a_rough_plane_keep_their_properties():
    """0-6 points and 0-3 rotors, mu_f 0.05 to 1.5, landing, sliding, sticking: judged
    as derive verify robustness judges its scenes (no penetration beyond 1e-9 of the
    size, the friction cone in every contact row, an honest status, |K| in flight,
    friction's work never positive, no energy gain beyond the drives')."""
    rng = np.random.default_rng(12)
    verdicts = []
    for i, (n_points, n_rotors) in enumerate(((0, 0), (0, 3), (2, 1), (6, 2), (3, 3), (1, 1),
                                              (5, 0), (4, 2), (2, 3), (0, 1), (6, 3), (3, 0))):
        doc = random_bodies_scene(rng, 2.0, rough=True, n_points=n_points, n_rotors=n_rotors)
        doc["run"]["duration"] = min(doc["run"]["duration"], 2.0)
        if doc["run"]["method"] == "rk4":
            doc["run"]["step"] = 1e-3
        res = simulate(doc)
        size = doc["body"].get("radius") or max(doc["body"]["semi_axes"])
        verdicts.append((i, res.model, *judge_run(res, size)))
    assert all(v[2] in ("ok", "painleve") for v in verdicts), verdicts
    assert {v[1] for v in verdicts} == {"moments_rough"}


# ---- the README's examples ----------------------------------------------------------------
def _example(name: str) -> str:
    from importlib import resources
    return str(resources.files("derive.scene") / "examples" / f"{name}.toml")


def test_the_examples_of_several_bodies_do_what_the_readme_says():
    capsule = simulate(_example("two-mass-capsule"))
    bal = energy_balance(capsule, motion(capsule))
    assert capsule.model == "moments_rough" and capsule.status == "done"
    assert 0.16 < capsule.q[-1][0] < 0.17 and abs(capsule.q[-1][1]) < 1e-9   # 16.5 cm on +x
    assert capsule.stats["sticks"] >= 20 and capsule.stats["slips"] >= 20
    assert abs(bal["residual"]) < 1e-9 and bal["work_of_friction"] < 0
    sphere = simulate(_example("rotor-sphere"))
    bal = energy_balance(sphere, motion(sphere))
    assert sphere.model == "moments_rough" and sphere.status == "done"
    assert sphere.stats["slips"] == 0 and np.hypot(*sphere.slip.T).max() < 1e-5
    assert sphere.q[-1][0] < -0.8 and sphere.q[-1][1] > 0.5        # off along -x, then +y
    assert abs(bal["residual"]) < 1e-8 and len(bal["drive_work_by_body"]) == 3
