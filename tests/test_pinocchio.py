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


def random_scene(rng):
    law = HarmonicLaw(rng)
    M, m = float(rng.uniform(0.5, 3.0)), float(rng.uniform(0.05, 0.6))
    second = rng.uniform(0.05, 0.4, 3)
    J = np.array([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
    radius = float(rng.uniform(0.3, 0.6))
    center = rng.uniform(-0.08, 0.08, 3)
    quat = rng.normal(size=4)
    quat /= np.linalg.norm(quat)
    doc = {"name": "pinocchio-peer",
           "body": {"mass": M, "inertia": J.tolist(), "shape": "sphere", "radius": radius,
                    "center": center.tolist()},
           "point": {"mass": m, "law": law.texts()},
           "plane": {"restitution": float(rng.uniform(0.6, 0.95))},
           "initial": {"com": [0.0, 0.0, float(rng.uniform(0.9, 1.3))],
                       "com_velocity": rng.normal(0.0, 0.5, 3).tolist(),
                       "omega": rng.normal(0.0, 1.5, 3).tolist(), "quaternion": quat.tolist()},
           "run": {"duration": 1.6, "rtol": 1e-12, "atol": 1e-14,
                   "g": 9.81, "output_dt": 0.1, "outputs": ["pose", "impacts"]}}
    return doc, law


def pinocchio_run(doc, law, times):
    """SciPy DOP853 on Pinocchio's dynamics: state (O, quaternion x y z w, O' and omega
    in body axes); a terminal event at the sphere's lowest point, the impulse there."""
    body, point = doc["body"], doc["point"]
    M, m, J = body["mass"], point["mass"], np.array(body["inertia"])
    g, e = doc["run"]["g"], doc["plane"]["restitution"]
    radius, center = body["radius"], np.array(body["center"])
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
        A, _ = rotation(s)
        return s[2] + (A @ center)[2] - radius
    gap.terminal, gap.direction = True, -1

    t0, t_end, impacts, pieces = 0.0, doc["run"]["duration"], [], []
    while t0 < t_end:
        sol = solve_ivp(rhs, (t0, t_end), state, method="DOP853", rtol=1e-12, atol=1e-14,
                        events=gap, dense_output=True)
        pieces.append((t0, sol.t[-1], sol.sol))
        if sol.status != 1:
            break
        t0, state = sol.t[-1], sol.y[:, -1].copy()
        A, quat = rotation(state)
        r, _, _ = law(t0)
        s_body = center - radius * A[2]               # S, the lowest point, body axes
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
@pytest.mark.parametrize("seed", range(6))
def test_bouncing_runs_match_pinocchio(seed, method):
    """derive.simulate on a random bouncing scene (offset sphere, 3-D law, spinning
    carrier) against SciPy with Pinocchio's dynamics and impulses: the state on the
    output grid and every impact time and impulse."""
    doc, law = random_scene(np.random.default_rng(1000 + seed))
    doc["run"]["method"] = method
    res = derive.simulate(doc)
    assert res.status == "done"
    rows = res.row_kind == 0
    t, ours = res.t[rows], res.general[rows]
    peer, impacts = pinocchio_run(doc, law, t)
    assert len(impacts) >= 1, "the scene should bounce"
    assert len(res.impacts) == len(impacts)
    dt = np.max(np.abs(res.impacts[:, 0] - impacts[:, 0]))
    dI = rel_err(res.impacts[:, 1], impacts[:, 1])
    err = np.max(np.abs(ours - peer))
    print(f"seed {seed} {method}: {len(impacts)} impacts, times {dt:.1e}, impulses {dI:.1e}, "
          f"state {err:.1e}")
    assert dt < 1e-10 and dI < 1e-9 and err < 1e-9
