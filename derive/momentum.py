"""Flight: the momentum Q and the angular momentum K about C from their definitions, and
the theorems of momentum and angular momentum (E1.1) turned into E1.2–E1.7 and E1.9.

Definitions used (and nothing the paper prints):

* ``C`` is the centre of mass: ``OC = m/(m+M) OP`` (body axes).
* ``Q = M V_O + m V_P`` (absolute velocities, fixed axes).
* ``K`` about ``C`` is the sum over the system of ``rho x (d rho/dt)`` with ``rho`` the
  position relative to ``C``.  The carrier's own part about its centre ``O`` is
  ``diag(J_x, J_y, J_z) omega`` (``Oxyz`` are its principal central axes), so
  ``K = diag(J) omega + M rho_O x rho_O' + m rho_P x rho_P'``.
* The theorems in flight: ``dQ/dt = -(m+M) g e_Z`` and ``dK/dt = 0``.

Those definitions make the one-point :class:`~derive.system.System` (:func:`point_system`);
the theorems are then applied to any system's ``K = J omega + k`` (:func:`flight_dynamics`,
:func:`flight_dynamics_structured`, :func:`momentum_form`), and called without a system
they apply to this one.  Euler's form of E1.7 (:func:`flight_dynamics_euler`) is the one
point's own rewriting for the code.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache, wraps

import sympy as sp

from . import notation as nt
from .kinematics import absolute_rate_in_body_axes, centre_of_mass_offset_t
from .notation import (E_Z, MASS_FRACTION, J_x, J_y, J_z, M, OP_t, X_C_t, Y_C_t, Z_C_t, a_t,
                       cross, freeze, from_paper_notation, g, m, nu, omega, omega_dot,
                       omega_vec_t, t, thaw, to_paper_notation)
from .system import AngularMomentum, System

# the chain rule of the point's law: x -> x' -> x'' (x, y, z)
POINT_LAW_RATES = tuple(zip((nt.x, nt.y, nt.z, nt.xd, nt.yd, nt.zd),
                            (nt.xd, nt.yd, nt.zd, nt.xdd, nt.ydd, nt.zdd)))


@lru_cache(maxsize=None)
def _point_angular_momentum() -> AngularMomentum:
    """E1.4–E1.6 from the definition of K about C (K: E1.6 in paper notation, mu; J: E1.5;
    own: the part carried by the relative motion of P; K_vector: J_O omega + mu OP x (the
    absolute rate of OP))."""
    oc = centre_of_mass_offset_t()
    rho_O = -oc                       # O relative to C
    rho_P = OP_t - oc                 # P relative to C
    J_O = sp.diag(J_x, J_y, J_z)
    K_def = (J_O * omega_vec_t
             + M * cross(rho_O, absolute_rate_in_body_axes(rho_O))
             + m * cross(rho_P, absolute_rate_in_body_axes(rho_P)))
    K_def = freeze(K_def).xreplace({nu: MASS_FRACTION})     # OC = m/(m+M) OP
    K = K_def.applyfunc(to_paper_notation)
    J = K.jacobian(omega)
    own = (K - J * omega).applyfunc(sp.expand)
    if own.jacobian(omega) != sp.zeros(3, 3):
        raise AssertionError("K is not affine in omega")
    # The same definition, summed before expanding: O and P lie on the line OP through
    # C, rho = c OP with c constant, so each contributes (mass) c^2 OP x (OP)'_abs and
    # the two coefficients add up to one scalar.
    coefficient = sp.factor(M * (-MASS_FRACTION) ** 2 + m * (1 - MASS_FRACTION) ** 2)
    K_vec = freeze(J_O * omega_vec_t + to_paper_notation(coefficient)
                   * cross(OP_t, absolute_rate_in_body_axes(OP_t)))
    if (K_vec - K).applyfunc(lambda c: sp.expand(from_paper_notation(c))) != sp.zeros(3, 1):
        raise AssertionError("the summed form of K differs from the expanded one")
    return AngularMomentum(K=K, J=J, own=own, K_definition=K_def, K_vector=K_vec)


@lru_cache(maxsize=None)
def point_system() -> System:
    """The paper's system: the carrier and one point P of mass m on the law OP(t), with
    ``OC = m/(m+M) OP`` and K of E1.4–E1.6."""
    return System(name="point", oc=centre_of_mass_offset_t(),
                  momentum=_point_angular_momentum(), law_rates=POINT_LAW_RATES)


def per_system(fn):
    """A derivation of a :class:`~derive.system.System`, cached per system; called
    without one it derives the paper's (:func:`point_system`)."""
    cached = lru_cache(maxsize=None)(fn)

    @wraps(fn)
    def call(system: System | None = None):
        return cached(point_system() if system is None else system)

    call.cache_clear = cached.cache_clear
    return call


