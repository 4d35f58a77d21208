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


def test_a_cylinder_tipping_on_its_rim_keeps_its_energy_and_no_jump_is_seen():
    """A cylinder (radius 0.3 m, half-length 0.5 m) set at rest on the smooth plane on its
    rim, its axis 30 deg off the vertical, tips for 0.3 s in contact with S moving along
    the rim, continuously: the check for a jump of S (asked of surfaces that are not
    strictly convex) must not take the contact's drift for one, and the run ends done.
    The plane's reaction is vertical and does no work (v_n = 0 at S): the energy
    (M + m)(|v_C|^2 / 2 + g Z_C) + omega.J omega / 2 keeps its start's value (the point
    fixed at O = C), and C does not move horizontally."""
    import math
    from derive.layout import GENERAL as G
    from derive.runtime.driver import simulate
    from test_runtime import ball
    half = math.radians(30.0) / 2
    doc = ball(e=0.0, duration=0.3, method="dopri5", rtol=1e-11, atol=1e-13, model="general")
    doc["body"].update({"shape": "cylinder", "radius": 0.3, "half_length": 0.5})
    doc["initial"].update(quaternion=[math.cos(half), math.sin(half), 0.0, 0.0],
                          on_plane=True)
    doc["initial"].pop("com")
    res = simulate(doc, progress=False)
    # put on the plane at rest: in contact from t0, no impact (tests/test_trial_findings.py)
    assert res.status == "done" and [(e["kind"], e["t"]) for e in res.events] == \
        [("contact", 0.0)]
    s, q = res.scene, res.general
    mass, J = s.M + s.m, np.array(s.J)
    energy = (0.5 * mass * np.sum(q[:, G.com_velocity] ** 2, axis=1) + mass * s.g * q[:, G.Z]
              + 0.5 * np.einsum("ni,i,ni->n", q[:, G.omega], J, q[:, G.omega]))
    assert np.ptp(energy) < 1e-9 * mass * s.g
    assert np.max(np.abs(q[:, G.horizontal])) < 1e-12
