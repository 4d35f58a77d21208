"""The moments family (derive/moments.py, derive/models_moments.py): the carrier with any
number of points and rotors, against things computed another way.

* The emitted functions agree with each other: the C (ctypes), the CasADi functions of
  generated/casadi and the NumPy evaluation of the specifications; and the library's
  jac_ with CasADi's AD.
* One point's moments give the general model's functions (the paper's), to rounding.
* An independent Newton–Euler formulation (tests/newton_euler_moments.py: the carrier,
  each point under its own force, each rotor under its own torque) on random systems of
  0–6 points and 0–3 rotors: flight (omega', C''), the impact map and I, persistent
  contact (dq, N), the Delassus matrix and K in fixed axes, to 1e-10.
* Closed forms derived here: a free body spun up or down by two masses moving
  symmetrically on a radial guide, and a body turned in free flight by a rotor on a
  principal axis, integrated with the emitted right-hand side, to 1e-9.
* Pinocchio: a free flyer with three prismatic joints per point and a revolute joint per
  rotor, driven along their laws: omega', C'' and the centroidal angular momentum.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import quad, solve_ivp

import newton_euler_moments as ne
from cases import rel_err, rotation_from_quaternion
from derive import layout
from derive.clib import generated_library, load_generated
from derive.emit.numpy_backend import compile_spec
from derive.emit.render import GENERATED
from derive.models_moments import moments_specs

TOL = 1e-10
SPECS = {s.name: s for s in moments_specs()}
SPIN = layout.MOMENTS.spin


@pytest.fixture(scope="module")
def lib():
    return load_generated()


def random_system(rng, n_points, n_rotors) -> ne.System:
    second = rng.uniform(0.05, 1.0, 3)
    J = np.array([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
    points = [ne.Point(m=rng.uniform(0.05, 2.0), r=rng.uniform(-1, 1, 3),
                       v=rng.normal(0, 1, 3), a=rng.normal(0, 3, 3)) for _ in range(n_points)]
    rotors = []
    for _ in range(n_rotors):
        axis = rng.normal(size=3)
        rotors.append(ne.Rotor(axis=axis / np.linalg.norm(axis), I=rng.uniform(0.005, 0.05),
                               It=rng.uniform(0.005, 0.05), rate=rng.normal(0, 30),
                               acc=rng.normal(0, 30)))
    return ne.System(M=rng.uniform(0.5, 5.0), J=J, g=9.81, points=points, rotors=rotors)


def random_state(rng) -> np.ndarray:
    A = rotation_from_quaternion(rng.normal(size=4))
    return np.concatenate([rng.normal(0, 1, 3), rng.normal(0, 1, 3), rng.normal(0, 2, 3),
                           A.ravel()])


def systems(n: int, seed: int):
    """(system, state) pairs: every count of points 0..6 and rotors 0..3 in turn."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        sys_ = random_system(rng, k % 7, k % 4)
        out.append((sys_, random_state(rng)))
    return out


def emitted_moments(lib, sys_: ne.System) -> np.ndarray:
    """The moments as the runtime will form them: the emitted shares, summed."""
    u = np.zeros(layout.MOMENTS.nq)
    for p in sys_.points:
        jet = np.r_[p.r, p.v, p.a]                       # u's order: x, y, z, x', ...
        u += lib["point_moments"](p.m, jet)[0]
    for r in sys_.rotors:
        u[SPIN] += lib["rotor_moments"](r.axis, r.I, [r.rate, r.acc])[0]
    return u


# ---- the shares -------------------------------------------------------------------------
def test_emitted_shares_sum_to_the_moments_definitions(lib):
    worst = 0.0
    for sys_, _ in systems(70, seed=1):
        worst = max(worst, rel_err(emitted_moments(lib, sys_), sys_.moments()))
    assert worst < 1e-14, worst


