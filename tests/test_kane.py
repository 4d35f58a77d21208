"""Cross-check (a): sympy.physics.mechanics.KanesMethod on the same two-body system.

Carrier: rigid body of mass M with central principal inertia diag(J_x, J_y, J_z) at O;
generalised speeds are its body-axes angular velocity and the fixed-axes velocity of O.
Point: a particle of mass m at OP = x(t) B.x + y(t) B.y + z(t) B.z, a rheonomic
constraint.  Impact: generalised impulse of the vertical impulse I at the body point S,
M_kane (u+ - u-) = (dv_S/du . N.z) I, with I from v_n+ = -e v_n-.
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
import sympy.physics.mechanics as me

from cases import cases, rel_err
from derive.emit.numpy_backend import compile_spec
from derive.models import flight_rhs, impact

N_STATES = 200
TOL = 1e-12


@pytest.fixture(scope="module")
def kane():
    t = me.dynamicsymbols._t
    q = me.dynamicsymbols("q1:7")
    u = me.dynamicsymbols("u1:7")
    xs = me.dynamicsymbols("x y z")
    M, m, Jx, Jy, Jz, g = sp.symbols("M m J_x J_y J_z g", positive=True)
    sx, sy, sz = sp.symbols("s_x s_y s_z")
    Nf = me.ReferenceFrame("N")
    B = me.ReferenceFrame("B")
    B.orient_body_fixed(Nf, q[:3], "123")
    w_q = B.ang_vel_in(Nf)
    kd = [(w_q & B.x) - u[0], (w_q & B.y) - u[1], (w_q & B.z) - u[2],
          q[3].diff(t) - u[3], q[4].diff(t) - u[4], q[5].diff(t) - u[5]]
    B.set_ang_vel(Nf, u[0] * B.x + u[1] * B.y + u[2] * B.z)
    O = me.Point("O")
    O.set_pos(me.Point("Oa"), q[3] * Nf.x + q[4] * Nf.y + q[5] * Nf.z)
    O.set_vel(Nf, u[3] * Nf.x + u[4] * Nf.y + u[5] * Nf.z)
    Pp = O.locatenew("P", xs[0] * B.x + xs[1] * B.y + xs[2] * B.z)
    Pp.set_vel(B, xs[0].diff(t) * B.x + xs[1].diff(t) * B.y + xs[2].diff(t) * B.z)
    Pp.v1pt_theory(O, Nf, B)
    S = O.locatenew("S", sx * B.x + sy * B.y + sz * B.z)
    S.v2pt_theory(O, Nf, B)
    carrier = me.RigidBody("carrier", O, B, M, (me.inertia(B, Jx, Jy, Jz), O))
    point = me.Particle("point", Pp, m)
    loads = [(O, -M * g * Nf.z), (Pp, -m * g * Nf.z)]
    km = me.KanesMethod(Nf, q_ind=q, u_ind=u, kd_eqs=kd)
    km.kanes_equations([carrier, point], loads)
    MM, F = km.mass_matrix, km.forcing
    # freeze time functions into plain symbols for lambdify
    qs, us = sp.symbols("q1:7"), sp.symbols("u1:7")
    r0, r1, r2 = sp.symbols("r0:3"), sp.symbols("r1_0:3"), sp.symbols("r2_0:3")
    table = {}
    for k in range(3):
        table[xs[k].diff(t, 2)] = r2[k]
        table[xs[k].diff(t)] = r1[k]
        table[xs[k]] = r0[k]
    table.update(dict(zip(q, qs)))
    table.update(dict(zip(u, us)))
    MM, F = MM.xreplace(table), F.xreplace(table)
    v_S = S.vel(Nf)
    partial = [v_S.diff(ui, Nf, var_in_dcm=False) & Nf.z for ui in u]
    G = sp.Matrix(partial).xreplace(table)
    v_n = (v_S & Nf.z).xreplace(table)
    dcm = Nf.dcm(B).xreplace(table)       # fixed = dcm @ body
    args = [qs, us, r0, r1, r2, (M, m, Jx, Jy, Jz, g), (sx, sy, sz)]
    return {name: sp.lambdify(args, expr, modules="numpy", cse=True)
            for name, expr in (("MM", MM), ("F", F), ("G", G), ("v_n", v_n), ("dcm", dcm))}


def angles_from_dcm(A: np.ndarray) -> np.ndarray:
    """Body-fixed 1-2-3 angles with fixed = R1(q1) R2(q2) R3(q3) body."""
    q2 = np.arcsin(np.clip(A[0, 2], -1, 1))
    q1 = np.arctan2(-A[1, 2], A[2, 2])
    q3 = np.arctan2(-A[0, 1], A[0, 0])
    return np.array([q1, q2, q3])


def kane_state(kane, c):
    angles = angles_from_dcm(c.A)
    assert np.allclose(kane["dcm"](np.r_[angles, 0, 0, 0], np.zeros(6), c.r, c.v, c.acc,
                                   c.p, c.s), c.A, atol=1e-12)
    frac = c.m / (c.M + c.m)
    r_O = c.R_C - frac * c.A @ c.r
    V_O = c.V_C - frac * c.A @ (c.v + np.cross(c.omega, c.r))
    return np.r_[angles, r_O], np.r_[c.omega, V_O]


def test_flight_matches_kane(kane):
    ours = compile_spec(flight_rhs("general"))
    worst = 0.0
    for c in cases(N_STATES):
        qk, uk = kane_state(kane, c)
        args = (qk, uk, c.r, c.v, c.acc, c.p, c.s)
        udot = np.linalg.solve(kane["MM"](*args), np.ravel(kane["F"](*args)))
        (dq,) = ours(c.q_general, c.u, c.p)
        omega_dot = dq[6:9]
        worst = max(worst, rel_err(omega_dot, udot[:3]))
        # acceleration of O from ours: a_C - m/(m+M) d2/dt2 (A OP)
        frac = c.m / (c.M + c.m)
        rel_acc = (np.cross(omega_dot, c.r) + np.cross(c.omega, np.cross(c.omega, c.r))
                   + 2 * np.cross(c.omega, c.v) + c.acc)
        a_O = dq[3:6] - frac * c.A @ rel_acc
        worst = max(worst, rel_err(a_O, udot[3:]))
    print(f"max relative difference {worst:.2e}")
    assert worst < TOL, f"max relative difference {worst:.2e}"


def test_impact_matches_kane(kane):
    ours = compile_spec(impact("general"))
    worst = 0.0
    for c in cases(N_STATES, seed=7):
        qk, uk = kane_state(kane, c)
        args = (qk, uk, c.r, c.v, c.acc, c.p, c.s)
        MM = kane["MM"](*args)
        G = np.ravel(kane["G"](*args))
        Minv_G = np.linalg.solve(MM, G)
        v_minus = float(kane["v_n"](*args))
        impulse = -(1 + c.e) * v_minus / (G @ Minv_G)
        u_plus = uk + impulse * Minv_G
        q_plus, I = ours(c.q_general, c.u, c.s, c.p, [c.e])
        worst = max(worst, rel_err(I, [impulse]), rel_err(q_plus[6:9], u_plus[:3]))
        frac = c.m / (c.M + c.m)
        V_O_plus = q_plus[3:6] - frac * c.A @ (c.v + np.cross(q_plus[6:9], c.r))
        worst = max(worst, rel_err(V_O_plus, u_plus[3:]))
        assert np.array_equal(q_plus[9:], c.q_general[9:])   # orientation unchanged
    print(f"max relative difference {worst:.2e}")
    assert worst < TOL, f"max relative difference {worst:.2e}"
