"""Section 2: translational motion of the carrier (C2.1–C2.5)."""
from __future__ import annotations

import sympy as sp

from derive import notation as nt
from derive.impact import impact_map, lever
from derive.momentum import angular_momentum, flight_dynamics, integral_of_kinetic_moment
from derive.surfaces import center, ellipsoid, radius, sphere

from . import printed as P
from .exact import assert_same, assert_zero
from .laws import at_rest, with_law
from .registry import Report, check


def translational_conditions() -> sp.Matrix:
    """E1.7 with omega = omega' = 0, divided by mu: what the point law must satisfy."""
    return (at_rest(flight_dynamics().residual) / nt.mu).applyfunc(sp.expand)


@check("C2.1")
def c2_1(r: Report) -> None:
    conditions = translational_conditions()
    assert_same("C2.1 (2.1)", conditions, P.E2_1)
    r.show("E1.7 at omega = 0, divided by mu", conditions)
    r.detail = "E1.7 at omega = 0 is mu (y z'' - z y'', ...) = 0; mu > 0"


@check("C2.2")
def c2_2(r: Report) -> None:
    law = dict(zip((nt.x, nt.y, nt.z), P.E2_2))
    assert_zero("(2.1) under (2.2)", with_law(translational_conditions(), law))
    r.detail = "uniform rectilinear relative motion satisfies (2.1) for all t"


@check("C2.3")
def c2_3(r: Report) -> None:
    t = nt.t
    X = sp.Matrix([sp.Function(n, real=True)(t) for n in ("X", "Y", "Z")])
    c_t = X.cross(X.diff(t))                              # OP x V_r as time functions
    # (2.1) is OP x A_r = 0; d/dt (OP x V_r) = OP x A_r identically
    conditions_t = sp.Matrix([with_law(v, dict(zip((nt.x, nt.y, nt.z), X)))
                              for v in translational_conditions()])
    assert_zero("d/dt(OP x V_r) - (2.1)", c_t.diff(t) - conditions_t)
    # the vector (2.3) is OP x V_r: so (2.1) on an interval <=> c' = 0 <=> c constant
    assert_same("C2.3 (2.3)", nt.cross(nt.OP, nt.V_r), P.E2_3)
    # => : c . OP = 0 identically, so P stays in the plane through O normal to c, and
    #      the areal velocity |c|/2 is constant (equal areas in equal times)
    assert_zero("(c, OP)", (P.E2_3.T * nt.OP)[0])
    # c = 0 : d/dt (OP/|OP|) = ((OP x V_r) x OP)/|OP|^3, so the direction of OP is fixed
    #         and P moves on a line through O
    norm = sp.sqrt((X.T * X)[0])
    direction_rate = (X / norm).diff(t) - c_t.cross(X) / norm**3
    assert_zero("d/dt(OP/|OP|) - (c x OP)/|OP|^3", direction_rate.applyfunc(sp.simplify))
    # <= : any law along a line through O, OP = f(t) e, has c = 0 and satisfies (2.1)
    f = sp.Function("f", real=True)(t)
    e_dir = sp.Matrix(sp.symbols("e_1:4", real=True))
    line = dict(zip((nt.x, nt.y, nt.z), f * e_dir))
    assert_zero("(2.3) on a line through O", with_law(P.E2_3, line))
    assert_zero("(2.1) on a line through O", with_law(translational_conditions(), line))
    # and a planar law with constant areal velocity satisfies (2.1): a Kepler-like
    # law in the plane z = 0, rho^2 theta' = h, rho(t) arbitrary
    rho, h = sp.Function("rho", positive=True)(t), sp.Symbol("h", real=True)
    theta = sp.Integral(h / rho**2, t)
    planar = {nt.x: rho * sp.cos(theta), nt.y: rho * sp.sin(theta), nt.z: 0}
    conditions = with_law(translational_conditions(), planar).doit()
    assert_zero("(2.1) under the law of areas", conditions.applyfunc(sp.simplify))
    r.detail = ("d/dt(OP x V_r) = OP x A_r; (c, OP) = 0; c = 0 fixes the direction of "
                "OP; lines through O and constant areal velocity satisfy (2.1)")


