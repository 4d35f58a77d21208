"""A rough plane: frictional impacts and sliding or sticking contact, derived from the
momentum theorems with a reaction ``R = N e_Z + F_t`` that has tangential components.

The paper's plane is smooth (E1.10–E1.16: a vertical impulse ``I e_Z`` at S; persistent
contact in :mod:`derive.contact`).  Here the plane's reaction at the body point S has
a horizontal part too, limited by Coulomb's law ``|F_t| <= mu_f N`` with the friction
coefficient ``mu_f`` (the paper's ``mu`` is the reduced mass ``mM/(m+M)``).  Starting
points, as in :mod:`derive.impact` and :mod:`derive.contact`:

    (m + M) dV_C/dt = -(m + M) g e_Z + R         theorem of momentum (E1.1 with R)
    dK/dt = CS x (A^T R)                          angular momentum about C (body axes)

and their integrals over an impact (positions, attitude and ``V_r`` unchanged):
``Q+ - Q- = P``, ``K+ - K- = CS x (A^T P)`` for an impulse ``P`` at S (fixed axes).

What is derived here:

* :func:`delassus`: the velocity of S (all three components, fixed axes) changes under
  an impulse ``P`` at S by ``W P``, W the inverse inertia at S of the two-body system
  (the Delassus matrix).  Its columns come from three solves with J,
  ``J Y_k = CS x a_k`` (``a_k`` the fixed axis k in body axes), never an inverse:
  ``W_jk = delta_jk/(m+M) + (CS x a_j, Y_k)``; ``W_ZZ`` is E1.16's ``k``.
* :func:`darboux_keller`: the impact as Darboux–Keller's integration in the normal
  impulse ``p = P_Z``: ``dv/dp = W dP/dp`` with ``dP_t/dp = -mu_f sigma`` while S slips
  (``sigma`` the unit slip direction), the stick rate ``tau`` that keeps the tangential
  velocity zero (``W (tau_X, tau_Y, 1)`` vertical; stick is possible iff
  ``|tau| <= mu_f``), the re-sliding direction when it is not, and the events that end
  compression and restitution (energetic, Poisson, Newton).
* :func:`sliding_contact`: S on the plane slipping, ``R = N (e_Z - mu_f sigma)``, N
  from ``dv_n/dt = 0``.
* :func:`sticking_contact`: S at rest on the plane, the three components of ``R`` from
  ``dv_S/dt = 0``; its coefficient matrix is the same W (checked while deriving).

Each takes a :class:`~derive.system.System` (the paper's when called without one).
``derive/friction_models.py`` packages them as FunctionSpecs, ``derive/darboux_keller.py``
integrates an impact numerically, ``paper_checks/extensions.py`` (X1.1) proves that
``mu_f = 0`` gives back E1.10–E1.16 and the smooth contact of :mod:`derive.contact`.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp

from . import notation as nt
from .impact import contact_point_velocity, impact_map, lever
from .kinematics import poisson_equations
from .momentum import angular_momentum, flight_dynamics_structured, per_system
from .system import System

# ---- symbols ------------------------------------------------------------------------------
mu_f = sp.Symbol("mu_f", nonnegative=True)          # Coulomb friction coefficient
P_IMP = sp.Matrix(sp.symbols("P_X P_Y P_Z", real=True))   # impulse at S, fixed axes
# J Y_k = CS x a_k: the unknowns of the Delassus matrix's solves (k = 1, 2, 3)
Y = tuple(sp.Matrix(sp.symbols(f"y{k}_x y{k}_y y{k}_z", real=True)) for k in (1, 2, 3))
# W itself as plain symbols, for the Darboux–Keller relations (symmetric)
W_XX, W_XY, W_XZ, W_YY, W_YZ, W_ZZ = sp.symbols("W_XX W_XY W_XZ W_YY W_YZ W_ZZ", real=True)
W_UPPER = (W_XX, W_XY, W_XZ, W_YY, W_YZ, W_ZZ)
W_LABELS = ("W_XX", "W_XY", "W_XZ", "W_YY", "W_YZ", "W_ZZ")
W_SYM = sp.Matrix([[W_XX, W_XY, W_XZ], [W_XY, W_YY, W_YZ], [W_XZ, W_YZ, W_ZZ]])
# the velocity of S during an impact, fixed axes (v_Z = v_n)
V_S = sp.Matrix(sp.symbols("v_X v_Y v_Z", real=True))
SIGMA = sp.Matrix(sp.symbols("sigma_X sigma_Y", real=True))   # unit slip direction
TAU = sp.Matrix(sp.symbols("tau_X tau_Y", real=True))         # stick rate dP_t/dp
Z_STICK = sp.Matrix(sp.symbols("z_X z_Y z_Z", real=True))     # W z = e_Z
C_RAY = sp.Symbol("c", positive=True)        # rate of the slip speed on a re-sliding ray
# the work of the normal impulse and of friction, integrated along the impact
E_N, E_T = sp.symbols("E_n E_t", real=True)
P_T = sp.Matrix(sp.symbols("P_X P_Y", real=True))            # = P_IMP[:2]
P_N = P_IMP[2]                                                # the normal impulse p
# values recorded at events: v_n at the start, p and E_n at the end of compression
V_N0, P_C, E_C = sp.symbols("v_n0 p_c E_c", real=True)
# contact: the reaction (fixed axes), the accelerations of C, the unknowns of the solves
R_VEC = sp.Matrix(sp.symbols("R_X R_Y R_Z", real=True))
ACC_C = sp.Matrix([nt.X_Cdd, nt.Y_Cdd, nt.Z_Cdd])
OMEGA_DOT_0 = sp.Matrix(sp.symbols("omega_x'0 omega_y'0 omega_z'0", real=True))  # J w'0 = f
W_SLIDE = sp.Matrix(sp.symbols("wf_x wf_y wf_z", real=True))   # J wf = d - mu_f CS x A^T sigma


def _zero(expr) -> bool:
    return sp.expand(expr) == 0


def _axis_in_body(k: int) -> sp.Matrix:
    """The fixed axis k (0: X, 1: Y, 2: Z = n) in body axes: row k of A."""
    return nt.a[k, :].T


# ---- the velocity of S and its change under an impulse ---------------------------------------
@per_system
def velocity_of_S(system: System) -> sp.Matrix:
    """Velocity of the body point S, fixed axes: ``V_C + A (omega x CS - nu V_r)``
    (:func:`derive.impact.contact_point_velocity`; its Z component is E1.14).  The
    horizontal components are the slip velocity ``v_t`` of S over the plane."""
    return contact_point_velocity(system)


@dataclass(frozen=True)
class Delassus:
    matrix: sp.Matrix          # W, fixed axes, in A, OS, OP, M, m and the unknowns Y_k
    rhs: tuple                 # CS x a_k: J Y_k = CS x a_k
    velocity_jump: sp.Matrix   # V_C+ - V_C- = P/(m+M)
    omega_jump: sp.Matrix      # omega+ - omega- = sum_k P_k Y_k
    moment: sp.Matrix          # CS x (A^T P), body axes


@per_system
def delassus(system: System) -> Delassus:
    """The impulse theorems with an impulse ``P`` of any direction at S give the jumps
    of ``V_C`` and ``omega``, and the jump of the velocity of S is ``W P``."""
    am = angular_momentum(system)
    J, own = am.J, am.own
    CS, d = lever(system)
    M, m = nt.M, nt.m
    # momentum: Q = (m+M) V_C (E1.2's lemma), Q+ - Q- = P
    dV = sp.Matrix(sp.symbols("dX_C' dY_C' dZ_C'", real=True))
    sol = sp.solve(list((m + M) * dV - P_IMP), list(dV), dict=True)[0]
    velocity_jump = sp.Matrix([sol[c] for c in dV])
    # angular momentum about C: K = J omega + own, J and own unchanged by the impact
    w_plus = sp.Matrix(sp.symbols("omega_x+ omega_y+ omega_z+", real=True))
    moment = nt.cross(CS, nt.a.T * P_IMP)
    jump = (J * w_plus + own - (J * nt.omega + own) - moment).applyfunc(sp.expand)
    if jump.jacobian(w_plus).applyfunc(sp.expand) != J.applyfunc(sp.expand):
        raise AssertionError("the angular impulse equation is not J-linear in omega+")
    # the moment is linear in P: J (omega+ - omega-) = sum_k P_k (CS x a_k)
    rhs = tuple(moment.diff(P_k) for P_k in P_IMP)
    for k in range(3):
        if not all(_zero(r - c) for r, c in zip(rhs[k], nt.cross(CS, _axis_in_body(k)))):
            raise AssertionError("d(CS x A^T P)/dP_k is not CS x a_k")
    if not all(_zero(v) for v in moment - sum((P_IMP[k] * rhs[k] for k in range(3)),
                                             sp.zeros(3, 1))):
        raise AssertionError("the moment of the impulse is not linear in P")
    omega_jump = sum((P_IMP[k] * Y[k] for k in range(3)), sp.zeros(3, 1))
    # the velocity of S after minus before: V_r, A, OS, OP unchanged
    v = velocity_of_S(system)
    after = v.xreplace({**{nt.V_C[i]: nt.V_C[i] + velocity_jump[i] for i in range(3)},
                        **{nt.omega[i]: nt.omega[i] + omega_jump[i] for i in range(3)}})
    dv = (after - v).applyfunc(sp.expand)
    W = dv.jacobian(P_IMP)
    if not all(_zero(c) for c in dv - W * P_IMP):
        raise AssertionError("the jump of the velocity of S is not linear in P")
    # the normal row and column: CS x a_3 = CS x n = d (E1.10), so Y_3 is E1.12's w and
    # W_ZZ is E1.16's k
    if not all(_zero(r - c) for r, c in zip(rhs[2], d)):
        raise AssertionError("CS x a_3 is not E1.10's d")
    if not _zero(W[2, 2].xreplace(dict(zip(Y[2], nt.W))) - impact_map(system).k):
        raise AssertionError("W_ZZ differs from E1.16's k")
    return Delassus(matrix=W, rhs=rhs, velocity_jump=velocity_jump, omega_jump=omega_jump,
                    moment=moment)


# ---- Darboux–Keller: the impact integrated in the normal impulse -----------------------------
@dataclass(frozen=True)
class DarbouxKeller:
    """The impact's rates in the normal impulse ``p`` for a constant W (``W_SYM``).

    The state along ``p`` is ``(v_X, v_Y, v_Z, P_X, P_Y, E_n, E_t)``: the velocity of S,
    the tangential impulse, the work of the normal impulse ``E_n = int v_Z dp`` and of
    friction ``E_t = int (v_t, dP_t)``.
    """
    slip_impulse_rate: sp.Matrix     # dP/dp while slipping along SIGMA
    slip_rate: sp.Matrix             # dv/dp = W dP/dp
    stick_tau: sp.Matrix             # dP_t/dp keeping v_t = 0 (2x2 closed form in W_SYM)
    stick_tau_by_z: sp.Matrix        # the same as z_t/z_Z with W z = e_Z
    stick_rate: sp.Matrix            # dv/dp while sticking: (0, 0, 1/z_Z)
    stick_margin: sp.Expr            # mu_f^2 - |tau|^2 >= 0: stick is possible
    ray_direction: sp.Matrix         # sigma(c) = (c 1 + mu_f W_tt)^-1 W_tn (2x2 closed form)
    ray_residual: sp.Expr            # |sigma(c)|^2 - 1: zero at the re-sliding ray
    ray_polynomial: sp.Poly          # its numerator, a quartic in c
    terminations: dict               # restitution model -> event expression (zero at the end)
    compression_end: sp.Expr         # v_Z (upward crossing)


@lru_cache(maxsize=None)
def darboux_keller() -> DarbouxKeller:
    """Slip, stick, re-sliding and the ends of compression and restitution.

    * Slip: Coulomb's law on the increments, ``dP_t = -mu_f sigma dp`` with
      ``sigma = v_t/|v_t|``, so ``dv/dp = W (e_Z - mu_f sigma)``.
    * Stick (``v_t = 0``): the increments must keep ``dv_t/dp = 0``, i.e. the tangential
      rows of ``W (tau, 1)`` vanish; with W positive definite this fixes ``tau``, and
      Coulomb's law on the increments admits it iff ``|tau| <= mu_f``.  With ``z`` the
      solution of ``W z = e_Z``, ``tau = z_t/z_Z`` and ``dv_Z/dp = 1/z_Z`` (the Schur
      complement of ``W_tt``, positive): sticking never jams.  W is constant during the
      impact, so once S sticks it sticks to the end.
    * Re-sliding from ``v_t = 0`` when stick is impossible: slip restarts along a ray
      ``v_t = c (p - p*) sigma`` with ``c > 0``, so ``c sigma = W_tn - mu_f W_tt sigma``:
      ``sigma(c) = (c 1 + mu_f W_tt)^-1 W_tn`` with ``|sigma(c)| = 1``.  ``|sigma(c)|^2``
      decreases strictly and convexly in ``c > 0`` (in the eigenbasis of W_tt it is
      ``sum b_i^2/(c + mu_f w_i)^2``) from ``|W_tt^-1 W_tn|^2/mu_f^2 > 1`` to 0: one
      root, which Newton's method from ``c = 0`` reaches monotonically.  The ray is an
      exact solution (the rate depends on the direction only), so S slides along it to
      the end of the impact.  In a plane motion it is the reversal of the slip.
    * Ends: compression where ``v_Z`` crosses 0 upwards (``p_c``, ``E_c`` recorded);
      restitution ends at ``E_n = (1 - e^2) E_c`` (``energetic``, Stronge: the normal
      impulse's work in restitution is ``-e^2`` times that in compression), at
      ``p = (1 + e) p_c`` (``poisson``) or at ``v_Z = -e v_n0`` (``newton``).
    """
    e_Z = sp.Matrix([0, 0, 1])
    sigma3 = sp.Matrix([SIGMA[0], SIGMA[1], 0])
    slip_impulse = e_Z - mu_f * sigma3
    slip_rate = W_SYM * slip_impulse
    # stick: tangential rows of W (tau_X, tau_Y, 1) vanish
    stick_eqs = (W_SYM * sp.Matrix([TAU[0], TAU[1], 1]))[:2, 0]
    sol = sp.solve(list(stick_eqs), list(TAU), dict=True)
    if len(sol) != 1:
        raise AssertionError("the stick rate is not unique")
    tau = sp.Matrix([sp.factor(sol[0][t]) for t in TAU])
    tau_z = sp.Matrix([Z_STICK[0] / Z_STICK[2], Z_STICK[1] / Z_STICK[2]])
    # check tau = z_t/z_Z with z = adj(W) e_Z / det(W) (plain symbols: a proof, not code)
    z_adj = W_SYM.adjugate()[:, 2]
    if not all(_zero(sp.together(a - b.xreplace(dict(zip(Z_STICK, z_adj))))
                     .as_numer_denom()[0]) for a, b in zip(tau, tau_z)):
        raise AssertionError("tau differs from z_t/z_Z")
    rate_n = (W_SYM * sp.Matrix([TAU[0], TAU[1], 1]))[2]
    schur = rate_n.xreplace(dict(zip(TAU, tau)))
    if not _zero(sp.together(schur * z_adj[2] / W_SYM.det() - 1).as_numer_denom()[0]):
        raise AssertionError("dv_Z/dp in stick is not 1/z_Z")
    stick_rate = sp.Matrix([0, 0, 1 / Z_STICK[2]])
    margin = mu_f ** 2 - (tau_z[0] ** 2 + tau_z[1] ** 2)
    # re-sliding ray
    W_tt, W_tn = W_SYM[:2, :2], W_SYM[:2, 2]
    sig = sp.Matrix(sp.symbols("s_1 s_2", real=True))
    ray = sp.solve(list((C_RAY * sp.eye(2) + mu_f * W_tt) * sig - W_tn), list(sig), dict=True)
    ray_dir = sp.Matrix([sp.factor(ray[0][s]) for s in sig])
    residual = ray_dir[0] ** 2 + ray_dir[1] ** 2 - 1
    numer, _ = sp.together(residual).as_numer_denom()
    poly = sp.Poly(sp.expand(numer), C_RAY)
    if poly.degree() != 4:
        raise AssertionError(f"the re-sliding equation has degree {poly.degree()}, not 4")
    # on the ray the slip rate is c sigma: the derived slip rate there
    on_ray = slip_rate[:2, 0].xreplace(dict(zip(SIGMA, ray_dir))) - C_RAY * ray_dir
    if not all(_zero(sp.together(c).as_numer_denom()[0]) for c in on_ray):
        raise AssertionError("sigma(c) is not a ray of the slip equations")
    terminations = {
        "energetic": E_N - (1 - nt.e ** 2) * E_C,
        "poisson": P_N - (1 + nt.e) * P_C,
        "newton": V_S[2] + nt.e * V_N0,
    }
    return DarbouxKeller(slip_impulse_rate=slip_impulse, slip_rate=slip_rate, stick_tau=tau,
                         stick_tau_by_z=tau_z, stick_rate=stick_rate, stick_margin=margin,
                         ray_direction=ray_dir, ray_residual=residual, ray_polynomial=poly,
                         terminations=terminations, compression_end=V_S[2])


# ---- contact: the acceleration of S and the two phases ----------------------------------------
@per_system
def acceleration_of_S(system: System) -> sp.Matrix:
    """``dv_S/dt`` (fixed axes) along the motion by the chain rule over everything
    ``v_S`` depends on: ``V_C' = ACC_C``, ``omega'`` (the symbols ``omega_dot``), ``A'``
    (E1.8), the law, and ``OS' = OS_rate`` (S moves over the surface as the body turns,
    :mod:`derive.surfaces`).  Checked to be ``ACC_C + A (omega' x CS) + rest``."""
    v = velocity_of_S(system)
    poisson = poisson_equations()
    rates = {**dict(zip(nt.V_C, ACC_C)), **dict(zip(nt.omega, nt.omega_dot)),
             **{nt.a[i, j]: poisson[i, j] for i in range(3) for j in range(3)},
             **system.rates(),
             **dict(zip(nt.OS, nt.OS_rate))}
    acc = sp.Matrix([sum((sp.diff(vi, s) * r for s, r in rates.items()), sp.Integer(0))
                     for vi in v])
    CS, _ = lever(system)
    if acc.jacobian(ACC_C) != sp.eye(3):
        raise AssertionError("dv_S/dt is not V_C' + ...")
    want = (nt.a * nt.cross(nt.omega_dot, CS)).jacobian(nt.omega_dot)
    if not all(_zero(c) for c in acc.jacobian(nt.omega_dot) - want):
        raise AssertionError("dv_S/dt is not A (omega' x CS) + ...")
    return acc


def _with_reaction(R: sp.Matrix, omega_dot: sp.Matrix, system: System) -> sp.Matrix:
    """``dv_S/dt`` with the momentum theorem's ``V_C' = R/(m+M) - g e_Z`` and the given
    ``omega'``."""
    M, m = nt.M, nt.m
    sol = sp.solve(list((m + M) * ACC_C - (-(m + M) * nt.g * nt.E_Z + R)), list(ACC_C),
                   dict=True)[0]
    acc_C = sp.Matrix([sol[c] for c in ACC_C])
    return acceleration_of_S(system).xreplace({**dict(zip(ACC_C, acc_C)),
                                         **dict(zip(nt.omega_dot, omega_dot))}), acc_C


@dataclass(frozen=True)
class StickingContact:
    """S at rest on the plane: ``v_S = 0`` held by ``R`` (fixed axes)."""
    acc_C: sp.Matrix           # R/(m+M) - g e_Z
    omega_dot: sp.Matrix       # omega'_0 + sum_k R_k Y_k
    a_free: sp.Matrix          # dv_S/dt with R = 0 (in omega'_0)
    matrix: sp.Matrix          # d(dv_S/dt)/dR: the Delassus matrix W
    forcing: sp.Matrix         # f of J omega'_0 = f (E1.7's forcing)


@per_system
def sticking_contact(system: System) -> StickingContact:
    """``dK/dt = CS x A^T R = sum_k R_k (CS x a_k)``, so ``omega' = omega'_0 + sum R_k
    Y_k`` with the same solves as :func:`delassus`; ``dv_S/dt = a_free + W R = 0``
    gives ``R`` by a solve with W (numeric in generated code)."""
    fd = flight_dynamics_structured(system)
    dl = delassus(system)
    moment = dl.moment.xreplace(dict(zip(P_IMP, R_VEC)))
    omega_dot = OMEGA_DOT_0 + sum((R_VEC[k] * Y[k] for k in range(3)), sp.zeros(3, 1))
    if not all(_zero(c) for c in moment - sum((R_VEC[k] * dl.rhs[k] for k in range(3)),
                                              sp.zeros(3, 1))):
        raise AssertionError("the moment of R is not sum R_k CS x a_k")
    acc, acc_C = _with_reaction(R_VEC, omega_dot, system)
    acc = acc.applyfunc(sp.expand)
    matrix = acc.jacobian(R_VEC)
    if not all(_zero(c) for c in matrix - dl.matrix):
        raise AssertionError("the contact's coefficient of R differs from the Delassus matrix")
    a_free = acc.xreplace({r: 0 for r in R_VEC})
    if not all(_zero(c) for c in acc - a_free - matrix * R_VEC):
        raise AssertionError("dv_S/dt is not affine in R")
    return StickingContact(acc_C=acc_C, omega_dot=omega_dot, a_free=a_free, matrix=dl.matrix,
                           forcing=fd.forcing)


@dataclass(frozen=True)
class SlidingContact:
    """S on the plane slipping along ``SIGMA`` (fixed horizontal axes, unit):
    ``R = N (e_Z - mu_f sigma)``."""
    reaction: sp.Matrix        # R in terms of N
    acc_C: sp.Matrix           # V_C' in terms of N
    omega_dot: sp.Matrix       # omega'_0 + N wf
    lever: sp.Matrix           # d - mu_f CS x A^T sigma: J wf = lever
    a_free: sp.Expr            # dv_n/dt at N = 0 (in omega'_0)
    k_f: sp.Expr               # dv_n/dt = a_free + N k_f; k_f = 1/(m+M) + (d, wf)
    normal_force: sp.Expr      # N = -a_free/k_f
    slip_acceleration: sp.Matrix   # dv_t/dt (X, Y) in terms of N
    forcing: sp.Matrix


@per_system
def sliding_contact(system: System) -> SlidingContact:
    """The momentum theorems with ``R = N (e_Z - mu_f sigma)`` and ``dv_n/dt = 0``.

    Valid while ``N >= 0`` and ``k_f > 0``; ``k_f = W_ZZ - mu_f (W_Zt, sigma)`` can turn
    non-positive for large ``mu_f`` (Painlevé's paradox: no consistent N), which the
    runtime must refuse."""
    fd = flight_dynamics_structured(system)
    _, d = lever(system)
    CS, _ = lever(system)
    N = nt.N
    sigma3 = sp.Matrix([SIGMA[0], SIGMA[1], 0])
    R = N * (nt.E_Z - mu_f * sigma3)
    moment = nt.cross(CS, nt.a.T * R)
    arm = d - mu_f * nt.cross(CS, nt.a.T * sigma3)
    if not all(_zero(c) for c in moment - N * arm):
        raise AssertionError("the moment of R is not N (d - mu_f CS x A^T sigma)")
    omega_dot = OMEGA_DOT_0 + N * W_SLIDE
    acc, acc_C = _with_reaction(R, omega_dot, system)
    a_n = sp.expand(acc[2])
    if sp.diff(a_n, N, 2) != 0:
        raise AssertionError("dv_n/dt is not affine in N")
    k_f = sp.diff(a_n, N)
    a_free = a_n.xreplace({N: 0})
    want_k = 1 / (nt.m + nt.M) + (d.T * W_SLIDE)[0]
    if not _zero(k_f - want_k):
        raise AssertionError("dv_n/dt's coefficient of N is not 1/(m+M) + (d, wf)")
    k_f = want_k                      # the compact form, proved equal above
    # solved on symbols (a big expression would go through simplify), then filled in
    a0, k0 = sp.symbols("a_0 k_0", real=True)
    normal = sp.solve(sp.Eq(a0 + N * k0, 0), N)[0].xreplace({a0: a_free, k0: k_f})
    return SlidingContact(reaction=R, acc_C=acc_C, omega_dot=omega_dot, lever=arm,
                          a_free=a_free, k_f=k_f, normal_force=normal,
                          slip_acceleration=acc[:2, 0], forcing=fd.forcing)


# ---- spin friction and rolling resistance: the contact's whole wrench ------------------------
T_VEC = sp.Matrix(sp.symbols("T_X T_Y T_Z", real=True))     # a couple on the body, fixed axes
# J YT_k = a_k: the unknowns of the solves for a couple about the fixed axis k
YT = tuple(sp.Matrix(sp.symbols(f"yt{k}_x yt{k}_y yt{k}_z", real=True)) for k in (1, 2, 3))
OMEGA_DOT_W = sp.Matrix(sp.symbols("omega_x'w omega_y'w omega_z'w", real=True))
WRENCH = sp.Matrix([*R_VEC, *T_VEC])
WRENCH_LABELS = ("R_X", "R_Y", "R_Z", "T_X", "T_Y", "T_Z")
RATE_LABELS = ("v_X", "v_Y", "v_Z", "Omega_X", "Omega_Y", "Omega_Z")


@dataclass(frozen=True)
class ContactWrench:
    """The contact's reaction as a wrench at S: the force ``R`` and a couple ``T`` (fixed
    axes), which spin (drilling) friction and rolling resistance exert (a contact patch's
    moment about S: ``|T_Z| <= mu_s N``, ``|(T_X, T_Y)| <= mu_r N``, mu_s and mu_r lengths).
    The contact's velocities ``u = (v_S, Omega)`` (the velocity of S and the body's angular
    velocity ``Omega = A omega``, fixed axes) change as ``du/dt = a_free + G (R, T)``."""
    velocity: sp.Matrix        # u = (v_S, A omega)
    matrix: sp.Matrix          # G, 6x6, in the unknowns Y_k and YT_k; G[:3, :3] = W
    a_free: sp.Matrix          # du/dt with no reaction (in omega'_0)
    rhs: tuple                 # CS x a_k (J Y_k = ...), then a_k (J YT_k = ...)
    acc_C: sp.Matrix           # R/(m+M) - g e_Z
    moment: sp.Matrix          # CS x A^T R + A^T T: J omega' = f + moment


@per_system
def contact_wrench(system: System) -> ContactWrench:
    """``dK/dt = CS x A^T R + A^T T`` (a couple adds its own moment, in body axes), so
    ``omega' = omega'_0 + sum R_k Y_k + sum T_k YT_k`` with ``J YT_k = a_k``; ``Omega' =
    A omega'`` (``A' omega = 0`` by E1.8, checked), and ``dv_S/dt`` is
    :func:`acceleration_of_S` with that ``omega'``.  Sticking contact is the case T = 0
    (its G block is W, checked)."""
    dl = delassus(system)
    CS, _ = lever(system)
    axes = tuple(_axis_in_body(k) for k in range(3))
    moment = nt.cross(CS, nt.a.T * R_VEC) + nt.a.T * T_VEC
    for k in range(3):
        if not all(_zero(c) for c in moment.diff(T_VEC[k]) - axes[k]):
            raise AssertionError("the moment of the couple T_k is not a_k")
    omega_dot = (OMEGA_DOT_0 + sum((R_VEC[k] * Y[k] for k in range(3)), sp.zeros(3, 1))
                 + sum((T_VEC[k] * YT[k] for k in range(3)), sp.zeros(3, 1)))
    acc, acc_C = _with_reaction(R_VEC, omega_dot, system)
    poisson = poisson_equations()
    a_dot = sp.Matrix(3, 3, lambda i, j: poisson[i, j])
    if not all(_zero(c) for c in a_dot * nt.omega):
        raise AssertionError("A' omega is not 0")
    # G and a_free from the rates as they stand (the products of the solves' unknowns with
    # A and CS, not multiplied out: a third fewer operations in the generated code)
    rates = sp.Matrix([*acc, *(nt.a * omega_dot)])
    G = rates.jacobian(WRENCH)
    a_free = rates.xreplace({w: 0 for w in WRENCH})
    if not all(_zero(c) for c in rates - a_free - G * WRENCH):
        raise AssertionError("du/dt is not affine in the wrench")
    if not all(_zero(c) for c in G[:3, :3] - dl.matrix):
        raise AssertionError("the force block of G differs from the Delassus matrix")
    velocity = sp.Matrix([*velocity_of_S(system), *(nt.a * nt.omega)])
    return ContactWrench(velocity=velocity, matrix=G, a_free=a_free, rhs=(*dl.rhs, *axes),
                         acc_C=acc_C, moment=moment)
