"""The planned law of P: a uniform cubic B-spline in scaled time, C^2 by construction.

Time is scaled to ``tau = t / T`` on ``[0, 1]`` (``T`` the horizon, the touchdown time
or the hop period, fixed or a decision variable).  The spline has ``n`` pieces; on piece
``i`` (``s = n tau - i`` in ``[0, 1]``) the value is ``sum_k c[i + k] b_k(s)`` with the
uniform cubic B-spline basis ``b_k``: ``n + 3`` control points, or ``n`` with indices
taken modulo ``n`` for a periodic law.  Two shapes of law:

* ``cartesian``: the spline is OP itself (3 coordinates, body axes).  Its second
  derivative is linear on each piece, so ``|OP''|`` is largest at a knot, and the curve
  lies in the convex hull of its control points: bounding the control points bounds the
  whole law exactly.
* ``circle``: the spline is an angle ``theta``, and ``OP = (c_x + R cos theta,
  c_y + R sin theta, 0)``: P on a circle in the body plane z = 0.

Everything evaluates either numerically (NumPy) or on CasADi symbols (the same code
path: the basis weights are numbers, the control points may be symbols).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# rows: basis function b_k; columns: coefficient of s^j
BASIS = np.array([[1.0, -3.0, 3.0, -1.0],
                  [4.0, 0.0, -6.0, 3.0],
                  [1.0, 3.0, 3.0, -3.0],
                  [0.0, 0.0, 0.0, 1.0]]) / 6.0


def basis_values(s: float, d: int) -> np.ndarray:
    """The four local basis functions (derivative ``d`` in s) at ``s``."""
    powers = np.zeros(4)
    for j in range(d, 4):
        fact = 1.0
        for k in range(d):
            fact *= j - k
        powers[j] = fact * s ** (j - d)
    return BASIS @ powers


@dataclass(frozen=True)
class Spline:
    n: int                 # pieces
    periodic: bool = False

    @property
    def n_ctrl(self) -> int:
        return self.n if self.periodic else self.n + 3

    def indices(self, i: int) -> list[int]:
        """Control indices of piece i."""
        return [(i + k) % self.n if self.periodic else i + k for k in range(4)]

    def locate(self, tau: float) -> tuple[int, float]:
        x = tau * self.n
        i = int(np.clip(np.floor(x), 0, self.n - 1))
        return i, x - i

    def weights(self, tau: float, d: int = 0) -> np.ndarray:
        """Row of weights on the control points: the d-th tau-derivative at tau."""
        i, s = self.locate(tau)
        w = np.zeros(self.n_ctrl)
        for k, idx in enumerate(self.indices(i)):
            w[idx] += basis_values(s, d)[k] * self.n ** d
        return w

    def local_polynomials(self, C: np.ndarray) -> np.ndarray:
        """(n, dim, 4): on piece i, value = sum_j P[i, :, j] s^j."""
        C = np.asarray(C, dtype=float).reshape(self.n_ctrl, -1)
        out = np.empty((self.n, C.shape[1], 4))
        for i in range(self.n):
            out[i] = (BASIS.T @ C[self.indices(i)]).T
        return out


@dataclass
class Law:
    """A solved law: the spline, its control points, the time scale and the shape."""
    spline: Spline
    ctrl: np.ndarray       # (n_ctrl, dim)
    T: float
    kind: str = "cartesian"          # cartesian | circle
    circle: tuple = ()               # (c_x, c_y, R) for kind == circle
    ends: str = "free"               # periodic | rest | free (the tabulated law's ends)
    rest: bool = False               # at rest at both ends (x' = x'' = 0): held there
    extra: dict = field(default_factory=dict)

    @property
    def repeats(self) -> bool:
        """The law repeats with period T (the spline is periodic, or the table's ends say
        so: a law at rest at both ends and back at its start)."""
        return self.spline.periodic or self.ends == "periodic"

    @property
    def knots(self) -> np.ndarray:
        return np.linspace(0.0, self.T, self.spline.n + 1)

    def polynomials_in_t(self) -> np.ndarray:
        """(n, dim, 4): on piece i the spline is sum_j P[i, :, j] (t - t_i)^j."""
        P = self.spline.local_polynomials(self.ctrl)
        h = self.T / self.spline.n
        return P / h ** np.arange(4)

    def spline_values(self, t) -> np.ndarray:
        """(3, dim, N): the spline and its first two t-derivatives at times t."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.repeats:
            t = np.mod(t, self.T)
        elif self.rest:
            # at rest at both ends (zero rate and acceleration there): P stays where it
            # ends, C^2, instead of following the last piece's cubic
            t = np.clip(t, 0.0, self.T)
        n, h = self.spline.n, self.T / self.spline.n
        i = np.clip(np.floor(t / h).astype(int), 0, n - 1)
        dt = t - i * h
        P = self.polynomials_in_t()[i]           # (N, dim, 4)
        d = dt[:, None]
        val = P[..., 0] + d * (P[..., 1] + d * (P[..., 2] + d * P[..., 3]))
        d1 = P[..., 1] + d * (2 * P[..., 2] + 3 * d * P[..., 3])
        d2 = 2 * P[..., 2] + 6 * d * P[..., 3]
        return np.stack([val.T, d1.T, d2.T])

    def u(self, t) -> np.ndarray:
        """(9, N): x, y, z, x', y', z', x'', y'', z'' in body axes."""
        S = self.spline_values(t)
        if self.kind == "cartesian":
            return np.concatenate([S[0], S[1], S[2]])
        return circle_u(S[0][0], S[1][0], S[2][0], *self.circle, np)


def circle_u(th, thd, thdd, cx, cy, R, lib):
    """(9, ...) OP, OP', OP'' of P on the circle of centre (cx, cy, 0) and radius R in
    the body plane z = 0 at angle th (rates thd, thdd); ``lib``: numpy or casadi."""
    c, s = lib.cos(th), lib.sin(th)
    zero = 0 * th
    x, y = cx + R * c, cy + R * s
    xd, yd = -R * s * thd, R * c * thd
    xdd = -R * s * thdd - R * c * thd * thd
    ydd = R * c * thdd - R * s * thd * thd
    rows = [x, y, zero, xd, yd, zero, xdd, ydd, zero]
    if lib is np:
        return np.array(rows)
    return lib.vertcat(*rows)