def angular_momentum(system: System | None = None) -> AngularMomentum:
    """K about C of a system (the paper's: E1.4–E1.6)."""
    return (point_system() if system is None else system).momentum


@dataclass(frozen=True)
class FlightDynamics:
    residual: sp.Matrix     # E1.7: dK~/dt + omega x K, linear in omega'
    mass_matrix: sp.Matrix  # coefficient of omega' (equals J)
    forcing: sp.Matrix      # J omega' = forcing along E1.7


@lru_cache(maxsize=None)
def relative_rate_equation():
    """E1.3: ``dK~/dt + omega x K = 0`` for generic body components ``K(t)``."""
    K_t = sp.Matrix([sp.Function(f"K_{c}", real=True)(t) for c in "xyz"])
    return K_t, absolute_rate_in_body_axes(K_t)


@per_system
def flight_dynamics(system: System) -> FlightDynamics:
    """E1.7: the angular-momentum theorem ``dK/dt = 0`` in body axes with K of E1.6 (of
    the system)."""
    K = angular_momentum(system).K
    residual = freeze(absolute_rate_in_body_axes(thaw(K)))
    residual = residual.applyfunc(lambda r: sp.collect(sp.expand(r), omega_dot))
    mass = residual.jacobian(omega_dot)
    forcing = -(residual - mass * omega_dot).applyfunc(sp.expand)
    if forcing.jacobian(omega_dot) != sp.zeros(3, 3):
        raise AssertionError("E1.7 is not linear in omega'")
    return FlightDynamics(residual=residual, mass_matrix=mass, forcing=forcing)


@per_system
def flight_dynamics_structured(system: System) -> FlightDynamics:
    """E1.7 with the same content, kept factored for code generation.

    E1.3 applied to ``K = J_O omega + mu OP x (V_r + omega x OP)`` (the definition
    summed before expanding) rather than to the expanded polynomial of E1.6: the cross
    products survive differentiation, and the operation count after CSE drops by about
    a seventh.  ``emit`` uses this form; ``tests`` check that it equals
    :func:`flight_dynamics`.
    """
    am = angular_momentum(system)
    residual = freeze(absolute_rate_in_body_axes(thaw(am.K_vector)))
    forcing = -residual.xreplace({w: 0 for w in omega_dot})
    mass = residual.jacobian(omega_dot)
    return FlightDynamics(residual=residual, mass_matrix=mass, forcing=forcing)


def _same(lhs: sp.Matrix, rhs: sp.Matrix, what: str) -> sp.Matrix:
    """``rhs`` after checking ``lhs == rhs`` by expansion (a step of a derivation)."""
    if (lhs - rhs).applyfunc(sp.expand) != sp.zeros(*lhs.shape):
        raise AssertionError(f"{what}: the two sides differ")
    return rhs


# named quantities of E1.7's Euler form: mu OP, and 2 mu OP.V_r (derive.models computes
# them first, so that the code forms each product once)
MU_OP = sp.Matrix(sp.symbols("muOP_x muOP_y muOP_z", real=True))
MU_OP_V = sp.Symbol("muOPV2", real=True)


