"""Peer check against Pinocchio (PyPI ``pin``), a rigid-body dynamics library nobody
here wrote: its algorithms (CRBA, RNEA, centroidal momentum, impulse dynamics) against
the generated C, pointwise and over whole bouncing runs.

The system in Pinocchio: a free-flyer (the carrier: mass M, principal inertia J at its
centre O) and a body of mass m and no rotational inertia on a three-axis translation
joint from O (the point P, its joint position OP in body axes).  The point's joint
motion is prescribed, so the carrier's acceleration solves the free-flyer rows of
``M(q) a + h(q, v) = tau`` with the point's rows' acceleration known:

    M_bb a_b = -(h_b + M_bp a_r)

(the angular part of ``a_b`` is omega' in body axes).  At an impact the point's relative
velocity is held, so the carrier and the point move as one rigid body during the
impulse: Pinocchio's ``impulseDynamics`` of that body, with the contact row of the
plane's normal at S and restitution e.

Checks: E1.2 and E1.7 (the flight right-hand side), E1.4 in fixed axes (Pinocchio's
centroidal angular momentum), E1.10-E1.16 (the impact map), and whole runs of
``derive.simulate`` on random bouncing scenes against SciPy integrating Pinocchio's
dynamics with a terminal event and the impulse at each impact.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import derive
from cases import cases, rel_err, rotation_from_quaternion
from derive.clib import load_generated

N_STATES = 200
TOL = 1e-12
MAX_IMPACTS = 40          # a peer run with more stops (impacts accumulating: not its job)


@pytest.fixture(scope="module")
def generated():
    return load_generated()


def carrier_model(M, m, J, g, frozen_at=None, contact_at=None):
    """The carrier (free-flyer) and the point on a translation joint; ``frozen_at``: the
    point fixed at that OP instead (the rigid body of an impact); ``contact_at``: a
    frame on the carrier at that point (body axes)."""
    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, -g])
    root = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "carrier")
    body = pin.Inertia(M, np.zeros(3), np.diag(J))
    if frozen_at is None:
        model.appendBodyToJoint(root, body, pin.SE3.Identity())
        point = model.addJoint(root, pin.JointModelTranslation(), pin.SE3.Identity(), "P")
        model.appendBodyToJoint(point, pin.Inertia(m, np.zeros(3), np.zeros((3, 3))),
                                pin.SE3.Identity())
    else:
        model.appendBodyToJoint(root, body + pin.Inertia(m, np.asarray(frozen_at, float),
                                                         np.zeros((3, 3))),
                                pin.SE3.Identity())
    frame = None
    if contact_at is not None:
        frame = model.addFrame(pin.Frame("S", root, pin.SE3(np.eye(3), np.asarray(
            contact_at, float)), pin.FrameType.OP_FRAME))
    return model, frame


def base_state(A, R_C, V_C, omega, r, v, nu):
    """Pinocchio's free-flyer configuration and velocity (O, quaternion; O' and omega in
    body axes) from the centre of mass C of the system (E1.8a)."""
    O = R_C - nu * A @ r
    V_O = V_C - nu * A @ (np.cross(omega, r) + v)
    return np.r_[O, pin.Quaternion(A).coeffs()], np.r_[A.T @ V_O, omega]


def base_acceleration(model, data, qb, vb, r, v, acc):
    q, vel = np.r_[qb, r], np.r_[vb, v]
    Mq = pin.crba(model, data, q)
    Mq = np.triu(Mq) + np.triu(Mq, 1).T
    h = pin.rnea(model, data, q, vel, np.zeros(model.nv))
    return np.linalg.solve(Mq[:6, :6], -(h[:6] + Mq[:6, 6:] @ acc))


def impulse(c_M, c_m, J, g, A, qb, vb, r, s, e):
    """Pinocchio's impulse dynamics of the frozen body: (velocity after, impulse)."""
    model, frame = carrier_model(c_M, c_m, J, g, frozen_at=r, contact_at=s)
    data = model.createData()
    pin.computeJointJacobians(model, data, qb)
    pin.updateFramePlacements(model, data)
    normal_row = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)[2:3]
    after = pin.impulseDynamics(model, data, qb, vb, normal_row, e)
    return np.array(after), float(data.impulse_c[0])