# ---- the emitted implementations agree ---------------------------------------------------
def _inputs(spec, sys_, q, u, rng) -> list:
    A = q[9:18].reshape(3, 3)
    n = A[2]
    values = {"q": q, "u": u, "p": sys_.params(), "s": rng.uniform(-1, 1, 3),
              "sdot": rng.normal(size=3), "e": rng.uniform(0, 1), "P": rng.normal(size=3),
              "mu_f": rng.uniform(0, 1), "dir": (lambda d: d / np.linalg.norm(d))(
                  rng.normal(size=2)),
              "w": rng.normal(size=6), "mass": rng.uniform(0.1, 2), "jet": rng.normal(size=9),
              "axis": n, "inertia": rng.uniform(0.01, 0.1), "rate": rng.normal(size=2),
              "A": A.ravel(), "omega": q[6:9], "K": rng.normal(size=3),
              "W": rng.uniform(-0.4, 0.4, 3), "k": rng.normal(size=3)}
    return [values[v.name] for v in spec.inputs]


@pytest.fixture(scope="module")
def implementations(lib):
    library = str(generated_library())
    return {name: {"c": lib[name], "numpy": compile_spec(spec),
                   "casadi": ca.Function.load(str(GENERATED / "casadi" / f"{name}.casadi")),
                   "external": ca.external(name, library)}
            for name, spec in SPECS.items()}


def test_emitted_implementations_agree(lib, implementations):
    """C, C through casadi.external, CasADi and NumPy, every function of the family, at
    random systems: 1e-12 of each output's scale."""
    rng = np.random.default_rng(5)
    worst = {}
    for sys_, q in systems(28, seed=2):
        u = emitted_moments(lib, sys_)
        for name, spec in SPECS.items():
            impl = implementations[name]
            values = _inputs(spec, sys_, q, u, rng)
            ref = impl["numpy"](*values)
            got = {"c": impl["c"](*values),
                   "casadi": [np.array(r.full()).ravel() for r in
                              impl["casadi"].call([ca.DM(v) for v in values])],
                   "external": [np.array(r.full()).ravel() for r in
                                impl["external"].call([ca.DM(v) for v in values])]}
            for kind, outs in got.items():
                for a, b in zip(outs, ref):
                    err = float(np.max(np.abs(np.ravel(a) - np.ravel(b)), initial=0.0)
                                / max(float(np.max(np.abs(b), initial=0.0)), 1.0))
                    worst[name] = max(worst.get(name, 0.0), err)
    bad = {k: v for k, v in worst.items() if v > 1e-12}
    assert not bad, bad


@pytest.mark.parametrize("name", ["moments_flight_rhs", "moments_impact", "moments_lie_stage",
                                  "point_moments", "rotor_moments"])
def test_library_jacobian_is_casadis_ad(name, lib):
    ext = ca.external(name, str(generated_library()))
    assert ext.jacobian().name() == f"jac_{name}"
    ref = ca.Function.load(str(GENERATED / "casadi" / f"{name}.casadi"))

    def blocks(f):
        xs = [ca.MX.sym(f.name_in(j), f.sparsity_in(j)) for j in range(f.n_in())]
        outs = f.call(xs)
        return ca.Function("J", xs, [ca.jacobian(y, x) for y in outs for x in xs])
    ours, theirs = blocks(ext), blocks(ref)
    rng = np.random.default_rng(9)
    for sys_, q in systems(8, seed=3):
        values = _inputs(SPECS[name], sys_, q, emitted_moments(lib, sys_), rng)
        for a, b in zip(ours(*values), theirs(*values)):
            a, b = np.array(a.full()), np.array(b.full())
            assert np.max(np.abs(a - b), initial=0.0) <= 1e-11 * max(1.0, np.abs(b).max(
                initial=0.0))


