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
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp

from .kinematics import absolute_rate_in_body_axes, centre_of_mass_offset_t
from .notation import (E_Z, MASS_FRACTION, J_x, J_y, J_z, M, OP_t, X_C_t, Y_C_t, Z_C_t, a_t,
                       cross, freeze, from_paper_notation, g, m, nu, omega, omega_dot,
                       omega_vec_t, t, thaw, to_paper_notation)


@dataclass(frozen=True)
class AngularMomentum:
    K: sp.Matrix          # E1.6: components in body axes, paper notation (mu)
    J: sp.Matrix          # E1.5: dK/d omega
    own: sp.Matrix        # K - J omega: the part carried by the relative motion of P
    K_definition: sp.Matrix   # straight from the definition, in M and m
    K_vector: sp.Matrix   # the same K kept as J_O omega + mu OP x (absolute rate of OP)


@lru_cache(maxsize=None)
def angular_momentum() -> AngularMomentum:
    """E1.4–E1.6 from the definition of K about C."""
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


@lru_cache(maxsize=None)
def flight_dynamics() -> FlightDynamics:
    """E1.7: the angular-momentum theorem ``dK/dt = 0`` in body axes with K of E1.6."""
    K = angular_momentum().K
    residual = freeze(absolute_rate_in_body_axes(thaw(K)))
    residual = residual.applyfunc(lambda r: sp.collect(sp.expand(r), omega_dot))
    mass = residual.jacobian(omega_dot)
    forcing = -(residual - mass * omega_dot).applyfunc(sp.expand)
    if forcing.jacobian(omega_dot) != sp.zeros(3, 3):
        raise AssertionError("E1.7 is not linear in omega'")
    return FlightDynamics(residual=residual, mass_matrix=mass, forcing=forcing)


@lru_cache(maxsize=None)
def flight_dynamics_structured() -> FlightDynamics:
    """E1.7 with the same content, kept factored for code generation.

    E1.3 applied to ``K = J_O omega + mu OP x (V_r + omega x OP)`` (the definition
    summed before expanding) rather than to the expanded polynomial of E1.6: the cross
    products survive differentiation, and the operation count after CSE drops by about
    a seventh.  ``emit`` uses this form; ``tests`` check that it equals
    :func:`flight_dynamics`.
    """
    am = angular_momentum()
    residual = freeze(absolute_rate_in_body_axes(thaw(am.K_vector)))
    forcing = -residual.xreplace({w: 0 for w in omega_dot})
    mass = residual.jacobian(omega_dot)
    return FlightDynamics(residual=residual, mass_matrix=mass, forcing=forcing)


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


@lru_cache(maxsize=None)
def integral_of_kinetic_moment() -> sp.Expr:
    """The quantity of E1.9, ``K_x^2 + K_y^2 + K_z^2``."""
    K = angular_momentum().K
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


def _law_rate(expr):
    """d/dt of an expression in the point's law (x, x', ...) and nothing else moving."""
    from .notation import xd, xdd, yd, ydd, zd, zdd, x, y, z
    chain = ((x, xd), (y, yd), (z, zd), (xd, xdd), (yd, ydd), (zd, zdd))
    return sum((sp.diff(expr, s) * r for s, r in chain), sp.Integer(0))


@lru_cache(maxsize=None)
def momentum_form() -> MomentumForm:
    from .notation import a, omega as w, skew
    am = angular_momentum()
    J, own = am.J, am.own
    body_rhs = K_BODY - own
    fixed = a * (J * w + own)
    # J omega + own = A^T K: differentiate with A' = A skew(omega), K constant:
    # (A^T)' K = -skew(omega) A^T K = -omega x (J omega + own)
    K_seen = J * w + own
    omega_rate_rhs = (-skew(w) * K_seen - J.applyfunc(_law_rate) * w
                      - own.applyfunc(_law_rate))
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