@dataclass(frozen=True)
class EulerForm:
    """E1.7 as ``matrix omega' = forcing`` with the matrix a diagonal minus a rank-one
    term: ``matrix = diag(diagonal) - rank OP OP^T``.

    ``forcing`` is in Euler's form: the carrier's ``-omega x J_O omega`` (the components
    ``(J_y - J_z) omega_y omega_z, ...``), then what the point adds, with OP, V_r, A_r
    and omega in dot and cross products only (:func:`flight_dynamics_euler`).
    ``forcing`` and ``matrix`` read the named quantities of ``definitions``
    (:data:`MU_OP` = rank OP, :data:`MU_OP_V` = 2 rank OP.V_r); ``inline`` substitutes
    them.
    """
    diagonal: sp.Matrix     # 3 entries
    rank: sp.Expr
    vector: sp.Matrix       # OP
    forcing: sp.Matrix
    definitions: tuple      # ((symbol, value), ...)
    scale: sp.Expr          # this system is ``scale`` times E1.7 (1 or m + M)

    @property
    def matrix(self) -> sp.Matrix:
        """``diag(diagonal) - (rank OP) OP^T``, with rank OP named."""
        return sp.diag(*self.diagonal) - MU_OP * self.vector.T

    def inline(self, expr):
        return expr.xreplace(dict(self.definitions))


@lru_cache(maxsize=None)
def flight_dynamics_euler() -> EulerForm:
    """E1.7 in Euler's form, from the theorem of angular momentum applied to the summed
    K of E1.4, ``K = J_O omega + mu OP x U`` with ``U = V_r + omega x OP`` (the absolute
    rate of OP in body axes).  Each step is an identity of vector algebra, checked by
    expansion; the result is checked against :func:`flight_dynamics_structured`, and
    ``tests/test_momentum.py`` against :func:`flight_dynamics` (E1.6 expanded).

    E1.3 on each part of K (the relative rate plus ``omega x``), with ``OP' = V_r``,
    ``U' = A_r + omega' x OP + omega x V_r`` (both found by differentiating):

        J_O omega' + omega x J_O omega
          + mu [V_r x U + OP x U' + omega x (OP x U)] = 0.

    The terms in omega' are ``J_O omega' + mu OP x (omega' x OP) = J omega'``, and
    ``OP x (omega' x OP) = |OP|^2 omega' - OP (OP.omega')`` makes J (E1.5) the diagonal
    ``J_O + mu |OP|^2`` minus ``mu OP OP^T``.  Of the rest, ``V_r x U = V_r x (omega x
    OP)``, and by Jacobi's identity ``V_r x (omega x OP) + omega x (OP x V_r) = OP x
    (omega x V_r)``, so the three terms in V_r and omega are ``2 OP x (omega x V_r) =
    2 (OP.V_r) omega - 2 (OP.omega) V_r``; and ``omega x (OP x (omega x OP)) = -(OP.omega)
    omega x OP``.  So

        J omega' = -omega x J_O omega - mu OP x A_r
                   + (OP.omega) (2 mu V_r + omega x mu OP) - 2 mu (OP.V_r) omega.

    The forcing is linear in ``(J_x, J_y, J_z, mu)`` jointly and so is J: times
    ``m + M`` the system reads the same with ``J_i -> (m + M) J_i`` and ``mu -> mM``
    (``scaled``), which needs no division for mu."""
    from .notation import A_r, OP, V_r, dot, mu, omega as w, omega_dot as wd, skew
    J_O = sp.diag(J_x, J_y, J_z)
    U = V_r + cross(w, OP)
    # OP' and U' by differentiating the time functions (body components)
    OP_rate = freeze(OP_t.diff(t))
    U_t = thaw(U)
    U_rate = _same(freeze(U_t.diff(t)), A_r + cross(wd, OP) + cross(w, V_r), "U'")
    K = J_O * w + mu * cross(OP, U)
    _same(K, angular_momentum().K_vector, "K = J_O omega + mu OP x U")
    # E1.3 part by part: the relative rate of J_O omega and of OP x U, plus omega x K
    residual = (J_O * wd + cross(w, J_O * w)
                + mu * (cross(OP_rate, U) + cross(OP, U_rate) + cross(w, cross(OP, U))))
    _same(residual, flight_dynamics_structured().residual, "E1.3 applied to K")
    # the terms in omega': J omega', J a diagonal minus a rank-one term
    r2 = dot(OP, OP)
    J_wd = _same(J_O * wd + mu * cross(OP, cross(wd, OP)),
                 J_O * wd + mu * (r2 * wd - OP * dot(OP, wd)), "OP x (omega' x OP)")
    diagonal = sp.Matrix([J_x + mu * r2, J_y + mu * r2, J_z + mu * r2])
    _same(J_wd, (sp.diag(*diagonal) - mu * OP * OP.T) * wd, "J = diag - mu OP OP^T")
    # the rest, identity by identity
    three = _same(cross(V_r, cross(w, OP)) + cross(OP, cross(w, V_r)) + cross(w, cross(OP, V_r)),
                  2 * cross(OP, cross(w, V_r)), "Jacobi's identity")
    three = _same(three, 2 * dot(OP, V_r) * w - 2 * dot(OP, w) * V_r, "OP x (omega x V_r)")
    spin = _same(cross(w, cross(OP, cross(w, OP))), -dot(OP, w) * cross(w, OP),
                 "omega x (OP x (omega x OP))")
    rest = _same(residual - J_wd,
                 cross(w, J_O * w) + mu * cross(OP, A_r) + mu * three + mu * spin,
                 "the terms without omega'")
    # -omega x J_O omega: Euler's terms, (J_y - J_z) omega_y omega_z, ...
    carrier = (-skew(w) * J_O * w).applyfunc(sp.factor)
    forcing = (carrier - cross(MU_OP, A_r)
               + dot(OP, w) * (2 * mu * V_r + cross(w, MU_OP)) - MU_OP_V * w)
    definitions = tuple(zip(MU_OP, mu * OP)) + ((MU_OP_V, 2 * mu * dot(OP, V_r)),)
    form = EulerForm(diagonal=diagonal, rank=mu, vector=OP, forcing=forcing,
                     definitions=definitions, scale=sp.Integer(1))
    _same(form.inline(forcing), -rest, "the forcing")
    _same(form.inline(form.matrix), sp.diag(*diagonal) - mu * OP * OP.T, "the matrix")
    return form


