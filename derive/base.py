"""The base model: a body whose flat face lies on the plane, derived from the momentum
theorems in the terms of the moments of its internal bodies (issue 33).

The body does not tilt: its face stays on the plane, so in the *face frame* (body axes
turned so that the third is the upward vertical, derive/face.py) its angular velocity is
``omega = w e_z`` (w = psi', the yaw rate) and O stays at the height ``h`` above the plane.
What moves is O's horizontal position ``(X_O, Y_O)`` and the yaw ``psi``; the state (fixed
axes) is

    q = (X_O, Y_O, psi, X_O', Y_O', psi'),     v = R(psi)^T (X_O', Y_O', 0) (face frame).

The carrier (M, J_O = diag(J_x, J_y, J_z) in the face frame, O its centre of mass) sees
its points and rotors only through their moments about O (the contract of issue 32,
derive/layout.py's MOMENTS on branch ``moments``): ``s``, ``Theta``, ``h`` and the rates
``s', s'', Theta', h'`` relative to the body, and their total mass m.  From the
definitions, with absolute velocities:

* the linear momentum ``P = (M + m) v + s' + omega x s`` (sum of m_i r_i', O the
  carrier's centre: ``sum m_j (V_O + omega x rho_j + rho_j') `` and ``M V_O``);
* the angular momentum about the moving point O, ``L = J_O omega + Theta omega + h + s x
  v`` (the carrier's J_O omega; a point's ``m rho x (V_O + omega x rho + rho') = m rho x
  V_O + Theta_j omega + h_j``; a rotor's spin in h).

The theorems, in face-frame components (``X' + omega x X`` the absolute rate of X):

    P' + omega x P = F + (N - (M + m) g) e_z                          (linear momentum)
    L' + omega x L = tau_O - V_O x P                    (angular momentum about moving O)

with the contact's force: friction ``F = (F_x, F_y, 0)`` and the normal force N, acting on
the face at the height ``-h``; its torque about O is ``(y_cp N + h F_y, -x_cp N - h F_x,
T_z)``, (x_cp, y_cp) the centre of pressure and T_z the friction's torque about O's
vertical; gravity's is ``s x (-g e_z)``.

* Vertical: ``N = (M + m) g + s_z''`` (omega x anything has no vertical component).
* In slip (F, T_z given by the face's friction, derive/face.py): the horizontal linear
  momentum and the vertical angular momentum are linear in ``(v_x', v_y', w')`` with the
  symmetric matrix ``[[M + m, 0, -s_y], [0, M + m, s_x], [-s_y, s_x, J_z + Theta_zz]]``
  (positive definite: its Schur complement is J_zz about C), solved numerically.
* In stick (v = 0, w = 0 and their rates 0): the friction the rest needs, ``F = s''_h``
  (the rate of the internal momentum s') and ``T_z = h_z'`` (of the internal angular
  momentum about O), checked against the face's limit surface (derive/face.py).
* Either way the horizontal angular momentum gives the centre of pressure (the body does
  not tilt), ``N y_cp = [L' + omega x L + V_O x P - tau_g]_x - h F_y`` and ``N x_cp =
  -[...]_y - h F_x``: lift-off where N reaches 0, tipping where cp reaches the face's edge.

The functions (FunctionSpecs, emitted to generated/c and generated/casadi):

* ``base_slip(q, u, p, h, wrench) -> (dq, N, cp)``;
* ``base_stick(u, p, h) -> (wrench, N, cp)``: the wrench ``(F_x, F_y, T_z)`` at rest;
* ``base_twist(q) -> twist``: ``(v_x, v_y, w)`` in the face frame, the slip of the face.

u is the 27 moments in the contract's order (s, s', s'', Theta and Theta' as their upper
triangles, h, h'), p = (M, m, J_x, J_y, J_z, g) with J in the face frame.  Checked in
tests/test_base_model.py against a Newton–Euler formulation of the carrier and each point
and rotor (derive/base_reference.py), which does not use the moments.
"""
from __future__ import annotations

from functools import lru_cache

import sympy as sp

from . import notation as nt
from .layout import BASE, MOMENTS_LABELS, UPPER_INDEX
from .models import FunctionSpec, LinearSolve, Vector

# ---- the moments (derive/layout.py's MOMENTS: the contract with the runtime); the symbols
# are the same SymPy objects as the moments family's
MOMENTS = tuple(sp.Symbol(label, real=True) for label in MOMENTS_LABELS)


def _vec(k: int) -> sp.Matrix:
    return sp.Matrix(MOMENTS[k:k + 3])


def _sym(k: int) -> sp.Matrix:
    out = sp.zeros(3, 3)
    for (i, j), value in zip(UPPER_INDEX, MOMENTS[k:k + 6]):
        out[i, j] = out[j, i] = value
    return out


S, SD, SDD = _vec(0), _vec(3), _vec(6)
THETA, THETA_D = _sym(9), _sym(15)
H, HD = _vec(21), _vec(24)

