"""Section 4: plane motions and stationary rotations (E4.1, E4.2, E4.4–E4.6, C4.1–C4.3)."""
from __future__ import annotations

import sympy as sp

from derive import notation as nt
from derive import reduced
from derive.momentum import angular_momentum, flight_dynamics

from . import printed as P
from .exact import assert_same, assert_zero
from .laws import IN_PLANE, ON_AXIS, stationary_about_z, with_law
from .registry import Report, check

PLANE_ROTATION = {nt.omega_x: 0, nt.omega_y: 0, nt.omega_xd: 0, nt.omega_yd: 0}


def stationary_conditions() -> sp.Matrix:
    """E1.7 at omega = (0, 0, omega), omega' = 0, divided by mu."""
    res = stationary_about_z(flight_dynamics().residual, P.omega_s)
    return (res / nt.mu).applyfunc(sp.expand)


@check("E4.1")
def e4_1(r: Report) -> None:
    res = flight_dynamics().residual.xreplace(IN_PLANE).xreplace(PLANE_ROTATION)
    assert_zero("x and y equations with z = 0, omega_x = omega_y = 0", res[:2, 0])
    assert_same("E4.1 (4.1)", res[2], P.E4_1)
    r.detail = "with z = 0 the x, y equations vanish identically at omega_x = omega_y = 0"


@check("E4.2")
def e4_2(r: Report) -> None:
    Kz = angular_momentum().K[2].xreplace(IN_PLANE).xreplace(PLANE_ROTATION)
    assert_same("E4.2 (4.2) is K_z", Kz, P.E4_2)
    rate = nt.freeze(nt.thaw(P.E4_2).diff(nt.t))
    assert_same("d/dt (4.2) = (4.1)", rate, P.E4_1)
    # omega_z algebraically: derive.reduced solves K_z = kappa; it satisfies (4.2)
    pl = reduced.planar()
    assert_same("(4.2) at the derived omega_z", P.E4_2.xreplace({nt.omega_z: pl.omega_z}),
                pl.kappa)
    r.show("omega_z", pl.omega_z)
    r.detail = f"d/dt of (4.2) is (4.1); omega_z = {sp.sstr(pl.omega_z)}"


@check("E4.4")
def e4_4(r: Report) -> None:
    assert_same("E4.4 (4.4)", stationary_conditions()[0], P.E4_4)
    r.show("E1.7 at omega = (0, 0, omega), divided by mu", stationary_conditions())


@check("E4.5")
def e4_5(r: Report) -> None:
    assert_same("E4.5 (4.5)", stationary_conditions()[1], P.E4_5)


@check("E4.6")
def e4_6(r: Report) -> None:
    assert_same("E4.6 (4.6)", stationary_conditions()[2], P.E4_6)


@check("C4.1")
def c4_1(r: Report) -> None:
    assert_zero("(4.4)-(4.6) with x = y = 0", stationary_conditions().xreplace(ON_AXIS))
    r.detail = "any z(t), any J_x, J_y, J_z"


@check("C4.2")
def c4_2(r: Report) -> None:
    law = dict(zip((nt.x, nt.y), P.E4_7_XY))
    conditions = with_law(stationary_conditions(), law).xreplace({nt.zdd: P.E4_7_ZDD})
    assert_zero("(4.4)-(4.6) under (4.7)", conditions)
    r.detail = "x = x0, y = y0 and z'' = -omega^2 z make (4.4)-(4.6) vanish"


@check("C4.3")
def c4_3(r: Report) -> None:
    t = nt.t
    law = dict(zip((nt.x, nt.y), P.E4_8_XY))
    conditions = with_law(stationary_conditions(), law).xreplace({nt.zdd: P.E4_8_ZDD})
    assert_zero("(4.4)-(4.6) under (4.8)", conditions.applyfunc(sp.simplify))
    # the trajectory: on the cylinder x^2 + y^2 = R^2, closed with period 4 pi/omega
    w = sp.Symbol("omega", positive=True)      # the period is 4 pi/|omega|
    x_t, y_t = (c.xreplace({P.omega_s: w}) for c in P.E4_8_XY)
    assert_zero("x^2 + y^2 - R^2", sp.simplify(x_t**2 + y_t**2 - P.R_cyl**2))
    z_f = sp.Function("z")
    zdd_rule = P.E4_8_ZDD.xreplace({P.omega_s: w, nt.z: z_f(t)})
    general = sp.dsolve(sp.Eq(z_f(t).diff(t, 2), zdd_rule), z_f(t)).rhs
    period = 4 * sp.pi / w
    for comp in (x_t, y_t, general):
        assert_zero("periodic", sp.simplify(sp.expand_trig(comp.subs(t, t + period) - comp)))
    # and the rotation rate is twice the point's angular frequency omega/2
    r.detail = ("(4.4)-(4.6) vanish; x^2 + y^2 = R^2; x, y, z all 4 pi/omega-periodic: a "
                "closed curve on the cylinder, traversed at omega/2 while the body turns at omega")
