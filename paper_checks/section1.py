"""Section 1: the derived equations of flight and impact equal the printed ones."""
from __future__ import annotations

import sympy as sp

from derive import notation as nt
from derive.impact import K_SYMBOL, V_N_MINUS, impact_map, lever
from derive.kinematics import carrier_centre_position, poisson_equations
from derive.momentum import (angular_momentum, centre_of_mass_motion, flight_dynamics,
                             integral_of_kinetic_moment, relative_rate_equation)

from . import printed as P
from .exact import LinearDefinition, assert_numeric, assert_same, assert_zero, is_same
from .registry import CheckFailed, Report, check


def paper(expr):
    """Derived expressions carry the symbols mu and nu; the paper writes mM/(m+M) and
    m/(m+M)."""
    return nt.from_paper_notation(expr) if hasattr(expr, "xreplace") else expr


# w = J^-1 d with the printed J of (1.5) and the printed d of (1.10)
W_IS_JINV_D = LinearDefinition(nt.W, P.E1_5.xreplace({nt.mu: P.MU}), P.E1_10_D)


@check("E1.1")
def e1_1(r: Report) -> None:
    _, _, lemma = centre_of_mass_motion()
    assert_zero("Q - (m+M) V_C", lemma)
    # dK/dt = 0 about C: the moment of gravity about C vanishes, sum m_i rho_i = 0
    oc = nt.MASS_FRACTION * nt.OP
    first_moment = nt.M * (-oc) + nt.m * (nt.OP - oc)
    assert_zero("moment of gravity about C", first_moment)
    # the printed force of (1.1) is what the derivation applies
    _, acc, _ = centre_of_mass_motion()
    assert_same("E1.1 force", (nt.m + nt.M) * acc, P.E1_1_FORCE)
    r.detail = "Q = (m+M) V_C; gravity has no moment about C"


@check("E1.2")
def e1_2(r: Report) -> None:
    assert_same("E1.2", centre_of_mass_motion()[1], P.E1_2)


@check("E1.3")
def e1_3(r: Report) -> None:
    _, lhs = relative_rate_equation()
    assert_same("E1.3", lhs, P.E1_3)


@check("E1.4")
def e1_4(r: Report) -> None:
    K = angular_momentum().K
    assert_same("E1.4", paper(K), paper(P.E1_4).xreplace({nt.mu: P.MU}))
    # and K really is the definition's: the mu form equals the M, m form
    assert_same("E1.4 (definition)", paper(K), angular_momentum().K_definition)


@check("E1.5")
def e1_5(r: Report) -> None:
    assert_same("E1.5", paper(angular_momentum().J), P.E1_5.xreplace({nt.mu: P.MU}))


@check("E1.6")
def e1_6(r: Report) -> None:
    assert_same("E1.6", paper(angular_momentum().K), P.E1_6.xreplace({nt.mu: P.MU}))


@check("E1.7")
def e1_7(r: Report) -> None:
    assert_same("E1.7", paper(flight_dynamics().residual), P.E1_7.xreplace({nt.mu: P.MU}))


@check("E1.8")
def e1_8(r: Report) -> None:
    assert_same("E1.8", poisson_equations(), P.E1_8)


@check("E1.8a")
def e1_8a(r: Report) -> None:
    _, r_O = carrier_centre_position()
    assert_same("E1.8a", r_O, P.E1_8A)


@check("E1.9")
def e1_9(r: Report) -> None:
    V = integral_of_kinetic_moment()
    assert_same("E1.9 (the quantity)", paper(V), P.E1_9.xreplace({nt.mu: P.MU}))
    # dV/dt along E1.7: d/dt |K|^2 = 2 K . dK~/dt = 2 K . (residual - omega x K)
    # = 2 K . residual, which vanishes where E1.7 holds.
    K = angular_momentum().K
    residual = flight_dynamics().residual
    dV = nt.freeze(nt.thaw(V).diff(nt.t))
    identity = dV - 2 * (K.T * residual)[0]
    assert_zero("dV/dt - 2 (K, E1.7)", paper(identity))
    r.detail = "d|K|^2/dt = 2 (K, E1.7 residual) identically"


