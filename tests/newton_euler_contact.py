"""An independent Newton–Euler formulation of persistent contact (plain NumPy).

Two bodies, everything in body axes of the carrier (n = e_Z in body axes, r = OP):

  carrier, Newton   M a_O            = -M g n + N n - F
  point,   Newton   m a_P            = -m g n + F
  carrier, Euler    J omega' + omega x J omega = s x (N n) + r x (-F)     (about O)
  kinematics        a_P = a_O + omega' x r + omega x (omega x r) + 2 omega x r' + r''
  constraint        h'' = 0,  h = Z_O + n . s(n)

F is the force the carrier exerts on the point (whatever keeps its prescribed relative
motion), a_O the absolute acceleration of O, s = OS(n) the lowest surface point.  The
derivatives of the constraint, with n' = n x omega (e_Z fixed in space):

  h'  = Z_O' + omega . (s x n)                                 (n . ds = 0 at S)
  h'' = n . a_O + omega' . (s x n) + omega . (s' x n) + omega . (s x n'),  s' = (ds/dn) n'

the s' term being the motion of S over the surface as the body turns.  Ten unknowns
(a_O, omega', F, N), ten linear equations, solved by numpy.linalg.solve.  Without the
reaction (N = 0, no constraint row) the same system gives the free h'' = a_free.

Nothing here is taken from derive/contact.py, derive/models.py or the generated code.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass
class Body:
    M: float
    m: float
    J: np.ndarray               # (J_x, J_y, J_z)
    g: float
    center: np.ndarray          # shape centre in body axes
    axes: np.ndarray            # semi-axes (a, a, a) for a sphere of radius a

    @property
    def rho(self):
        return self.m / (self.m + self.M)

    def lowest(self, n):
        """OS and d(OS)/dn for the vertical n (body axes)."""
        D = self.axes ** 2
        Dn = D * n
        q = n @ Dn
        s = self.center - Dn / np.sqrt(q)
        ds = -np.diag(D) / np.sqrt(q) + np.outer(Dn, Dn) / q ** 1.5
        return s, ds


def unpack(q):
    q = np.asarray(q, dtype=float)
    return q[0:3], q[3:6], q[6:9], q[9:18].reshape(3, 3)


def solve(body: Body, q, u, with_reaction=True):
    """(dq, N, a_S) at state q with the law's u = (x, x', x'', y, y', y'', z, z', z'').
    with_reaction: persistent contact (a_S = h'' = 0 up to rounding); otherwise free
    flight, N = 0 and a_S the normal acceleration of S."""
    X, V, w, A = unpack(q)
    u = np.asarray(u, dtype=float)
    r, rd, rdd = u[[0, 3, 6]], u[[1, 4, 7]], u[[2, 5, 8]]
    n = A[2, :]                          # e_Z in body axes
    M, m, g = body.M, body.m, body.g
    J = np.diag(body.J)
    s, ds = body.lowest(n)
    nd = np.cross(n, w)
    sd = ds @ nd
    I3 = np.eye(3)
    # unknowns x = (a_O, omega', F, N)
    K = np.zeros((10, 10))
    b = np.zeros(10)
    K[0:3, 0:3] = M * I3
    K[0:3, 6:9] = I3
    K[0:3, 9] = -n
    b[0:3] = -M * g * n
    K[3:6, 0:3] = m * I3
    K[3:6, 3:6] = -m * skew(r)           # omega' x r = -r x omega'
    K[3:6, 6:9] = -I3
    b[3:6] = -m * g * n - m * (np.cross(w, np.cross(w, r)) + 2 * np.cross(w, rd) + rdd)
    K[6:9, 3:6] = J
    K[6:9, 6:9] = skew(r)
    K[6:9, 9] = -np.cross(s, n)
    b[6:9] = -np.cross(w, J @ w)
    sxn = np.cross(s, n)
    h2_rest = w @ np.cross(sd, n) + w @ np.cross(s, nd)
    K[9, 0:3] = n
    K[9, 3:6] = sxn
    b[9] = -h2_rest
    if with_reaction:
        x = np.linalg.solve(K, b)
    else:
        x = np.zeros(10)
        x[:9] = np.linalg.solve(K[:9, :9], b[:9])
    aO, wd, N = x[0:3], x[3:6], x[9]           # x[6:9]: the force on the point
    aP = aO + np.cross(wd, r) + np.cross(w, np.cross(w, r)) + 2 * np.cross(w, rd) + rdd
    aC = (M * aO + m * aP) / (M + m)
    hdd = n @ aO + sxn @ wd + h2_rest
    dq = np.concatenate([V, A @ aC, wd, (A @ skew(w)).ravel()])
    return dq, N, hdd


def gap(body: Body, q, u):
    """(h, v_n) of S: h = Z_O + n.s, v_n = Z_O' + omega.(s x n), with O from C."""
    X, V, w, A = unpack(q)
    u = np.asarray(u, dtype=float)
    r, rd = u[[0, 3, 6]], u[[1, 4, 7]]
    n = A[2, :]
    s, _ = body.lowest(n)
    rho = body.rho
    ZO = X[2] - rho * (n @ r)
    ZOd = V[2] - rho * (np.cross(n, w) @ r + n @ rd)
    return ZO + n @ s, ZOd + w @ np.cross(s, n)


def on_plane(body: Body, A, w, u, XY=(0.0, 0.0), VXY=(0.0, 0.0)):
    """A state with S on the plane and v_n = 0: Z_C and Z_C' from the attitude, omega
    and the law."""
    u = np.asarray(u, dtype=float)
    r, rd = u[[0, 3, 6]], u[[1, 4, 7]]
    n = A[2, :]
    s, _ = body.lowest(n)
    rho = body.rho
    ZO = -(n @ s)
    ZOd = -(w @ np.cross(s, n))
    ZC = ZO + rho * (n @ r)
    ZCd = ZOd + rho * (np.cross(n, w) @ r + n @ rd)
    return np.concatenate([[XY[0], XY[1], ZC], [VXY[0], VXY[1], ZCd], w, A.ravel()])


def kinetic_moment_C(body: Body, q, u):
    """K about C in fixed axes, from the two bodies' momenta (for invariant checks)."""
    X, V, w, A = unpack(q)
    u = np.asarray(u, dtype=float)
    r, rd = u[[0, 3, 6]], u[[1, 4, 7]]
    rho = body.rho
    # body-axes positions/velocities relative to C
    cO, cP = -rho * r, (1 - rho) * r
    vO = np.cross(w, cO) - rho * rd          # velocity of O relative to C
    vP = np.cross(w, cP) + (1 - rho) * rd
    K = np.diag(body.J) @ w + body.M * np.cross(cO, vO) + body.m * np.cross(cP, vP)
    return A @ K