@check("C2.4")
def c2_4(r: Report) -> None:
    lam, sig = sp.Function("lambda", real=True)(nt.t), sp.Symbol("sigma", real=True)
    n = nt.n
    # P on the vertical line through O (fixed in the body while the body translates)
    on_line = {nt.x: lam * n[0], nt.y: lam * n[1], nt.z: lam * n[2]}
    # S on the same line: for a sphere centred on it, the derived lowest point is there
    kappa = sp.Symbol("kappa", real=True)
    s_sphere = sphere().point.xreplace({**dict(zip(center, kappa * n)), radius: 1})
    unit = {n[2]: sp.sqrt(1 - n[0]**2 - n[1]**2)}
    assert_zero("sphere S x n", nt.cross(s_sphere, n).xreplace(unit).applyfunc(sp.simplify))
    # for an ellipsoid, S is on the line when n is along a principal axis
    s_ell = ellipsoid().point.xreplace({n[0]: 0, n[1]: 0, n[2]: 1,
                                        **dict(zip(center, (0, 0, kappa)))})
    assert_zero("ellipsoid S x n (n along an axis)",
                nt.cross(s_ell, sp.Matrix([0, 0, 1])).applyfunc(sp.simplify))
    # with OS = sigma n the lever vanishes identically, so omega+ = omega- + I J^-1 0
    _, d = lever()
    on_ell = with_law(d, on_line).xreplace(dict(zip(nt.OS, sig * n)))
    assert_zero("d on the vertical line", on_ell)
    # the derived jump is I w with J w = d: d = 0 gives w = 0 (J is definite, R1)
    jump = impact_map().omega_plus - nt.omega
    assert_same("omega+ - omega-", jump, nt.I * nt.W)
    # and translational flight holds along the line: (2.1) with OP = lambda(t) n
    assert_zero("(2.1) along the vertical line", with_law(translational_conditions(), on_line))
    r.detail = "OP, OS along n => CS x n = 0 => J w = 0 => omega+ = omega-"


@check("C2.5")
def c2_5(r: Report) -> None:
    am = angular_momentum()
    t = nt.t
    f = sp.Function("f", real=True)(t)
    e_dir = sp.Matrix(sp.symbols("e_1:4", real=True))
    line = dict(zip((nt.x, nt.y, nt.z), f * e_dir))
    # c = 0 (P on a line through O): K is linear homogeneous in omega, (2.4)
    assert_zero("K - J omega on a line through O", with_law(am.own, line))
    assert_same("C2.5 (2.4)", am.J * nt.omega, P.E2_4)
    # V = |K|^2 (2.5), with K = J omega, is an integral (E1.9: dV/dt = 2 (K, E1.7))
    K_c0 = am.J * nt.omega
    assert_same("C2.5 (2.5)", (K_c0.T * K_c0)[0], P.E2_5)
    dV = nt.freeze(nt.thaw(integral_of_kinetic_moment()).diff(t))
    assert_zero("dV/dt - 2 (K, E1.7)", dV - 2 * (am.K.T * flight_dynamics().residual)[0])
    # K <-> omega: for every v, v^T J v = v^T J_O v + mu |OP x v|^2 >= J_min |v|^2 and
    # (|OP|^2 1 - OP OP^T) has eigenvalues 0, |OP|^2, |OP|^2, so
    #   J_min |omega| <= |K| <= (J_max + mu |OP|^2) |omega|
    # and V is positive definite in omega as well as in K, uniformly in t for a bounded law
    v = sp.Matrix(sp.symbols("v_1:4", real=True))
    quad = (v.T * am.J * v)[0]
    rv = nt.cross(nt.OP, v)
    assert_zero("v^T J v bound", quad - (nt.J_x * v[0]**2 + nt.J_y * v[1]**2
                                         + nt.J_z * v[2]**2) - nt.mu * (rv.T * rv)[0])
    G = (am.J - sp.diag(nt.J_x, nt.J_y, nt.J_z)) / nt.mu
    r2 = (nt.OP.T * nt.OP)[0]
    assert_zero("G OP", (G * nt.OP).applyfunc(sp.expand))
    k = sp.Matrix(sp.symbols("k_1:4", real=True))
    orth = nt.cross(nt.OP, k)                              # any vector normal to OP
    assert_zero("G v = |OP|^2 v for v normal to OP", (G * orth - r2 * orth).applyfunc(sp.expand))
    r.detail = ("c = 0 => K = J omega; |K|^2 integral; J_min |w| <= |K| <= "
                "(J_max + mu r^2)|w| => |w(t)| <= (J_max + mu r_max^2)/J_min |w(0)|")