# ---- pointwise: the generated C against Pinocchio at random states ---------------------
def test_flight_rhs_matches_pinocchio(generated):
    """E1.2 and E1.7: omega' (body axes) and the acceleration of C."""
    worst = 0.0
    for c in cases(N_STATES, seed=31):
        model, _ = carrier_model(c.M, c.m, c.J, c.g)
        data = model.createData()
        nu = c.m / (c.M + c.m)
        qb, vb = base_state(c.A, c.R_C, c.V_C, c.omega, c.r, c.v, nu)
        ab = base_acceleration(model, data, qb, vb, c.r, c.v, c.acc)
        pin.centerOfMass(model, data, np.r_[qb, c.r], np.r_[vb, c.v], np.r_[ab, c.acc])
        (dq,) = generated["general_flight_rhs"](c.q_general, c.u, c.p)
        worst = max(worst, rel_err(dq[6:9], ab[3:6]), rel_err(dq[3:6], data.acom[0]))
    print(f"max relative difference {worst:.2e}")
    assert worst < TOL


def test_kinetic_moment_matches_pinocchio(generated):
    """E1.4 in fixed axes against Pinocchio's centroidal angular momentum (about the
    centre of mass C, world axes), and the momentum (m + M) V_C."""
    worst = 0.0
    for c in cases(N_STATES, seed=37):
        model, _ = carrier_model(c.M, c.m, c.J, c.g)
        data = model.createData()
        qb, vb = base_state(c.A, c.R_C, c.V_C, c.omega, c.r, c.v, c.m / (c.M + c.m))
        hg = pin.computeCentroidalMomentum(model, data, np.r_[qb, c.r], np.r_[vb, c.v])
        (K_fixed,) = generated["fixed_kinetic_moment"](c.A.ravel(), c.omega, c.u, c.p)
        (K_body,) = generated["general_kinetic_moment"](c.q_general, c.u, c.p)
        worst = max(worst, rel_err(K_fixed, hg.angular), rel_err(c.A @ K_body, hg.angular),
                    rel_err((c.M + c.m) * c.V_C, hg.linear))
    print(f"max relative difference {worst:.2e}")
    assert worst < TOL


def test_impact_matches_pinocchio(generated):
    """E1.10-E1.16: omega+, V_C+ and the impulse I against Pinocchio's impulse dynamics
    (the rigid body of carrier and point; restitution on the normal row at S)."""
    worst = 0.0
    for c in cases(N_STATES, seed=41):
        nu = c.m / (c.M + c.m)
        qb, vb = base_state(c.A, c.R_C, c.V_C, c.omega, c.r, c.v, nu)
        after, I = impulse(c.M, c.m, c.J, c.g, c.A, qb, vb, c.r, c.s, c.e)
        q_plus, (ours_I,) = generated["general_impact"](c.q_general, c.u, c.s, c.p, c.e)
        omega = after[3:6]
        V_C = c.A @ after[:3] + nu * c.A @ (np.cross(omega, c.r) + c.v)
        worst = max(worst, rel_err(q_plus[6:9], omega), rel_err(q_plus[3:6], V_C),
                    rel_err([ours_I], [I]), rel_err(q_plus[9:], c.A.ravel()))
    print(f"max relative difference {worst:.2e}")
    assert worst < TOL


# ---- whole runs: derive.simulate against SciPy integrating Pinocchio's dynamics ---------
class HarmonicLaw:
    """x_k = a_k sin(w_k t + p_k) + b_k: the scene's text and its exact jets."""

    def __init__(self, rng):
        self.a = rng.uniform(0.02, 0.12, 3)
        self.w = rng.uniform(1.0, 6.0, 3)
        self.p = rng.uniform(0.0, 2 * np.pi, 3)
        self.b = rng.uniform(-0.05, 0.05, 3)

    def texts(self):
        return [f"{float(a)!r}*sin({float(w)!r}*t + {float(p)!r}) + {float(b)!r}"
                for a, w, p, b in zip(self.a, self.w, self.p, self.b)]

    def __call__(self, t):
        th = self.w * t + self.p
        s, co = np.sin(th), np.cos(th)
        return (self.a * s + self.b, self.a * self.w * co, -self.a * self.w ** 2 * s)