# ---- one point: the general model --------------------------------------------------------
def test_one_point_is_the_general_model(lib):
    rng = np.random.default_rng(4)
    worst = 0.0
    for sys_, q in systems(60, seed=4):
        sys_.points, sys_.rotors = sys_.points[:1] or [random_system(rng, 1, 0).points[0]], []
        pt = sys_.points[0]
        u1, p = np.r_[pt.r, pt.v, pt.a], sys_.params()
        (um,) = lib["point_moments"](pt.m, u1)
        s, sdot, e = rng.uniform(-1, 1, 3), rng.normal(size=3), rng.uniform(0, 1)
        W, k = rng.uniform(-0.4, 0.4, 3), rng.normal(size=3)
        pairs = [("moments_flight_rhs", "general_flight_rhs", (q, um, p), (q, u1, p)),
                 ("moments_gap", "general_gap", (q, um, s, p), (q, u1, s, p)),
                 ("moments_impact", "general_impact", (q, um, s, p, e), (q, u1, s, p, e)),
                 ("moments_contact_rhs", "general_contact_rhs", (q, um, s, sdot, p),
                  (q, u1, s, sdot, p)),
                 ("moments_kinetic_moment", "general_kinetic_moment", (q, um, p), (q, u1, p)),
                 ("moments_lie_stage", "lie_stage", (W, k, um, p), (W, k, u1, p)),
                 ("moments_lie_point", "lie_point", (W, k, um, p), (W, k, u1, p))]
        for ours, theirs, a, b in pairs:
            worst = max(worst, rel_err(np.concatenate(lib[ours](*a)),
                                       np.concatenate(lib[theirs](*b))))
    assert worst < 1e-13, worst


# ---- Newton-Euler ------------------------------------------------------------------------
def test_flight_matches_newton_euler(lib):
    worst = 0.0
    for sys_, q in systems(84, seed=6):
        (dq,) = lib["moments_flight_rhs"](q, emitted_moments(lib, sys_), sys_.params())
        ref = ne.flight(sys_, q)
        assert np.allclose(ref[3:6], [0, 0, -sys_.g], atol=1e-12)     # C'' of E1.2
        worst = max(worst, rel_err(dq, ref))
    assert worst < TOL, worst


def test_impact_matches_newton_euler(lib):
    rng = np.random.default_rng(7)
    worst = 0.0
    for sys_, q in systems(84, seed=7):
        s, e = rng.uniform(-1, 1, 3), rng.uniform(0, 1)
        q_plus, (I,) = lib["moments_impact"](q, emitted_moments(lib, sys_), s,
                                             sys_.params(), e)
        ref_q, ref_I = ne.impact(sys_, q, s, e)
        worst = max(worst, rel_err(q_plus, ref_q), rel_err([I], [ref_I]))
    assert worst < TOL, worst


def test_contact_matches_newton_euler(lib):
    rng = np.random.default_rng(8)
    worst = 0.0
    for sys_, q in systems(84, seed=8):
        s, sdot = rng.uniform(-1, 1, 3), rng.normal(size=3)
        dq, (N,) = lib["moments_contact_rhs"](q, emitted_moments(lib, sys_), s, sdot,
                                              sys_.params())
        ref_dq, ref_N = ne.contact(sys_, q, s, sdot)
        scale = sys_.mass * sys_.g
        worst = max(worst, rel_err(dq, ref_dq), abs(N - ref_N) / max(abs(ref_N), scale))
    assert worst < TOL, worst


def test_delassus_and_kinetic_moment_match_newton_euler(lib):
    """W (fixed axes): column k is the change of the velocity of S under a unit impulse
    along the fixed axis k; K about C in fixed axes from the bodies' momenta."""
    rng = np.random.default_rng(10)
    worst = 0.0
    for sys_, q in systems(56, seed=10):
        u, p = emitted_moments(lib, sys_), sys_.params()
        s = rng.uniform(-1, 1, 3)
        A = q[9:18].reshape(3, 3)
        W_up, _ = lib["moments_delassus"](q, u, s, p)
        W = np.zeros((3, 3))
        W[np.triu_indices(3)] = W_up
        W = W + np.triu(W, 1).T
        cols = []
        for axis in np.eye(3):
            dVO, dw = ne.impulse_response(sys_, q, s, A.T @ axis)
            cols.append(A @ (dVO + np.cross(dw, s)))
        (K,) = lib["moments_fixed_kinetic_moment"](A.ravel(), q[6:9], u, p)
        worst = max(worst, rel_err(W, np.column_stack(cols)),
                    rel_err(K, ne.kinetic_moment_fixed(sys_, q)))
    assert worst < TOL, worst


