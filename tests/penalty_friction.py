"""A soft peer of the rough plane: a penalty formulation integrated with SciPy.

The two bodies' laws are tests/newton_euler_friction.py's (Newton for the carrier and
for the point, Euler for the carrier about O); the plane is not a constraint but a force
at the carrier's material point S (the lowest point of its sphere or ellipsoid):

  N   = max(0, k d - c v_n),  d = -h the penetration, v_n = dh/dt   (a spring and a damper)
  R_t = -mu N v_t / sqrt(|v_t|^2 + eps^2)                          (Coulomb, regularised)

As k -> infinity and eps -> 0 it tends to the rigid, event-driven model: an elastic spring
(c = 0) returns the work of compression in restitution, which is Stronge's energetic law
with e = 1; a damped one holds S on the plane, where the regularised friction tends to
sliding or sticking.  Nothing here reads the derivation.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

import newton_euler_friction as ne


def lowest_point(n, axes, center):
    """s = c - D^2 n/|D n| (body axes) for the vertical n in body axes."""
    D2 = np.diag(np.asarray(axes, float) ** 2)
    return np.asarray(center, float) - D2 @ n / np.sqrt(n @ D2 @ n)


def height_of_S(q, u, s, params):
    M, m = params[0], params[1]
    A = q[9:18].reshape(3, 3)
    return q[2] + (A @ (s - m / (m + M) * np.asarray(u[:3])))[2]


def forced(q, u, s, params, R):
    """dq/dt with the force R (fixed axes) at the body point S."""
    A = q[9:18].reshape(3, 3)
    K, Kr, b, _, _ = ne._rows(q, u, s, np.zeros(3), params)
    x = np.linalg.solve(K, b - Kr @ (A.T @ R))
    return ne._finish(q, u, params, x)


class Penalty:
    """The penalty model of one body on the plane: ``law(t) -> u`` (r, r', r'' in body
    axes), ``params = (M, m, J_x, J_y, J_z, g)``, the shape's semi-axes and centre."""

    def __init__(self, law, params, axes, center, mu, k, c, eps):
        self.law, self.params = law, np.asarray(params, float)
        self.axes, self.center = axes, center
        self.mu, self.k, self.c, self.eps = mu, k, c, eps

    def reaction(self, t, q):
        u = self.law(t)
        A = q[9:18].reshape(3, 3)
        s = lowest_point(A[2], self.axes, self.center)
        h = height_of_S(q, u, s, self.params)
        if h >= 0.0:
            return np.zeros(3), s, u
        v = ne.velocity_of_S(q, u, s, self.params)
        N = max(0.0, -self.k * h - self.c * v[2])
        vt = v[:2]
        Rt = -self.mu * N * vt / np.sqrt(vt @ vt + self.eps ** 2)
        return np.array([Rt[0], Rt[1], N]), s, u

    def rates(self, t, q):
        R, s, u = self.reaction(t, q)
        return forced(q, u, s, self.params, R)

    def run(self, t0, q0, t1, max_step, events=None, rtol=1e-10, atol=1e-12):
        return solve_ivp(self.rates, (t0, t1), q0, method="DOP853", rtol=rtol, atol=atol,
                         max_step=max_step, events=events, dense_output=False)
