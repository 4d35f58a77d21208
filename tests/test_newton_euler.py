"""Cross-check (b): Newton–Euler for carrier plus point, solved numerically.

Unknowns in flight: a_O (fixed axes), omega' (body), F (body axes, the force of the point
on the carrier, applied at P):
    M a_O = A F - M g e_Z
    J_O omega' + omega x J_O omega = OP x F
    m a_P = -A F - m g e_Z,  a_P = a_O + A (omega' x r + omega x (omega x r) + 2 omega x v + a_r)
At impact, with the point's relative velocity held, unknowns dV_O, d omega, the impulse
L of the point on the carrier (body axes) and the plane's impulse I:
    M dV_O = A L + I e_Z
    J_O d omega = OP x L + OS x (I n)
    m (dV_O + A (d omega x r)) = -A L
    v_n+ = -e v_n-,  v_n = (V_O + A (omega x OS))_Z
"""
from __future__ import annotations

import numpy as np

from cases import cases, rel_err
from derive.emit.numpy_backend import compile_spec
from derive.models import flight_rhs, impact

N_STATES = 200
TOL = 1e-12


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def newton_euler_flight(c):
    J = np.diag(c.J)
    ez = np.array([0.0, 0.0, 1.0])
    rows, rhs = [], []
    Z = np.zeros((3, 3))
    # unknown x = [a_O (3), omega' (3), F (3)]
    rows.append(np.hstack([c.M * np.eye(3), Z, -c.A]))
    rhs.append(-c.M * c.g * ez)
    rows.append(np.hstack([Z, J, -skew(c.r)]))
    rhs.append(-np.cross(c.omega, J @ c.omega))
    known = (np.cross(c.omega, np.cross(c.omega, c.r)) + 2 * np.cross(c.omega, c.v) + c.acc)
    # m (a_O + A(omega' x r) + A known) + A F = -m g e_Z;  omega' x r = -skew(r) omega'
    rows.append(np.hstack([c.m * np.eye(3), -c.m * c.A @ skew(c.r), c.A]))
    rhs.append(-c.m * c.g * ez - c.m * c.A @ known)
    x = np.linalg.solve(np.vstack(rows), np.concatenate(rhs))
    return x[:3], x[3:6]


def newton_euler_impact(c):
    J = np.diag(c.J)
    ez = np.array([0.0, 0.0, 1.0])
    n = c.A[2]
    frac = c.m / (c.M + c.m)
    V_O = c.V_C - frac * c.A @ (c.v + np.cross(c.omega, c.r))
    v_minus = (V_O + c.A @ np.cross(c.omega, c.s))[2]
    Z = np.zeros((3, 3))
    # unknown x = [dV_O (3), d omega (3), L (3), I (1)]
    A = np.zeros((10, 10))
    b = np.zeros(10)
    A[0:3] = np.hstack([c.M * np.eye(3), Z, -c.A, -ez[:, None]])
    A[3:6] = np.hstack([Z, J, -skew(c.r), -np.cross(c.s, n)[:, None]])
    A[6:9] = np.hstack([c.m * np.eye(3), -c.m * c.A @ skew(c.r), c.A, np.zeros((3, 1))])
    # v_n+ - v_n- = dV_O_Z + (A (d omega x OS))_Z = -(1 + e) v_n-
    A[9, 0:3] = ez
    A[9, 3:6] = -(c.A @ skew(c.s))[2]
    b[9] = -(1 + c.e) * v_minus
    x = np.linalg.solve(A, b)
    return V_O + x[0:3], c.omega + x[3:6], x[9]


def test_flight_matches_newton_euler():
    ours = compile_spec(flight_rhs("general"))
    worst = 0.0
    for c in cases(N_STATES, seed=11):
        a_O, omega_dot = newton_euler_flight(c)
        (dq,) = ours(c.q_general, c.u, c.p)
        frac = c.m / (c.M + c.m)
        rel_acc = (np.cross(dq[6:9], c.r) + np.cross(c.omega, np.cross(c.omega, c.r))
                   + 2 * np.cross(c.omega, c.v) + c.acc)
        worst = max(worst, rel_err(dq[6:9], omega_dot),
                    rel_err(dq[3:6] - frac * c.A @ rel_acc, a_O))
        # Poisson: A' = A skew(omega), row-major in the state
        worst = max(worst, rel_err(dq[9:], (c.A @ skew(c.omega)).ravel()))
        worst = max(worst, rel_err(dq[0:3], c.V_C))
    print(f"max relative difference {worst:.2e}")
    assert worst < TOL, f"max relative difference {worst:.2e}"


def test_impact_matches_newton_euler():
    ours = compile_spec(impact("general"))
    worst = 0.0
    for c in cases(N_STATES, seed=13):
        V_O_plus, omega_plus, impulse = newton_euler_impact(c)
        q_plus, I = ours(c.q_general, c.u, c.s, c.p, [c.e])
        frac = c.m / (c.M + c.m)
        ours_V_O = q_plus[3:6] - frac * c.A @ (c.v + np.cross(q_plus[6:9], c.r))
        worst = max(worst, rel_err(q_plus[6:9], omega_plus), rel_err(ours_V_O, V_O_plus),
                    rel_err(I, [impulse]))
    print(f"max relative difference {worst:.2e}")
    assert worst < TOL, f"max relative difference {worst:.2e}"


def test_vertical_and_attitude_agree_with_general():
    gen = compile_spec(flight_rhs("general"))
    ver = compile_spec(flight_rhs("vertical"))
    att = compile_spec(flight_rhs("attitude"))
    for c in cases(20, seed=17):
        (dg,) = gen(c.q_general, c.u, c.p)
        (dv,) = ver(c.q_vertical, c.u, c.p)
        (da,) = att(c.omega, c.u, c.p)
        np.testing.assert_allclose(dv, np.r_[dg[2], dg[5], dg[6:9], dg[15:18]], rtol=1e-13)
        np.testing.assert_allclose(da, dg[6:9], rtol=1e-13)
