"""Impact with the smooth plane (E1.10–E1.16) from classical impact theory.

Starting point (E1.10, E1.13): during the impact the positions, the orientation and the
relative velocity ``V_r`` of P do not change; the only impulsive force is the vertical
impulse ``I n`` applied at the body point S; so

    Q+ - Q- = I e_Z          (theorem of momentum, integrated over the impact)
    K+ - K- = CS x (I n)     (theorem of angular momentum about C)
    v_n+ = -e v_n-           (Newton's law for the normal velocity of S)

Everything else follows here, for any :class:`~derive.system.System` (OC and K = J omega
+ k are the system's; called without one, the paper's).  ``J^-1 d`` is never formed: it
appears as the unknown ``w`` with ``J w = d``, which generated code solves numerically.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .kinematics import absolute_rate_in_body_axes
from .momentum import angular_momentum, per_system
from .system import System
from .notation import E_Z, OS, V_C, W, Z_Cd, I, M, a, cross, dot, e, freeze, m, n, omega


@per_system
def lever(system: System) -> tuple[sp.Matrix, sp.Matrix]:
    """``CS = OS - OC`` and ``d = CS x n`` (E1.10), body axes."""
    CS = OS - freeze(system.oc)
    return CS, cross(CS, n)


@per_system
def contact_point_velocity(system: System) -> sp.Matrix:
    """Absolute velocity of the body point S in fixed axes (E1.14's starting point).

    ``O_aO = O_aC - A OC`` (definition of C) so ``V_O = V_C - d/dt(A OC)``; S is a
    point of the body, so ``V_S = V_O + A (omega x OS)``.  Time derivatives of ``A``
    are taken through the relative rate: ``d/dt(A b) = A (b' + omega x b)``.
    """
    oc_t = system.oc
    V_O = V_C - a * freeze(absolute_rate_in_body_axes(oc_t))
    return V_O + a * cross(omega, OS)


@per_system
def normal_velocity(system: System) -> sp.Expr:
    """E1.14: ``v_n = (V_S, e_Z)``, the rate of the height of S."""
    return sp.expand(dot(contact_point_velocity(system), E_Z))


@per_system
def height(system: System) -> sp.Expr:
    """Height of S above the plane: the Z component of ``O_aC + A CS``."""
    from .notation import R_C
    CS, _ = lever(system)
    return sp.expand((R_C + a * CS)[2])


V_N_MINUS = sp.Symbol("v_n-", real=True)   # normal velocity of S just before impact
K_SYMBOL = sp.Symbol("k", positive=True)     # the coefficient of E1.16


@dataclass(frozen=True)
class ImpactMap:
    velocity_jump: sp.Matrix     # E1.11: (X_C', Y_C', Z_C')+ - (...)-  (fixed axes)
    omega_jump_system: tuple     # E1.12 before solving: (J, I d): J (omega+ - omega-) = I d
    omega_plus: sp.Matrix        # E1.12: omega- + I w, with J w = d
    v_n_jump: sp.Expr            # v_n+ - v_n- = I k
    k: sp.Expr                   # E1.16
    impulse: sp.Expr             # E1.15, in terms of the symbols V_N_MINUS and K_SYMBOL
    normal_velocity: sp.Expr     # E1.14 (at the pre-impact state)


@per_system
def impact_map(system: System) -> ImpactMap:
    am = angular_momentum(system)
    J, own = am.J, am.own
    _, d = lever(system)

    # momentum: Q = (m+M) V_C (E1.2's lemma) and Q+ - Q- = I e_Z
    dV = sp.Matrix(sp.symbols("dX_C' dY_C' dZ_C'", real=True))
    sol = sp.solve(list((m + M) * dV - I * E_Z), list(dV), dict=True)[0]
    velocity_jump = sp.Matrix([sol[c] for c in dV])

    # angular momentum: K = J omega + own with J, own unchanged by the impact
    w_plus = sp.Matrix(sp.symbols("omega_x+ omega_y+ omega_z+", real=True))
    K_minus = J * omega + own
    K_plus = J * w_plus + own
    jump = (K_plus - K_minus - I * d).applyfunc(sp.expand)
    # jump = J (omega+ - omega-) - I d: linear in omega+ with matrix J
    if jump.jacobian(w_plus).applyfunc(sp.expand) != J.applyfunc(sp.expand):
        raise AssertionError("angular impulse equation is not J-linear in omega+")
    omega_plus = omega + I * W             # with J W = d: J (omega + I W) - J omega = I d

    # normal velocity of S before and after: V_r, n, d unchanged; Z_C' and omega jump
    v_n = normal_velocity(system)
    v_n_plus = v_n.xreplace({Z_Cd: Z_Cd + velocity_jump[2],
                             **{omega[i]: omega_plus[i] for i in range(3)}})
    v_n_jump = sp.expand(v_n_plus - v_n)
    k = sp.expand(v_n_jump / I)
    if k.has(I):
        raise AssertionError("the jump of v_n is not proportional to I")
    # Newton's law, with v_n+ = v_n- + I k
    impulse = sp.solve(sp.Eq(V_N_MINUS + I * K_SYMBOL, -e * V_N_MINUS), I)[0]
    return ImpactMap(velocity_jump=velocity_jump, omega_jump_system=(J, I * d),
                     omega_plus=omega_plus, v_n_jump=v_n_jump, k=k, impulse=impulse,
                     normal_velocity=v_n)
