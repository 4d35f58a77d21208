"""An independent Newton–Euler formulation of the carrier with N points and R rotors
(plain NumPy), written from first principles without reading derive/ (moments.py,
system.py, momentum.py, impact.py, contact.py) or the generated code.

Bodies, everything in the carrier's body axes (O its centre of mass, n = A^T e_Z):

* the carrier, mass M (its rotors' masses included), inertia J_O = diag(J) about O with
  its rotors locked in it;
* point j: mass m_j at r_j(t) (r, r', r'' given), moved along its path by a force F_j
  that the carrier exerts on it (it exerts -F_j on the carrier);
* rotor k: symmetric about the unit axis a_k through its centre G_k (fixed in the
  carrier), axial moment I_k, transverse moment It_k, turning by psi_k(t) relative to the
  carrier (psi', psi'' given) under a torque T_k from the carrier (-T_k on the carrier).
  Its mass moves with the carrier and is in M; its rotation is its own: the rigid rest of
  the carrier has the inertia J_O - sum_k I_r,k about O, I_r,k = It E + (I - It) a a^T.

Laws (a_O the absolute acceleration of O, R the plane's force at S, s = OS):

  carrier, Newton    M a_O = -M g n + R - sum_j F_j
  point j, Newton    m_j (a_O + w' x r + w x (w x r) + 2 w x r' + r'') = -m_j g n + F_j
  carrier, Euler     (J_O - sum I_r) w' + w x (J_O - sum I_r) w
                         = s x R - sum_j r_j x F_j - sum_k T_k                  (about O)
  rotor k, Euler     I_r (w' + psi'' a) + w x I_r (w + psi' a) = T_k            (about G_k)

Flight: R = 0.  Persistent contact on the smooth plane: R = N n and the normal
acceleration of the material point at S vanishes, n . (a_O + w' x s + w x (w x s) +
w x s') = 0 (S moves over the surface at s' as the body turns).  Impact: the same laws
integrated over an instant (positions, attitude, r' and psi' unchanged), impulse I n at S
and Newton's v_n+ = -e v_n-.  Each is one linear system, solved by numpy.linalg.solve.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

E_Z = np.array([0.0, 0.0, 1.0])


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass
class Point:
    m: float
    r: np.ndarray
    v: np.ndarray
    a: np.ndarray


@dataclass
class Rotor:
    axis: np.ndarray       # unit, body axes
    I: float               # axial moment
    It: float              # transverse moment
    rate: float            # psi'
    acc: float             # psi''

    @property
    def inertia(self):
        a = self.axis
        return self.It * np.eye(3) + (self.I - self.It) * np.outer(a, a)


@dataclass
class System:
    M: float
    J: np.ndarray          # principal moments about O, rotors locked
    g: float
    points: list = field(default_factory=list)
    rotors: list = field(default_factory=list)

    @property
    def mass(self):
        return self.M + sum(p.m for p in self.points)

    def oc(self):
        """OC and its rate relative to the body, from the definition of C."""
        c = sum((p.m * p.r for p in self.points), np.zeros(3)) / self.mass
        cd = sum((p.m * p.v for p in self.points), np.zeros(3)) / self.mass
        return c, cd

    def rigid(self):
        return np.diag(self.J) - sum((r.inertia for r in self.rotors), np.zeros((3, 3)))

    def velocity_of_O(self, q):
        """V_O in body axes from the state of C."""
        w, A = q[6:9], q[9:18].reshape(3, 3)
        c, cd = self.oc()
        return A.T @ q[3:6] - cd - np.cross(w, c)

    def moments(self):
        """The 27 moments from their definitions (derive/layout.py's order)."""
        s = sum((p.m * p.r for p in self.points), np.zeros(3))
        sd = sum((p.m * p.v for p in self.points), np.zeros(3))
        sdd = sum((p.m * p.a for p in self.points), np.zeros(3))
        th = sum((p.m * (p.r @ p.r * np.eye(3) - np.outer(p.r, p.r)) for p in self.points),
                 np.zeros((3, 3)))
        thd = sum((p.m * (2 * p.r @ p.v * np.eye(3) - np.outer(p.v, p.r) - np.outer(p.r, p.v))
                   for p in self.points), np.zeros((3, 3)))
        h = sum((p.m * np.cross(p.r, p.v) for p in self.points), np.zeros(3))
        h = h + sum((r.I * r.rate * r.axis for r in self.rotors), np.zeros(3))
        hd = sum((p.m * np.cross(p.r, p.a) for p in self.points), np.zeros(3))
        hd = hd + sum((r.I * r.acc * r.axis for r in self.rotors), np.zeros(3))
        up = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
        return np.r_[s, sd, sdd, [th[i, j] for i, j in up], [thd[i, j] for i, j in up], h, hd]

    def params(self):
        return np.array([self.M, sum(p.m for p in self.points), *self.J, self.g])


def _system(sys_: System, q, reaction=None):
    """The rows of the laws for the unknowns x = (a_O, w', F_1..F_N, T_1..T_R) with the
    plane's force R = (lever, direction) kept as one more column: K x + k R = b, where R
    acts along ``reaction[1]`` (body axes) at ``reaction[0]``."""
    w, A = q[6:9], q[9:18].reshape(3, 3)
    n = A.T @ E_Z
    N, R = len(sys_.points), len(sys_.rotors)
    size = 6 + 3 * N + 3 * R
    K = np.zeros((size, size))
    col = np.zeros(size)
    b = np.zeros(size)
    I3 = np.eye(3)
    rigid = sys_.rigid()
    # carrier, Newton (rows 0:3) and Euler (rows 3:6)
    K[0:3, 0:3] = sys_.M * I3
    b[0:3] = -sys_.M * sys_.g * n
    K[3:6, 3:6] = rigid
    b[3:6] = -np.cross(w, rigid @ w)
    if reaction is not None:
        s, direction = reaction
        col[0:3] = -direction
        col[3:6] = -np.cross(s, direction)
    for j, p in enumerate(sys_.points):
        rows = slice(6 + 3 * j, 9 + 3 * j)
        F = slice(6 + 3 * j, 9 + 3 * j)
        K[0:3, F] += I3
        K[3:6, F] += skew(p.r)
        K[rows, 0:3] = p.m * I3
        K[rows, 3:6] = -p.m * skew(p.r)
        K[rows, F] = -I3
        b[rows] = -p.m * sys_.g * n - p.m * (np.cross(w, np.cross(w, p.r))
                                            + 2 * np.cross(w, p.v) + p.a)
    for k, r in enumerate(sys_.rotors):
        rows = slice(6 + 3 * N + 3 * k, 9 + 3 * N + 3 * k)
        Ir = r.inertia
        K[3:6, rows] += I3
        K[rows, 3:6] = Ir
        K[rows, rows] = -I3
        b[rows] = -r.acc * (Ir @ r.axis) - np.cross(w, Ir @ (w + r.rate * r.axis))
    return K, col, b


def _finish(sys_: System, q, x):
    """dq from a_O and w': C'' from the bodies' accelerations, Poisson's equations."""
    w, A = q[6:9], q[9:18].reshape(3, 3)
    aO, wd = x[0:3], x[3:6]
    total = sys_.M * aO
    for p in sys_.points:
        total = total + p.m * (aO + np.cross(wd, p.r) + np.cross(w, np.cross(w, p.r))
                               + 2 * np.cross(w, p.v) + p.a)
    return np.concatenate([q[3:6], A @ total / sys_.mass, wd, (A @ skew(w)).ravel()])


def flight(sys_: System, q):
    K, _, b = _system(sys_, q)
    return _finish(sys_, q, np.linalg.solve(K, b))


def contact(sys_: System, q, s, sdot):
    """(dq, N) in persistent contact with the smooth plane at S (s, s' body axes)."""
    w, A = q[6:9], q[9:18].reshape(3, 3)
    n = A.T @ E_Z
    s, sdot = np.asarray(s, float), np.asarray(sdot, float)
    K, col, b = _system(sys_, q, (s, n))
    size = len(b)
    full = np.zeros((size + 1, size + 1))
    full[:size, :size], full[:size, size] = K, col
    full[size, 0:3] = n
    full[size, 3:6] = np.cross(s, n)              # n . (w' x s)
    rhs = np.r_[b, -n @ (np.cross(w, np.cross(w, s)) + np.cross(w, sdot))]
    x = np.linalg.solve(full, rhs)
    return _finish(sys_, q, x[:size]), x[size]


def impulse_response(sys_: System, q, s, rho):
    """(dV_O, dw) in body axes for an impulse rho (body axes) at S: the laws integrated
    over the impact, unknowns (dV_O, dw, Pi_1..Pi_N, tau_1..tau_R)."""
    N, R = len(sys_.points), len(sys_.rotors)
    size = 6 + 3 * N + 3 * R
    K = np.zeros((size, size))
    b = np.zeros(size)
    I3 = np.eye(3)
    K[0:3, 0:3] = sys_.M * I3
    b[0:3] = rho
    K[3:6, 3:6] = sys_.rigid()
    b[3:6] = np.cross(s, rho)
    for j, p in enumerate(sys_.points):
        sl = slice(6 + 3 * j, 9 + 3 * j)
        K[0:3, sl] += I3
        K[3:6, sl] += skew(p.r)
        K[sl, 0:3] = p.m * I3
        K[sl, 3:6] = -p.m * skew(p.r)
        K[sl, sl] = -I3
    for k, r in enumerate(sys_.rotors):
        sl = slice(6 + 3 * N + 3 * k, 9 + 3 * N + 3 * k)
        K[3:6, sl] += I3
        K[sl, 3:6] = r.inertia
        K[sl, sl] = -I3
    x = np.linalg.solve(K, b)
    return x[0:3], x[3:6]


def impact(sys_: System, q, s, e):
    """(q+, I): Newton's restitution of the normal velocity of the material point at S."""
    w, A = q[6:9], q[9:18].reshape(3, 3)
    n = A.T @ E_Z
    s = np.asarray(s, float)
    v_n = n @ (sys_.velocity_of_O(q) + np.cross(w, s))
    dVO, dw = impulse_response(sys_, q, s, n)          # per unit impulse
    k = n @ (dVO + np.cross(dw, s))
    I = -(1 + e) * v_n / k
    dVC = sys_.M * dVO + sum((p.m * (dVO + np.cross(dw, p.r)) for p in sys_.points),
                             np.zeros(3))
    q_plus = np.array(q, float).copy()
    q_plus[3:6] += I * (A @ dVC) / sys_.mass
    q_plus[6:9] += I * dw
    return q_plus, I


def kinetic_moment_fixed(sys_: System, q):
    """K about C in fixed axes from the bodies' momenta (points, carrier, rotors' spin)."""
    w, A = q[6:9], q[9:18].reshape(3, 3)
    c, cd = sys_.oc()
    # about O: the rigid rest of the carrier, and each rotor turning at w + psi' a
    K = sys_.rigid() @ w + sum((r.inertia @ (w + r.rate * r.axis) for r in sys_.rotors),
                               np.zeros(3))
    K = K + sys_.M * np.cross(-c, -cd + np.cross(w, -c))
    for p in sys_.points:
        rel = p.r - c
        K = K + p.m * np.cross(rel, p.v - cd + np.cross(w, rel))
    return A @ K