@lru_cache(maxsize=None)
def flight_dynamics_euler_scaled() -> EulerForm:
    """:func:`flight_dynamics_euler` times ``m + M``: ``J_i -> (m + M) J_i`` and ``mu ->
    mM`` (both sides are linear in ``(J_x, J_y, J_z, mu)`` jointly), so that the
    emitted code divides once, in the solve, and never for mu."""
    from .notation import MU_DEFINITION, mu
    ef = flight_dynamics_euler()
    scale = M + m
    rank = M * m
    if sp.cancel(scale * MU_DEFINITION - rank) != 0:
        raise AssertionError("(m + M) mu != mM")
    sub = {J_x: scale * J_x, J_y: scale * J_y, J_z: scale * J_z, mu: rank}
    return EulerForm(diagonal=ef.diagonal.xreplace(sub), rank=rank, vector=ef.vector,
                     forcing=ef.forcing.xreplace(sub),
                     definitions=tuple((s, v.xreplace(sub)) for s, v in ef.definitions),
                     scale=scale)


@lru_cache(maxsize=None)
def centre_of_mass_motion():
    """E1.1 (momentum) -> E1.2.

    Returns ``(Q, r_C'', Q - (m+M) r_C')`` where the last is identically zero: the
    momentum of the system is carried by its centre of mass.
    """
    r_O = sp.Matrix([sp.Function(f"{c}_O", real=True)(t) for c in "XYZ"])
    r_P = r_O + a_t * OP_t
    Q = M * r_O.diff(t) + m * r_P.diff(t)
    r_C_t = (M * r_O + m * r_P) / (m + M)
    lemma = (Q - (m + M) * r_C_t.diff(t)).applyfunc(sp.simplify)
    # theorem of momentum: dQ/dt = -(m+M) g e_Z, with Q = (m+M) r_C'
    r_C = sp.Matrix([X_C_t, Y_C_t, Z_C_t])
    acc = sp.Matrix([sp.Derivative(c, (t, 2)) for c in r_C])
    theorem = (m + M) * acc - (-(m + M) * g * E_Z)
    sol = sp.solve(list(theorem), list(acc), dict=True)[0]
    return Q, freeze(sp.Matrix([sol[c] for c in acc])), lemma