@check("E1.10")
def e1_10(r: Report) -> None:
    CS, d = lever()
    assert_same("E1.10 d", paper(d), P.E1_10_D)
    # the angular impulse about C of the vertical impulse I n applied at S is I d
    assert_same("E1.10 moment", paper(nt.cross(CS, nt.I * nt.n)), nt.I * P.E1_10_D)


@check("E1.11")
def e1_11(r: Report) -> None:
    assert_same("E1.11", impact_map().velocity_jump, P.E1_11_JUMP)


@check("E1.12")
def e1_12(r: Report) -> None:
    derived_rhs = impact_map().omega_plus          # omega- + I w,  J w = d
    printed_lhs, printed_rhs = P.E1_12_AS_PRINTED
    if is_same(derived_rhs, printed_rhs):
        raise CheckFailed("E1.12: expected the printed dots over omega, found none")
    undotted = printed_rhs.xreplace(dict(zip(printed_lhs, P.omega)))
    assert_same("E1.12 (without the dots)", derived_rhs, undotted)
    # with the printed K of (1.6): K+ - K- - I d = I (J w - d), zero exactly when
    # w = J^-1 d (the numeric stage solves for w at each point and gets zero)
    K_plus = P.E1_6.xreplace(dict(zip(P.omega, derived_rhs)))
    residual = (K_plus - P.E1_6).xreplace({nt.mu: P.MU}) - nt.I * P.E1_10_D
    J_p = P.E1_5.xreplace({nt.mu: P.MU})
    assert_same("E1.12 in K+ - K- = I d", residual, nt.I * (J_p * nt.W - P.E1_10_D),
                given=W_IS_JINV_D)
    r.erratum(printed="omega-dot+ = omega-dot- + I J^-1 d  (1.12)",
              correct="omega+ = omega- + I J^-1 d",
              consequence="typographic only: the jump is of omega itself (the "
                          "angular-momentum jump I d is finite, omega-dot has a delta)")


@check("E1.13")
def e1_13(r: Report) -> None:
    im = impact_map()
    # apply the derived map with the derived impulse (k kept as a symbol, then replaced,
    # so that the identity is checked on a polynomial numerator)
    impulse = im.impulse.xreplace({V_N_MINUS: im.normal_velocity})
    post = im.normal_velocity.xreplace({
        nt.Z_Cd: nt.Z_Cd + im.velocity_jump[2].xreplace({nt.I: impulse}),
        **{nt.omega[i]: im.omega_plus[i].xreplace({nt.I: impulse}) for i in range(3)}})
    newton = sp.numer(sp.together(paper(post - P.E1_13(im.normal_velocity))))
    assert_zero("v_n+ + e v_n-", newton.xreplace({K_SYMBOL: paper(im.k)}))
    assert_numeric("E1.13", paper(post.xreplace({K_SYMBOL: im.k})),
                   paper(P.E1_13(im.normal_velocity)), given=W_IS_JINV_D)


@check("E1.14")
def e1_14(r: Report) -> None:
    assert_same("E1.14", paper(impact_map().normal_velocity), P.E1_14)


@check("E1.15")
def e1_15(r: Report) -> None:
    im = impact_map()
    derived = im.impulse.xreplace({V_N_MINUS: im.normal_velocity, K_SYMBOL: im.k})
    assert_same("E1.15", paper(derived), P.E1_15, given=W_IS_JINV_D)


@check("E1.16")
def e1_16(r: Report) -> None:
    assert_same("E1.16", paper(impact_map().k), P.E1_16, given=W_IS_JINV_D)


@check("R1")
def r1(r: Report) -> None:
    """J is positive definite whenever the carrier's J_x, J_y, J_z are: for any v,
    v^T J v = J_x v_x^2 + J_y v_y^2 + J_z v_z^2 + mu |OP x v|^2, so det J != 0."""
    J = angular_momentum().J
    v = sp.Matrix(sp.symbols("v_1:4", real=True))
    quad = (v.T * J * v)[0]
    carrier = nt.J_x * v[0]**2 + nt.J_y * v[1]**2 + nt.J_z * v[2]**2
    rv = nt.cross(nt.OP, v)
    assert_zero("v^T J v - v^T J_O v - mu |OP x v|^2", quad - carrier - nt.mu * (rv.T * rv)[0])
    r.detail = "J = J_O + mu (|OP|^2 1 - OP OP^T) is positive definite; checked at run time"
