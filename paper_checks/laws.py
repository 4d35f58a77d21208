"""Helpers for the checks of sections 2–4: specialising derived expressions."""
from __future__ import annotations

import sympy as sp

from derive import notation as nt


def with_law(expr, law: dict):
    """Substitute a point law: ``law`` maps any of x, y, z to an expression of t; the
    frozen velocities and accelerations follow by differentiation."""
    table = {}
    for (s0, s1, s2) in ((nt.x, nt.xd, nt.xdd), (nt.y, nt.yd, nt.ydd),
                         (nt.z, nt.zd, nt.zdd)):
        if s0 in law:
            f = sp.sympify(law[s0])
            table.update({s0: f, s1: sp.diff(f, nt.t), s2: sp.diff(f, nt.t, 2)})
    return expr.xreplace(table)


ON_AXIS = {nt.x: 0, nt.y: 0, nt.xd: 0, nt.yd: 0, nt.xdd: 0, nt.ydd: 0}   # x = y = 0
SYMMETRIC = {nt.J_y: nt.J_x}                                               # J_x = J_y
IN_PLANE = {nt.z: 0, nt.zd: 0, nt.zdd: 0}                                  # z = 0


def at_rest(expr):
    """omega = 0 and omega' = 0."""
    return expr.xreplace({**{w: 0 for w in nt.omega}, **{w: 0 for w in nt.omega_dot}})


def stationary_about_z(expr, rate):
    """omega = (0, 0, rate), omega' = 0."""
    return expr.xreplace({nt.omega_x: 0, nt.omega_y: 0, nt.omega_z: rate,
                          **{w: 0 for w in nt.omega_dot}})