# ---- state, face, wrench, unknowns --------------------------------------------------------
X_O, Y_O, PSI, X_OD, Y_OD, PSI_D = sp.symbols("X_O Y_O psi X_O' Y_O' psi'", real=True)
STATE = (X_O, Y_O, PSI, X_OD, Y_OD, PSI_D)
STATE_LABELS = BASE.labels                            # (X_O, Y_O, psi, and their rates)
HEIGHT = sp.Symbol("h_O", positive=True)             # O's height above the plane
F_X, F_Y, T_Z = sp.symbols("F_x F_y T_z", real=True)  # friction on the body (face frame)
WRENCH = (F_X, F_Y, T_Z)
V_X, V_Y, W_Z = sp.symbols("v_x v_y w", real=True)    # O's velocity and the yaw rate
ACC = sp.symbols("v_x' v_y' w'", real=True)           # their rates (the slip's unknowns)
N_SYM = sp.Symbol("N", real=True)
CP = sp.symbols("x_cp y_cp", real=True)
P_SYMBOLS = (nt.M, nt.m, nt.J_x, nt.J_y, nt.J_z, nt.g)


def _theorems(v: sp.Matrix, w, acc, wrench, N, cp) -> sp.Matrix:
    """The six momentum equations (linear x, y, z; angular x, y, z about O), each ``= 0``,
    in face-frame components, differentiating the definitions of P and L along time
    functions and freezing them to the symbols."""
    t = nt.t
    vx_t, vy_t, w_t = (sp.Function(n, real=True)(t) for n in ("vx", "vy", "w"))
    mom_t = [sp.Function(f"mom{k}", real=True)(t) for k in range(27)]
    rates = {}
    # the chain of the moments: s -> s' -> s'', Theta -> Theta', h -> h'
    for lo, hi, n_ in ((0, 3, 3), (3, 6, 3), (9, 15, 6), (21, 24, 3)):
        for k in range(n_):
            rates[sp.Derivative(mom_t[lo + k], t)] = MOMENTS[hi + k]
    rates[sp.Derivative(vx_t, t)], rates[sp.Derivative(vy_t, t)] = acc[0], acc[1]
    rates[sp.Derivative(w_t, t)] = acc[2]
    frozen = {vx_t: v[0], vy_t: v[1], w_t: w, **dict(zip(mom_t, MOMENTS))}

    def vec(k):
        return sp.Matrix(mom_t[k:k + 3])

    def sym(k):
        out = sp.zeros(3, 3)
        for (i, j), value in zip(UPPER_INDEX, mom_t[k:k + 6]):
            out[i, j] = out[j, i] = value
        return out
    M, m, g = nt.M, nt.m, nt.g
    J_O = sp.diag(nt.J_x, nt.J_y, nt.J_z)
    V = sp.Matrix([vx_t, vy_t, 0])
    om = sp.Matrix([0, 0, w_t])
    s_t, sd_t, theta_t, h_t = vec(0), vec(3), sym(9), vec(21)
    P = (M + m) * V + sd_t + nt.cross(om, s_t)
    L = J_O * om + theta_t * om + h_t + nt.cross(s_t, V)

    def absolute_rate(X):
        return X.diff(t) + nt.cross(om, X)

    def freeze(X):
        return X.xreplace(rates).xreplace(frozen)
    Fx, Fy, Tz = wrench
    force = sp.Matrix([Fx, Fy, N - (M + m) * g])
    tau = sp.Matrix([cp[1] * N + HEIGHT * Fy, -cp[0] * N - HEIGHT * Fx, Tz]) \
        + nt.cross(s_t, sp.Matrix([0, 0, -g]))
    linear = freeze(absolute_rate(P)) - force
    angular = freeze(absolute_rate(L) - tau + nt.cross(V, P))
    return sp.Matrix([*linear, *angular]).applyfunc(sp.expand)


def _twist() -> tuple:
    """(v_x, v_y, w) from the state: O's velocity turned into the face frame."""
    c, s_ = sp.cos(PSI), sp.sin(PSI)
    return (c * X_OD + s_ * Y_OD, -s_ * X_OD + c * Y_OD, PSI_D)


def _q() -> Vector:
    return Vector("q", STATE, STATE_LABELS)


def _u() -> Vector:
    return Vector("u", MOMENTS, MOMENTS_LABELS)


def _p() -> Vector:
    return Vector("p", P_SYMBOLS, ("M", "m", "J_x", "J_y", "J_z", "g"))


def _h() -> Vector:
    return Vector("h", (HEIGHT,), ("h_O",))