def random_scene(rng, shape="sphere"):
    law = HarmonicLaw(rng)
    M, m = float(rng.uniform(0.5, 3.0)), float(rng.uniform(0.05, 0.6))
    second = rng.uniform(0.05, 0.4, 3)
    J = np.array([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
    radius = float(rng.uniform(0.3, 0.6))
    center = rng.uniform(-0.08, 0.08, 3)
    quat = rng.normal(size=4)
    quat /= np.linalg.norm(quat)
    body = {"mass": M, "inertia": J.tolist(), "shape": shape, "center": center.tolist()}
    if shape == "sphere":
        body["radius"] = radius
    else:
        body["semi_axes"] = rng.uniform(0.25, 0.6, 3).tolist()
    doc = {"name": "pinocchio-peer", "body": body,
           "point": {"mass": m, "law": law.texts()},
           "plane": {"restitution": float(rng.uniform(0.6, 0.95))},
           "initial": {"com": [0.0, 0.0, float(rng.uniform(0.9, 1.3))],
                       "com_velocity": rng.normal(0.0, 0.5, 3).tolist(),
                       "omega": rng.normal(0.0, 1.5, 3).tolist(), "quaternion": quat.tolist()},
           "run": {"duration": 1.6, "rtol": 1e-12, "atol": 1e-14,
                   "g": 9.81, "output_dt": 0.1, "outputs": ["pose", "impacts"]}}
    return doc, law


def lowest_point(body, n):
    """S in body axes for the upward vertical ``n`` (body axes): the sphere's centre
    less its radius along n; the ellipsoid's by its support function,
    ``c - D^2 n / sqrt(n^T D^2 n)``, D the semi-axes (geometry, not the derived form)."""
    center = np.asarray(body["center"], float)
    if body["shape"] == "sphere":
        return center - body["radius"] * n
    d2 = np.asarray(body["semi_axes"], float) ** 2
    return center - d2 * n / np.sqrt(n @ (d2 * n))


def pinocchio_run(doc, law, times, t_end=None):
    """SciPy DOP853 on Pinocchio's dynamics: state (O, quaternion x y z w, O' and omega
    in body axes); a terminal event at the shape's lowest point, the impulse there."""
    body, point = doc["body"], doc["point"]
    M, m, J = body["mass"], point["mass"], np.array(body["inertia"])
    g, e = doc["run"]["g"], doc.get("plane", {}).get("restitution")
    nu = m / (M + m)
    model, _ = carrier_model(M, m, J, g)
    data = model.createData()
    ini = doc["initial"]
    w, x, y, z = ini["quaternion"]
    A0 = rotation_from_quaternion(np.array([w, x, y, z]))
    r0, v0, _ = law(0.0)
    qb, vb = base_state(A0, np.array(ini["com"]), np.array(ini["com_velocity"]),
                        np.array(ini["omega"]), r0, v0, nu)
    state = np.r_[qb, vb]

    def rotation(s):
        quat = s[3:7] / np.linalg.norm(s[3:7])
        return pin.Quaternion(quat).toRotationMatrix(), quat

    def rhs(t, s):
        A, quat = rotation(s)
        r, v, acc = law(t)
        ab = base_acceleration(model, data, np.r_[s[:3], quat], s[7:], r, v, acc)
        omega, qv, qw = s[10:13], s[3:6], s[6]
        dquat = 0.5 * np.r_[qw * omega + np.cross(qv, omega), -qv @ omega]
        return np.r_[A @ s[7:10], dquat, ab]

    def gap(t, s):
        if t <= t0 + 1e-12:         # the restart at an impact: S leaves the plane there
            return 1.0
        A, _ = rotation(s)
        return s[2] + (A @ lowest_point(body, A[2]))[2]
    gap.terminal, gap.direction = True, -1
    events = gap if "plane" in doc else None

    t0, impacts, pieces = 0.0, [], []
    t_end = doc["run"]["duration"] if t_end is None else t_end
    while t0 < t_end:
        sol = solve_ivp(rhs, (t0, t_end), state, method="DOP853", rtol=1e-12, atol=1e-14,
                        events=events, dense_output=True)
        pieces.append((t0, sol.t[-1], sol.sol))
        if sol.status != 1:
            break
        if len(impacts) == MAX_IMPACTS:
            raise RuntimeError(f"more than {MAX_IMPACTS} impacts: the scene accumulates them")
        t0, state = sol.t[-1], sol.y[:, -1].copy()
        A, quat = rotation(state)
        r, _, _ = law(t0)
        s_body = lowest_point(body, A[2])              # S, body axes
        after, I = impulse(M, m, J, g, A, np.r_[state[:3], quat], state[7:], r, s_body, e)
        state[7:] = after
        impacts.append((t0, I))
    rows = []
    for t in times:
        lo, hi, dense = next(p for p in pieces if p[0] <= t <= p[1] + 1e-12)
        s = dense(min(t, hi))
        A, _ = rotation(s)
        r, v, _ = law(t)
        omega = s[10:13]
        C = s[:3] + nu * A @ r
        V_C = A @ s[7:10] + nu * A @ (np.cross(omega, r) + v)
        rows.append(np.r_[C, V_C, omega, A.ravel()])
    return np.array(rows), np.array(impacts)


@pytest.mark.parametrize("method", ["lie", "dop853"])
@pytest.mark.parametrize("shape", ["sphere", "ellipsoid"])
@pytest.mark.parametrize("seed", range(10))
def test_bouncing_runs_match_pinocchio(seed, shape, method):
    """derive.simulate on a random bouncing scene (offset sphere, 3-D law, spinning
    carrier) against SciPy with Pinocchio's dynamics and impulses: the state on the
    output grid and every impact time and impulse.  Seed 6 accumulates its impacts (33
    of them, then resting contact; 3 of the first 40 seeds do): compared up to its first
    impact slower than 1 cm/s; the accumulation (flights of microseconds) and the
    contact that follows are not the flight-only peer's to model."""
    doc, law = random_scene(np.random.default_rng(1000 + seed), shape)
    doc["run"]["method"] = method
    res = derive.simulate(doc)
    assert res.status == "done"
    contact = [e["t"] for e in res.events if e["kind"] == "impact" and
               any(c["kind"] == "contact" for c in res.events) and abs(e["v_minus"]) < 0.01]
    t_stop = contact[0] if contact else doc["run"]["duration"]
    rows = (res.row_kind == 0) & (res.t <= t_stop)
    t, ours = res.t[rows], res.general[rows]
    peer, impacts = pinocchio_run(doc, law, t, t_end=t_stop)
    impacts = impacts[impacts[:, 0] < t_stop - 1e-9] if contact else impacts
    mine = res.impacts[res.impacts[:, 0] < t_stop - 1e-9] if contact else res.impacts
    assert len(impacts) >= 1, "the scene should bounce"
    assert len(mine) == len(impacts)
    dt = np.max(np.abs(mine[:, 0] - impacts[:, 0]))
    dI = rel_err(mine[:, 1], impacts[:, 1])
    err = np.max(np.abs(ours - peer))
    print(f"seed {seed} {shape} {method}: {len(impacts)} impacts, times {dt:.1e}, "
          f"impulses {dI:.1e}, state {err:.1e}")
    assert dt < 1e-10 and dI < 1e-9 and err < 1e-9


# ---- resting contact and lift-off: Pinocchio's constrained dynamics ---------------------
def contact_scene(rng):
    """e = 0 (contact at the first impact); a vertical law strong enough to lift the
    body off and land it again; an offset sphere, a turning carrier."""
    doc, law = random_scene(rng)
    law.a[2], law.w[2], law.b[2] = 0.1, rng.uniform(20.0, 24.0), 0.0
    doc["point"] = {"mass": float(rng.uniform(0.6, 0.9)), "law": law.texts()}
    doc["body"]["mass"] = float(rng.uniform(0.6, 1.0))   # nu z'' reaches 1.5 g and more
    doc["plane"]["restitution"] = 0.0
    doc["initial"]["com"] = [0.0, 0.0, doc["body"]["radius"] + 0.15]
    doc["initial"]["com_velocity"] = [0.2, -0.1, 0.0]
    doc["initial"]["omega"] = (np.asarray(doc["initial"]["omega"]) / 3).tolist()
    tilt = np.r_[1.0, rng.normal(0.0, 0.1, 3)]         # body z near the vertical
    doc["initial"]["quaternion"] = (tilt / np.linalg.norm(tilt)).tolist()
    doc["run"]["duration"] = 1.2
    return doc, law


def pinocchio_contact_run(doc, law, times):
    """Flight as :func:`pinocchio_run`; after an impact with e = 0 the sphere's centre
    is held at its height (a bilateral row on the carrier, Pinocchio's Jacobian and
    drift acceleration, the 7 x 7 KKT system) while the reaction N > 0, and flight
    resumes where N crosses zero.  Returns the states on ``times`` and the events as
    (t, kind)."""
    body, point = doc["body"], doc["point"]
    M, m, J = body["mass"], point["mass"], np.array(body["inertia"])
    g = doc["run"]["g"]
    radius, center = body["radius"], np.array(body["center"])
    nu = m / (M + m)
    model, frame = carrier_model(M, m, J, g, contact_at=center)
    data = model.createData()
    ini = doc["initial"]
    A0 = rotation_from_quaternion(np.array(ini["quaternion"]))
    r0, v0, _ = law(0.0)
    qb, vb = base_state(A0, np.array(ini["com"]), np.array(ini["com_velocity"]),
                        np.array(ini["omega"]), r0, v0, nu)
    state = np.r_[qb, vb]

    def rotation(s):
        quat = s[3:7] / np.linalg.norm(s[3:7])
        return pin.Quaternion(quat).toRotationMatrix(), quat

    def dynamics(t, s, contact):
        A, quat = rotation(s)
        r, v, acc = law(t)
        q, vel = np.r_[s[:3], quat, r], np.r_[s[7:], v]
        Mq = pin.crba(model, data, q)
        Mq = np.triu(Mq) + np.triu(Mq, 1).T
        h = pin.rnea(model, data, q, vel, np.zeros(model.nv))
        rhs = -(h[:6] + Mq[:6, 6:] @ acc)
        if contact:
            pin.forwardKinematics(model, data, q, vel, np.zeros(model.nv))
            pin.computeJointJacobians(model, data, q)
            pin.updateFramePlacements(model, data)
            row = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)[2, :6]
            drift = pin.getFrameClassicalAcceleration(model, data, frame,
                                                      pin.LOCAL_WORLD_ALIGNED).linear[2]
            kkt = np.zeros((7, 7))
            kkt[:6, :6], kkt[:6, 6], kkt[6, :6] = Mq[:6, :6], -row, row
            sol = np.linalg.solve(kkt, np.r_[rhs, -drift])
            ab, N = sol[:6], sol[6]
        else:
            ab, N = np.linalg.solve(Mq[:6, :6], rhs), None
        omega, qv, qw = s[10:13], s[3:6], s[6]
        dquat = 0.5 * np.r_[qw * omega + np.cross(qv, omega), -qv @ omega]
        return np.r_[A @ s[7:10], dquat, ab], N

    def gap(t, s):
        if t <= t0 + 1e-12:         # the restart at an impact: S leaves the plane there
            return 1.0
        A, _ = rotation(s)
        return s[2] + (A @ center)[2] - radius
    gap.terminal, gap.direction = True, -1

    def reaction(t, s):
        return dynamics(t, s, True)[1]
    reaction.terminal, reaction.direction = True, -1

    t0, t_end, events, pieces, contact = 0.0, doc["run"]["duration"], [], [], False
    while t0 < t_end:
        sol = solve_ivp(lambda t, s: dynamics(t, s, contact)[0], (t0, t_end), state,
                        method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True,
                        events=reaction if contact else gap)
        pieces.append((t0, sol.t[-1], sol.sol))
        if sol.status != 1:
            break
        if len(events) == MAX_IMPACTS:
            raise RuntimeError(f"more than {MAX_IMPACTS} events")
        t0, state = sol.t[-1], sol.y[:, -1].copy()
        if contact:
            events.append((t0, "lift_off"))
            contact = False
            continue
        A, quat = rotation(state)
        r, _, _ = law(t0)
        after, _ = impulse(M, m, J, g, A, np.r_[state[:3], quat], state[7:], r,
                           center - radius * A[2], 0.0)
        state[7:] = after
        events.append((t0, "impact"))
        contact = dynamics(t0, state, True)[1] > 0
    rows = []
    for t in times:
        lo, hi, dense = next(p for p in pieces if p[0] <= t <= p[1] + 1e-12)
        s = dense(min(t, hi))
        A, _ = rotation(s)
        r, v, _ = law(t)
        omega = s[10:13]
        rows.append(np.r_[s[:3] + nu * A @ r,
                          A @ s[7:10] + nu * A @ (np.cross(omega, r) + v), omega, A.ravel()])
    return np.array(rows), events


@pytest.mark.parametrize("seed", range(8))
def test_contact_and_liftoff_match_pinocchio(seed):
    """derive.simulate on a scene that lands (e = 0), rests, lifts off and lands again,
    against Pinocchio's constrained dynamics: the impact and lift-off times and the
    state on the output grid."""
    doc, law = contact_scene(np.random.default_rng(2000 + seed))
    res = derive.simulate(doc)
    assert res.status == "done"
    rows = res.row_kind == 0
    t, ours = res.t[rows], res.general[rows]
    peer, events = pinocchio_contact_run(doc, law, t)
    kinds = [k for _, k in events]
    assert "lift_off" in kinds and kinds.count("impact") >= 2, kinds
    mine = [(e["t"], e["kind"]) for e in res.events if e["kind"] in ("impact", "lift_off")]
    print(f"seed {seed}: ours {[(round(a, 6), k) for a, k in mine]}")
    print(f"seed {seed}: peer {[(round(a, 6), k) for a, k in events]}")
    assert [k for _, k in mine] == kinds
    dt = max(abs(a - b) for (a, _), (b, _) in zip(mine, events))
    err = np.max(np.abs(ours - peer))
    print(f"seed {seed}: events {dt:.1e}, state {err:.1e}")
    assert dt < 1e-10 and err < 1e-9


# ---- the reduced models: the runtime's choice against the full 3-D peer ------------------
def reduced_scene(kind, rng):
    """A scene the runtime answers with the model ``kind`` (derive.runtime.choice)."""
    doc, law = random_scene(rng)
    ini, body = doc["initial"], doc["body"]
    if kind == "translational":              # P on the vertical body axis through O
        law.a[:2] = law.b[:2] = 0.0
        body["center"] = [0.0, 0.0, 0.0]
        ini.update(omega=[0.0, 0.0, 0.0], quaternion=[1.0, 0.0, 0.0, 0.0])
    elif kind == "planar":                   # z = 0, omega along z, body z horizontal
        law.a[2] = law.b[2] = 0.0
        body["center"] = [*body["center"][:2], 0.0]
        ini.update(omega=[0.0, 0.0, float(rng.normal(0.0, 2.0))],
                   quaternion=[float(np.sqrt(0.5)), float(np.sqrt(0.5)), 0.0, 0.0])
    elif kind == "axisymmetric":             # free flight, J_x = J_y, P on the axis
        law.a[:2] = law.b[:2] = 0.0
        J = body["inertia"]
        body["inertia"] = [J[0], J[0], J[2]]
        del doc["plane"]
    elif kind == "vertical":                 # the pose not asked
        doc["run"]["outputs"] = ["impacts"]
    doc["point"]["law"] = law.texts()
    return doc, law


@pytest.mark.parametrize("kind", ["translational", "planar", "axisymmetric", "vertical"])
@pytest.mark.parametrize("seed", range(3))
def test_reduced_models_match_pinocchio(kind, seed):
    """Each reduced model the runtime picks (its own state and equations) against
    Pinocchio's full 3-D dynamics of the same scene: the pose on the output grid (the
    general state rebuilt from the reduced one), and every impact."""
    doc, law = reduced_scene(kind, np.random.default_rng(3000 + seed))
    res = derive.simulate(doc)
    assert res.model == kind and res.status == "done", (res.model, res.why)
    t = res.t[res.row_kind == 0]
    peer, impacts = pinocchio_run(doc, law, t)
    if "plane" in doc:
        assert len(impacts) >= 1 and len(res.impacts) == len(impacts)
        assert np.max(np.abs(res.impacts[:, 0] - impacts[:, 0])) < 1e-10
        assert rel_err(res.impacts[:, 1], impacts[:, 1]) < 1e-9
    if kind != "vertical":
        err = np.max(np.abs(res.general[res.row_kind == 0] - peer))
        print(f"{kind}: {len(impacts)} impacts, state {err:.1e}")
        assert err < 1e-9