# ---- closed forms ------------------------------------------------------------------------
def _integrate(lib, moments_at, q0, p, t_end):
    def rhs(t, q):
        return lib["moments_flight_rhs"](q, moments_at(t), p)[0]
    return solve_ivp(rhs, (0.0, t_end), q0, method="DOP853", rtol=1e-13, atol=1e-14,
                     dense_output=True)


def test_spin_up_by_two_masses_on_a_radial_guide(lib):
    """Two masses m at +-r(t) e_x, r = r0 + b sin(nu t), the body turning about its
    principal z axis: s = 0, h = 0, Theta_zz = 2 m r^2, so K_z = (J_z + 2 m r^2) omega_z
    is constant and omega_z(t) = K_z/(J_z + 2 m r(t)^2); the body turns about z by
    phi(t) = the integral of omega_z (by quadrature); omega_x = omega_y = 0."""
    M, m, J, g = 2.0, 0.3, np.array([0.4, 0.5, 0.6]), 9.81
    r0, b, nu, w0 = 0.5, 0.3, 3.0, 2.0

    def r(t):
        return r0 + b * np.sin(nu * t), b * nu * np.cos(nu * t), -b * nu * nu * np.sin(nu * t)

    def moments_at(t):
        x, xd, xdd = r(t)
        return sum(lib["point_moments"](m, [sg * x, 0, 0, sg * xd, 0, 0, sg * xdd, 0, 0])[0]
                   for sg in (1.0, -1.0))
    p = np.array([M, 2 * m, *J, g])
    q0 = np.r_[0, 0, 10, 0.3, 0, 1.0, 0, 0, w0, np.eye(3).ravel()]
    Kz = (J[2] + 2 * m * r(0)[0] ** 2) * w0
    sol = _integrate(lib, moments_at, q0, p, 2.0)
    worst = 0.0
    for t in np.linspace(0.1, 2.0, 12):
        q = sol.sol(t)
        wz = Kz / (J[2] + 2 * m * r(t)[0] ** 2)
        phi = quad(lambda s: Kz / (J[2] + 2 * m * r(s)[0] ** 2), 0, t, epsabs=1e-12,
                   epsrel=1e-12)[0]
        c, s_ = np.cos(phi), np.sin(phi)
        A = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1]])
        worst = max(worst, abs(q[8] - wz), *np.abs(q[6:8]), np.abs(q[9:18] - A.ravel()).max(),
                    np.abs(q[:6] - [0.3 * t, 0, 10 + t - 4.905 * t * t, 0.3, 0,
                                    1 - 9.81 * t]).max())
    assert worst < 1e-9, worst


def test_a_rotor_turns_the_body_in_free_flight(lib):
    """A rotor of axial moment I on the principal z axis, psi(t) = Omega t + c sin(nu t):
    K_z = J_z omega_z + I psi' is constant (J_z with the rotor locked), so omega_z =
    (K_z - I psi'(t))/J_z and the body turns about z by phi = (K_z t - I (psi(t) -
    psi(0)))/J_z; omega_x = omega_y = 0."""
    M, J, g, I = 1.5, np.array([0.3, 0.35, 0.5]), 9.81, 0.04
    Omega, c_, nu, w0 = 40.0, 3.0, 5.0, 0.7

    def psi(t):
        return (Omega * t + c_ * np.sin(nu * t), Omega + c_ * nu * np.cos(nu * t),
                -c_ * nu * nu * np.sin(nu * t))

    def moments_at(t):
        u = np.zeros(layout.MOMENTS.nq)
        _, rate, acc = psi(t)
        u[SPIN] = lib["rotor_moments"]([0.0, 0.0, 1.0], I, [rate, acc])[0]
        return u
    p = np.array([M, 0.0, *J, g])
    q0 = np.r_[0, 0, 5, 0, 0, 0, 0, 0, w0, np.eye(3).ravel()]
    Kz = J[2] * w0 + I * psi(0)[1]
    sol = _integrate(lib, moments_at, q0, p, 2.0)
    worst = 0.0
    for t in np.linspace(0.1, 2.0, 12):
        q = sol.sol(t)
        phi = (Kz * t - I * (psi(t)[0] - psi(0)[0])) / J[2]
        c, s_ = np.cos(phi), np.sin(phi)
        A = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1]])
        worst = max(worst, abs(q[8] - (Kz - I * psi(t)[1]) / J[2]), *np.abs(q[6:8]),
                    np.abs(q[9:18] - A.ravel()).max())
    assert worst < 1e-9, worst