@lru_cache(maxsize=None)
def slip_equations():
    """``(matrix, rhs, N, cp)``: ``matrix (v_x', v_y', w') = rhs`` from the linear momentum
    along x, y and the angular momentum about the vertical; N from the vertical; cp from
    the horizontal angular momentum, in terms of ACC and the twist symbols."""
    v = sp.Matrix([V_X, V_Y, 0])
    eqs = _theorems(v, W_Z, ACC, WRENCH, N_SYM, CP)
    rows = (eqs[0], eqs[1], eqs[5])
    matrix = sp.Matrix([[sp.expand(r).coeff(a) for a in ACC] for r in rows])
    rhs = sp.Matrix([-sp.expand(r.xreplace({a: 0 for a in ACC})) for r in rows])
    check = matrix - sp.Matrix([[nt.M + nt.m, 0, -S[1]], [0, nt.M + nt.m, S[0]],
                                [-S[1], S[0], nt.J_z + THETA[2, 2]]])
    if check.applyfunc(sp.expand) != sp.zeros(3, 3):
        raise AssertionError("the slip's matrix is not the planar mass matrix")
    N = sp.solve(eqs[2], N_SYM)[0]
    cp = sp.solve([eqs[3], eqs[4]], CP, dict=True)[0]
    return matrix, rhs, N, (cp[CP[0]], cp[CP[1]])


@lru_cache(maxsize=None)
def stick_equations():
    """``(wrench, N, cp)`` at rest: v = w = 0 and their rates 0."""
    v = sp.Matrix([0, 0, 0])
    eqs = _theorems(v, sp.Integer(0), (0, 0, 0), WRENCH, N_SYM, CP)
    wrench = sp.solve([eqs[0], eqs[1], eqs[5]], WRENCH, dict=True)[0]
    wrench = tuple(sp.expand(wrench[k]) for k in WRENCH)
    if wrench != (SDD[0], SDD[1], HD[2]):
        raise AssertionError(f"the rest's friction is not (s_x'', s_y'', h_z'): {wrench}")
    N = sp.solve(eqs[2], N_SYM)[0]
    cp = sp.solve([eqs[3], eqs[4]], CP, dict=True)[0]
    cp = tuple(sp.factor_terms(sp.expand(cp[c].xreplace(dict(zip(WRENCH, wrench)))))
               for c in CP)
    return wrench, N, cp


@lru_cache(maxsize=None)
def base_slip() -> FunctionSpec:
    matrix, rhs, N, cp = slip_equations()
    vx, vy, w = _twist()
    acc = ACC
    # O's absolute acceleration in the face frame, a = v' + omega x v, turned to fixed axes
    ax, ay = acc[0] - w * V_Y, acc[1] + w * V_X
    c, s_ = sp.cos(PSI), sp.sin(PSI)
    dq = (X_OD, Y_OD, PSI_D, c * ax - s_ * ay, s_ * ax + c * ay, acc[2])
    twist = ((V_X, vx), (V_Y, vy), (W_Z, w))
    unknowns = tuple(sp.Symbol(f"{a.name}_slip", real=True) for a in ACC)
    to_unknown = dict(zip(ACC, unknowns))
    N_def = sp.Symbol("N_slip", real=True)
    dq = tuple(sp.sympify(x).xreplace(to_unknown) for x in dq)
    cp = tuple(sp.sympify(x).xreplace(to_unknown).xreplace({N_SYM: N_def}) for x in cp)
    return FunctionSpec(
        name="base_slip",
        doc="Base model (a body on its face) while the face slips under the friction "
            "wrench (F_x, F_y, T_z) on it (face frame, T_z about O's vertical): dq/dt, the "
            "normal force N and the centre of pressure (x_cp, y_cp) from O's vertical.",
        inputs=(_q(), _u(), _p(), _h(), Vector("wrench", WRENCH, ("F_x", "F_y", "T_z"))),
        outputs=(Vector("dq", dq, tuple(f"d({lb})/dt" for lb in STATE_LABELS)),
                 Vector("N", (N_def,), ("N",)), Vector("cp", cp, ("x_cp", "y_cp"))),
        solves=(LinearSolve(matrix=matrix, rhs=(rhs,), unknowns=(unknowns,)),),
        definitions=(*twist, (N_def, N)))


@lru_cache(maxsize=None)
def base_stick() -> FunctionSpec:
    wrench, N, cp = stick_equations()
    N_def = sp.Symbol("N_stick", real=True)
    return FunctionSpec(
        name="base_stick",
        doc="Base model at rest on its face: the friction wrench (F_x, F_y, T_z) the rest "
            "needs (s'' horizontal, h_z'), the normal force N and the centre of pressure.",
        inputs=(_u(), _p(), _h()),
        outputs=(Vector("wrench", wrench, ("F_x", "F_y", "T_z")),
                 Vector("N", (N_def,), ("N",)),
                 Vector("cp", tuple(x.xreplace({N_SYM: N_def}) for x in cp),
                        ("x_cp", "y_cp"))),
        definitions=((N_def, N),))


@lru_cache(maxsize=None)
def base_twist() -> FunctionSpec:
    return FunctionSpec(
        name="base_twist",
        doc="The slip of the face in the base model: O's velocity (v_x, v_y) and the yaw "
            "rate w, face frame.",
        inputs=(_q(),), outputs=(Vector("twist", _twist(), ("v_x", "v_y", "w")),))


def base_specs() -> list[FunctionSpec]:
    return [base_slip(), base_stick(), base_twist()]