@per_system
def integral_of_kinetic_moment(system: System) -> sp.Expr:
    """The quantity of E1.9, ``K_x^2 + K_y^2 + K_z^2``."""
    K = angular_momentum(system).K
    return sp.expand(sum((k ** 2 for k in K), sp.Integer(0)))


# ---- the momentum form of the flight ---------------------------------------------------------
K_X, K_Y, K_Z = sp.symbols("K_X K_Y K_Z", real=True)      # K about C, fixed axes
K_FIXED = sp.Matrix([K_X, K_Y, K_Z])
k_x, k_y, k_z = sp.symbols("k_x k_y k_z", real=True)      # K about C, body axes (given)
K_BODY = sp.Matrix([k_x, k_y, k_z])


@dataclass(frozen=True)
class MomentumForm:
    """Flight on the integral: K in fixed axes is a constant of each flight (E1.1), so the
    attitude alone is integrated, with omega from E1.4 solved (``J omega = A^T K - own``).

    ``J omega = body_rhs`` holds with ``body_rhs = K_BODY - own`` for ``K_BODY = A^T K``
    (the fixed K seen in body axes); ``attitude_rate`` is Poisson's ``A' = A skew(omega)``
    (E1.8).  ``omega_rate_rhs``: along the momentum form, ``J omega' = omega_rate_rhs``
    (d/dt of ``J omega + own = A^T K`` with ``A' = A skew(omega)``), which
    ``tests/test_momentum_form.py`` proves equal to E1.7's forcing.
    """
    J: sp.Matrix
    own: sp.Matrix
    body_rhs: sp.Matrix
    fixed: sp.Matrix            # A (J omega + own): K in fixed axes from the state
    omega_rate_rhs: sp.Matrix


@per_system
def momentum_form(system: System) -> MomentumForm:
    from .notation import a, omega as w, skew
    am = angular_momentum(system)
    J, own = am.J, am.own
    body_rhs = K_BODY - own
    fixed = a * (J * w + own)
    # J omega + own = A^T K: differentiate with A' = A skew(omega), K constant:
    # (A^T)' K = -skew(omega) A^T K = -omega x (J omega + own)
    K_seen = J * w + own
    omega_rate_rhs = (-skew(w) * K_seen - J.applyfunc(system.law_rate) * w
                      - own.applyfunc(system.law_rate))
    return MomentumForm(J=J, own=own, body_rhs=body_rhs, fixed=fixed,
                        omega_rate_rhs=omega_rate_rhs.applyfunc(sp.expand))


TAU = sp.Symbol("tau", nonnegative=True)       # time since the start of the flight


@lru_cache(maxsize=None)
def flight_parabola() -> tuple[sp.Matrix, sp.Matrix]:
    """E1.2 integrated from the start of a flight: ``(r_C(tau), r_C'(tau))`` in terms of
    the position and velocity of C at ``tau = 0`` (the symbols X_C, ..., Z_C')."""
    from .notation import R_C, V_C
    _, acc, _ = centre_of_mass_motion()
    s = sp.Symbol("s", nonnegative=True)
    velocity = V_C + acc.applyfunc(lambda c: sp.integrate(c, (s, 0, TAU)))
    position = R_C + velocity.applyfunc(lambda c: sp.integrate(c.xreplace({TAU: s}),
                                                                (s, 0, TAU)))
    return position.applyfunc(sp.expand), velocity.applyfunc(sp.expand)
