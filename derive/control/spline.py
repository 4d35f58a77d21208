"""The re-planned law: a uniform cubic B-spline of N pieces over [t, t + T], its control
points C (N + 3 of them; the basis is :data:`derive.planner.law.BASIS`), at rest from its
end on.  The controller's C (``templates/control/controller.c.jinja``) states the same
three operations line for line: the jets at a time, the last solution shifted onto a new
horizon, and the law played as the runtime's cubic segments.
"""
from __future__ import annotations

import math

import numpy as np

from ..planner.law import BASIS
from ..runtime.loop import Segments


def _piece(C: np.ndarray, i: int) -> np.ndarray:
    """(4, 3): piece i's coefficients of s^0..s^3 (sums in the C's order)."""
    B = BASIS
    P = np.zeros((4, 3))
    for j in range(4):
        for k in range(4):
            P[j] = P[j] + B[k, j] * C[i + k]
    return P


def spline_jets(C: np.ndarray, T: float, tau: float) -> np.ndarray:
    """(3, 3): rows x, x', x'' (t-derivatives) of the spline with control points C
    (N + 3, 3) over a horizon T at local time tau in [0, T] (clamped: at rest beyond)."""
    N = C.shape[0] - 3
    h = T / N
    if tau >= T:
        i, s = N - 1, 1.0
    else:
        x = max(tau, 0.0) / h
        i = min(int(math.floor(x)), N - 1)
        s = x - i
    P = _piece(C, i)                           # (4, 3): coefficients of s^0..s^3
    val = P[0] + s * (P[1] + s * (P[2] + s * P[3]))
    d1 = P[1] + s * (2.0 * P[2] + 3.0 * s * P[3])
    d2 = 2.0 * P[2] + 6.0 * s * P[3]
    if tau >= T:                               # held at rest from the end on
        return np.array([val, np.zeros(3), np.zeros(3)])
    return np.array([val, d1 / h, d2 / (h * h)])


def ctrl_from_jets(jets: np.ndarray, h: float) -> np.ndarray:
    """Control points (N + 3, 3) of the uniform spline of step h whose value, rate and
    acceleration at the N + 1 knots are ``jets`` (N + 1, 3, 3): exact when the law is
    such a spline, the quasi-interpolant otherwise.  At a knot x = (c_k + 4 c_k+1 +
    c_k+2)/6, h x' = (c_k+2 - c_k)/2, h^2 x'' = c_k - 2 c_k+1 + c_k+2."""
    x, v, a = jets[:, 0], jets[:, 1] * h, jets[:, 2] * h * h
    C = np.empty((len(jets) + 2, 3))
    C[1:-1] = x - a / 6.0
    C[0] = x[0] - v[0] + a[0] / 3.0
    C[-1] = x[-1] + v[-1] + a[-1] / 3.0
    return C


def shift(w: np.ndarray, t_prev: float, t: float, T_new: float) -> np.ndarray:
    """The previous solution (its law from t_prev) on the horizon [t, t + T_new]."""
    nc = (len(w) - 1) // 3
    C = w[:3 * nc].reshape(nc, 3, order="F")
    T = w[-1]
    N = nc - 3
    h = T_new / N
    jets = np.array([spline_jets(C, T, t - t_prev + k * h) for k in range(N + 1)])
    return np.r_[ctrl_from_jets(jets, h).ravel(order="F"), T_new]


def play(w: np.ndarray, t: float, u: np.ndarray) -> Segments:
    """The cubic segments of the law in w from t on, for the runtime: the B-spline's
    pieces in powers of (time - knot), the first re-expressed so that its value and rate
    at t are u's exactly (c3 = x, c2 = x'; c1, c0 keep the piece's end: Hermite), and a
    last, constant piece that holds P where the law ends."""
    nc = (len(w) - 1) // 3
    N = nc - 3
    C = w[:3 * nc].reshape(nc, 3, order="F")
    T = float(w[-1])
    h = T / N
    hp = (1.0, h, h * h, h * h * h)
    knots = np.empty(N + 2)
    coef = np.empty((N + 1, 3, 4))
    for i in range(N):
        knots[i] = t + i * h
        P = _piece(C, i)                       # s^0..s^3, s = (time - knot)/h
        for j in range(4):
            coef[i, :, 3 - j] = P[j] / hp[j]
        if i == 0:                             # from u exactly to the piece's own end
            x1 = P[0] + P[1] + P[2] + P[3]
            v1 = (P[1] + 2.0 * P[2] + 3.0 * P[3]) / h
            x0, v0 = np.asarray(u[0:3], float), np.asarray(u[3:6], float)
            dd = x1 - x0                       # Hermite (derive.runtime.loop.hermite)
            coef[0, :, 0] = (h * (v0 + v1) - 2.0 * dd) / (h * h * h)
            coef[0, :, 1] = (3.0 * dd - h * (2.0 * v0 + v1)) / (h * h)
            coef[0, :, 2] = v0
            coef[0, :, 3] = x0
    knots[N] = t + T
    knots[N + 1] = t + T + h
    P = _piece(C, N - 1)
    coef[N] = 0.0
    coef[N, :, 3] = P[0] + P[1] + P[2] + P[3]  # held where the last piece ends
    return Segments(knots, coef)