# ---- Pinocchio ---------------------------------------------------------------------------
def pinocchio_model(sys_: ne.System):
    """Free flyer (the carrier less its rotors' own inertia), three prismatic joints per
    point (the mass on the last), a revolute joint about each rotor's axis (no mass: the
    rotor's mass is in the carrier's)."""
    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, -sys_.g])
    root = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "carrier")
    model.appendBodyToJoint(root, pin.Inertia(sys_.M, np.zeros(3), sys_.rigid()),
                            pin.SE3.Identity())
    for j, p in enumerate(sys_.points):
        parent = root
        for k, joint in enumerate((pin.JointModelPX(), pin.JointModelPY(), pin.JointModelPZ())):
            parent = model.addJoint(parent, joint, pin.SE3.Identity(), f"P{j}{'xyz'[k]}")
        model.appendBodyToJoint(parent, pin.Inertia(p.m, np.zeros(3), np.zeros((3, 3))),
                                pin.SE3.Identity())
    for k, r in enumerate(sys_.rotors):
        rng = np.random.default_rng(k)
        where = pin.SE3(np.eye(3), rng.uniform(-0.3, 0.3, 3))       # any centre G
        joint = model.addJoint(root, pin.JointModelRevoluteUnaligned(r.axis), where, f"R{k}")
        model.appendBodyToJoint(joint, pin.Inertia(0.0, np.zeros(3), r.inertia),
                                pin.SE3.Identity())
    return model


def test_flight_and_centroidal_momentum_match_pinocchio(lib):
    worst = 0.0
    for sys_, q in systems(28, seed=12):
        model = pinocchio_model(sys_)
        data = model.createData()
        A, w = q[9:18].reshape(3, 3), q[6:9]
        c, _ = sys_.oc()
        base_q = np.r_[q[:3] - A @ c, pin.Quaternion(A).coeffs()]
        base_v = np.r_[sys_.velocity_of_O(q), w]
        psi = np.random.default_rng(1).uniform(0, 6, len(sys_.rotors))
        qp = np.r_[base_q, *(p.r for p in sys_.points), psi]
        vp = np.r_[base_v, *(p.v for p in sys_.points), [r.rate for r in sys_.rotors]]
        ap = np.r_[[x for p in sys_.points for x in p.a], [r.acc for r in sys_.rotors]]
        Mq = pin.crba(model, data, qp)
        Mq = np.triu(Mq) + np.triu(Mq, 1).T
        h = pin.rnea(model, data, qp, vp, np.zeros(model.nv))
        ab = np.linalg.solve(Mq[:6, :6], -(h[:6] + Mq[:6, 6:] @ ap))
        pin.centerOfMass(model, data, qp, vp, np.r_[ab, ap])
        hg = pin.computeCentroidalMomentum(model, data, qp, vp)
        u, p = emitted_moments(lib, sys_), sys_.params()
        (dq,) = lib["moments_flight_rhs"](q, u, p)
        (K,) = lib["moments_fixed_kinetic_moment"](A.ravel(), w, u, p)
        worst = max(worst, rel_err(dq[6:9], ab[3:6]), rel_err(dq[3:6], data.acom[0]),
                    rel_err(K, hg.angular), rel_err(sys_.mass * q[3:6], hg.linear))
    assert worst < TOL, worst
