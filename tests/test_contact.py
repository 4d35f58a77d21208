"""Persistent contact (derive.contact) against an independent Newton–Euler formulation.

Unknowns: a_O (fixed axes), omega' (body), F (the point's force on the carrier, body
axes) and the plane's reaction N at the lowest point S of a sphere s = c - R n:
    M a_O = A F - M g e_Z + N e_Z
    J_O omega' + omega x J_O omega = OP x F + OS x (N n)
    m a_P = -A F - m g e_Z
    d2/dt2 of the height of S = a_O,Z + (n', omega x s) + (n, omega' x s) + (n, omega x s') = 0
with n' = n x omega and s' = -R n'.
"""
from __future__ import annotations

import numpy as np

from cases import cases, rel_err
from derive.emit.numpy_backend import compile_spec
from derive.models import contact_rhs, flight_rhs, lowest_point, lowest_point_rate

TOL = 1e-12


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def newton_euler_contact(c, s, sdot):
    J = np.diag(c.J)
    ez = np.array([0.0, 0.0, 1.0])
    n = c.A[2]
    ndot = np.cross(n, c.omega)
    Z = np.zeros((3, 3))
    A = np.zeros((10, 10))
    b = np.zeros(10)
    # x = [a_O, omega', F, N]
    A[0:3] = np.hstack([c.M * np.eye(3), Z, -c.A, -ez[:, None]])
    b[0:3] = -c.M * c.g * ez
    A[3:6] = np.hstack([Z, J, -skew(c.r), -np.cross(s, n)[:, None]])
    b[3:6] = -np.cross(c.omega, J @ c.omega)
    known = np.cross(c.omega, np.cross(c.omega, c.r)) + 2 * np.cross(c.omega, c.v) + c.acc
    A[6:9] = np.hstack([c.m * np.eye(3), -c.m * c.A @ skew(c.r), c.A, np.zeros((3, 1))])
    b[6:9] = -c.m * c.g * ez - c.m * c.A @ known
    # (n, omega' x s) = -(n, s x omega') = -(n^T skew(s)) omega'
    A[9, 0:3] = ez
    A[9, 3:6] = -(n @ skew(s))
    b[9] = -(ndot @ np.cross(c.omega, s)) - n @ np.cross(c.omega, sdot)
    x = np.linalg.solve(A, b)
    return x[0:3], x[3:6], x[9]


def test_contact_matches_newton_euler():
    ours = compile_spec(contact_rhs("general"))
    sphere = compile_spec(lowest_point("sphere"))
    sphere_rate = compile_spec(lowest_point_rate("sphere"))
    rng = np.random.default_rng(41)
    worst = 0.0
    for c in cases(200, seed=43):
        centre, R = rng.uniform(-0.3, 0.3, 3), rng.uniform(0.2, 1.0)
        (s,) = sphere(c.A[2], centre, [R])
        (sdot,) = sphere_rate(c.A[2], c.omega, [R])
        np.testing.assert_allclose(sdot, -R * np.cross(c.A[2], c.omega), atol=1e-14)
        a_O, omega_dot, N = newton_euler_contact(c, s, sdot)
        dq, N_ours = ours(c.q_general, c.u, s, sdot, c.p)
        frac = c.m / (c.M + c.m)
        rel_acc = (np.cross(dq[6:9], c.r) + np.cross(c.omega, np.cross(c.omega, c.r))
                   + 2 * np.cross(c.omega, c.v) + c.acc)
        worst = max(worst, rel_err(dq[6:9], omega_dot), rel_err(N_ours, [N]),
                    rel_err(dq[3:6] - frac * c.A @ rel_acc, a_O))
    print(f"max relative difference {worst:.2e}")
    assert worst < TOL


def test_contact_without_reaction_is_flight():
    """Where the computed N happens to be tiny the contact and flight rates agree, and in
    general they differ exactly by N (1/(m+M) e_Z, J^-1 d) — checked through dq."""
    ours = compile_spec(contact_rhs("vertical"))
    flight = compile_spec(flight_rhs("vertical"))
    sphere = compile_spec(lowest_point("sphere"))
    sphere_rate = compile_spec(lowest_point_rate("sphere"))
    for c in cases(30, seed=47):
        (s,) = sphere(c.A[2], np.zeros(3), [0.5])
        (sdot,) = sphere_rate(c.A[2], c.omega, [0.5])
        dq, N = ours(c.q_vertical, c.u, s, sdot, c.p)
        (dq_free,) = flight(c.q_vertical, c.u, c.p)
        assert abs(dq[1] - dq_free[1] - N[0] / (c.M + c.m)) < 1e-12 * (1 + abs(N[0]))
        np.testing.assert_allclose(dq[5:], dq_free[5:], rtol=1e-14)   # Poisson unchanged
