"""The internal bodies of a scene that is not one point, along a run's rows: every point's
and rotor's motion from their law, their moments, the energy of each body, the power of
each drive, K about C, and where the points are.  Plain NumPy from the definitions
(derive/layout.py's MOMENTS; derive/moments.py derives the same in SymPy for the C):
what :mod:`derive.runtime.motion` reads for such a run in place of the one point's
formulas.

Bodies (body axes; O the carrier's centre, ``J_O = diag(J)`` its inertia about O with every
rotor locked, ``M`` its mass with theirs): points j of mass ``m_j`` at ``rho_j(t)``; rotors
k of axial moment ``I_k`` about the unit axis ``a_k``, at the angle ``psi_k(t)`` relative to
the body.  ``m = sum m_j``, ``mt = M + m``, ``s = sum m_j rho_j``, ``OC = c = s/mt``.

Velocities.  With ``V = A^T V_C``: ``V_O = V - (c' + omega x c)`` and ``V_j = V_O + rho_j'
+ omega x rho_j``.

Kinetic energy, split per body.  The carrier's ``1/2 M |V_O|^2 + 1/2 (omega, J_O omega)``
(its rotors counted as locked); point j's ``1/2 m_j |V_j|^2``; rotor k's spin beyond its
locked share, ``I_k psi_k' (a_k, omega) + 1/2 I_k psi_k'^2`` (its angular velocity is omega
+ psi_k' a_k, and ``a_k`` is an axis of its inertia).  The sum is the whole's.

K about C: ``K = J omega + k``, ``J = J_O + Theta - (|s|^2 E - s s^T)/mt``, ``k = h - s x
s'/mt``, with ``Theta = sum m_j (|rho_j|^2 E - rho_j rho_j^T)`` and ``h = sum m_j rho_j x
rho_j' + sum I_k psi_k' a_k``.  In flight K is constant in fixed axes: ``J omega' = -omega x
K - J' omega - k'``.

Drives.  The carrier moves point j along its law with the force ``F_j = m_j (a_j + g n)``
(``a_j`` its absolute acceleration, n the vertical in body axes) and does the work
``F_j . rho_j'`` per unit time; with the plane's force R at S (fixed axes), ``a_C = -g e_Z +
R/mt``, so ``F_j = m_j (A^T R/mt - c_abs'' + rho_j'' + 2 omega x rho_j' + omega' x rho_j +
omega x (omega x rho_j))``, ``c_abs'' = c'' + 2 omega x c' + omega' x c + omega x (omega x
c)``.  It turns rotor k with the torque T_k, ``(a_k, T_k) = I_k ((a_k, omega') + psi_k'')``
(its Euler equation about its axis), whose power is ``I_k psi_k' (psi_k'' + (a_k,
omega'))``.  At an impact the drives' impulsive work is ``m_j (V_j+ - V_j-) . rho_j'`` and
``I_k psi_k' (a_k, omega+ - omega-)`` (the laws' rates do not jump).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import layout


@dataclass
class Bodies:
    """The bodies along rows: the drives' ``names`` (the points', then the rotors'),
    ``masses`` (N,), ``r``, ``v``, ``a`` (N, n, 3) each point's rho, rho', rho'' (body
    axes); ``axes`` (R, 3), ``inertias`` (R,), ``psi`` (R, n, 3): each rotor's psi, psi',
    psi''."""
    names: tuple
    masses: np.ndarray
    r: np.ndarray
    v: np.ndarray
    a: np.ndarray
    axes: np.ndarray
    inertias: np.ndarray
    psi: np.ndarray

    def rows(self, a: int, b: int) -> "Bodies":
        return Bodies(self.names, self.masses, self.r[:, a:b], self.v[:, a:b], self.a[:, a:b],
                      self.axes, self.inertias, self.psi[:, a:b])

    @property
    def n_points(self) -> int:
        return len(self.masses)


def along(scene, t) -> Bodies:
    """The bodies of ``scene`` at the times ``t``, from the law the runtime runs
    (:meth:`~derive.scene.law.bodies.BodiesLaw.u`, the NumPy twin of crt_law.h)."""
    t = np.asarray(t, dtype=float)
    points, rotors = scene.points, scene.rotors
    u = scene.runtime_law.u(t) if not scene.one_point else \
        layout.u_of_jets(scene.law.jets(t))
    n_p = len(points)
    pts = np.stack([u[layout.point_slice(j)] for j in range(n_p)]) if n_p else \
        np.zeros((0, 9, len(t)))
    r, v, a = (np.transpose(pts[:, k:k + 3], (0, 2, 1)) for k in (0, 3, 6))
    psi = np.stack([u[layout.rotor_slice(n_p, k)].T for k in range(len(rotors))]) \
        if rotors else np.zeros((0, len(t), 3))
    return Bodies(names=tuple(p.name for p in (*points, *rotors)),
                  masses=np.array([p.mass for p in points], dtype=float),
                  r=r, v=v, a=a,
                  axes=np.array([ro.axis for ro in rotors], dtype=float).reshape(-1, 3),
                  inertias=np.array([ro.inertia for ro in rotors], dtype=float),
                  psi=psi)


def _sum(x: np.ndarray, n: int, shape=(3,)) -> np.ndarray:
    return x.sum(axis=0) if len(x) else np.zeros((n, *shape))


@dataclass
class Moments:
    """The moments along rows (derive/layout.py's MOMENTS), full matrices for Theta."""
    m: float
    s: np.ndarray
    sd: np.ndarray
    sdd: np.ndarray
    theta: np.ndarray          # (n, 3, 3)
    theta_d: np.ndarray
    h: np.ndarray
    hd: np.ndarray

    def vector(self) -> np.ndarray:
        """(n, 27) in layout.MOMENTS' order (Theta's upper triangles)."""
        up = [self.theta[:, i, j] for i, j in layout.UPPER_INDEX]
        upd = [self.theta_d[:, i, j] for i, j in layout.UPPER_INDEX]
        return np.column_stack([self.s, self.sd, self.sdd, *up, *upd, self.h, self.hd])


def moments(b: Bodies) -> Moments:
    n = b.r.shape[1] if b.n_points else b.psi.shape[1]
    m = b.masses[:, None, None]
    E = np.eye(3)
    rr = np.einsum("jni,jni->jn", b.r, b.r)
    rv = np.einsum("jni,jni->jn", b.r, b.v)
    outer = b.r[..., :, None] * b.r[..., None, :]
    outer_d = b.v[..., :, None] * b.r[..., None, :] + b.r[..., :, None] * b.v[..., None, :]
    theta = _sum(m[..., None] * (rr[..., None, None] * E - outer), n, (3, 3))
    theta_d = _sum(m[..., None] * (2.0 * rv[..., None, None] * E - outer_d), n, (3, 3))
    spin = b.inertias[:, None, None] * b.axes[:, None, :]               # (R, 1, 3)
    h = _sum(m * np.cross(b.r, b.v), n) + _sum(spin * b.psi[:, :, 1:2], n)
    hd = _sum(m * np.cross(b.r, b.a), n) + _sum(spin * b.psi[:, :, 2:3], n)
    return Moments(float(b.masses.sum()), _sum(m * b.r, n), _sum(m * b.v, n),
                   _sum(m * b.a, n), theta, theta_d, h, hd)


def offsets(scene, mo: Moments) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """OC = c, c', c'' along rows (body axes)."""
    mt = scene.M + mo.m
    return mo.s / mt, mo.sd / mt, mo.sdd / mt


def offsets_at(scene, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """OC, OC', OC'' at the times ``t`` (rows, body axes): offsets of the moments of the
    bodies there; of one point, m (r, r', r'')/(M + m) straight from its law's jets (the
    same numbers, without the moments' other entries)."""
    if not scene.one_point:
        # offsets(scene, moments(b)) but only the first moments (s, s', s''): the same
        # numbers, without Theta, h and their rates
        b = along(scene, t)
        n = b.r.shape[1] if b.n_points else b.psi.shape[1]
        m, mt = b.masses[:, None, None], scene.M + float(b.masses.sum())
        return _sum(m * b.r, n) / mt, _sum(m * b.v, n) / mt, _sum(m * b.a, n) / mt
    jets = scene.law.jets(np.asarray(t, dtype=float))
    mt = scene.M + scene.m
    return tuple(scene.m * jets[list(k)].T / mt for k in (layout.JET_R, layout.JET_V,
                                                         layout.JET_A))


def inertia(scene, mo: Moments) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(J, J', k, k') of K = J omega + k about C, along rows."""
    mt = scene.M + mo.m
    E = np.eye(3)
    ss = np.einsum("ni,ni->n", mo.s, mo.s)[:, None, None]
    ssd = np.einsum("ni,ni->n", mo.s, mo.sd)[:, None, None]
    J = np.diag(np.asarray(scene.J, dtype=float)) + mo.theta \
        - (ss * E - mo.s[:, :, None] * mo.s[:, None, :]) / mt
    Jd = mo.theta_d - (2.0 * ssd * E - mo.sd[:, :, None] * mo.s[:, None, :]
                       - mo.s[:, :, None] * mo.sd[:, None, :]) / mt
    k = mo.h - np.cross(mo.s, mo.sd) / mt
    kd = mo.hd - np.cross(mo.s, mo.sdd) / mt
    return J, Jd, k, kd


def kinetic_moment(scene, b: Bodies, omega) -> np.ndarray:
    """K about C in body axes along rows."""
    J, _, k, _ = inertia(scene, moments(b))
    return np.einsum("nij,nj->ni", J, omega) + k


def omega_rate_in_flight(scene, b: Bodies, omega) -> np.ndarray:
    """omega' in flight: J omega' = -omega x K - J' omega - k' (K constant in fixed
    axes)."""
    J, Jd, k, kd = inertia(scene, moments(b))
    K = np.einsum("nij,nj->ni", J, omega) + k
    rhs = -np.cross(omega, K) - np.einsum("nij,nj->ni", Jd, omega) - kd
    return np.linalg.solve(J, rhs[:, :, None])[:, :, 0]


def body_velocities(scene, b: Bodies, omega, A, v_C) -> tuple[np.ndarray, np.ndarray]:
    """(V_O (n, 3), V_j (N, n, 3)) in body axes."""
    c, cd, _ = offsets(scene, moments(b))
    V = np.einsum("nji,nj->ni", A, v_C)
    V_O = V - cd - np.cross(omega, c)
    return V_O, V_O[None] + b.v + np.cross(omega[None], b.r)


def energies(scene, b: Bodies, omega, A, v_C) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kinetic energy per body along rows: the carrier's (n,), each point's (N, n), each
    rotor's spin beyond its locked share (R, n)."""
    V_O, V_j = body_velocities(scene, b, omega, A, v_C)
    J0 = np.asarray(scene.J, dtype=float)
    T_c = 0.5 * scene.M * np.einsum("ni,ni->n", V_O, V_O) \
        + 0.5 * np.einsum("ni,i,ni->n", omega, J0, omega)
    T_p = 0.5 * b.masses[:, None] * np.einsum("jni,jni->jn", V_j, V_j)
    rate = b.psi[:, :, 1]
    T_r = b.inertias[:, None] * rate * (np.einsum("ki,ni->kn", b.axes, omega) + 0.5 * rate)
    return T_c, T_p, T_r


def positions(scene, b: Bodies, r_C, A) -> tuple[np.ndarray, np.ndarray]:
    """(r_O (n, 3), r_P (N, n, 3)) in fixed axes."""
    c, _, _ = offsets(scene, moments(b))
    r_O = r_C - np.einsum("nij,nj->ni", A, c)
    return r_O, r_O[None] + np.einsum("nij,knj->kni", A, b.r)


def drive_powers(scene, b: Bodies, omega, omega_dot, force=None, carrier=None) -> np.ndarray:
    """(N + R, n): the power of each drive (the points', then the rotors'); ``force``:
    the plane's force at S in body axes, A^T R, along the rows (None: flight);
    ``carrier``: in place of force, O's absolute acceleration plus g e_Z in body axes (the
    base model's rows, which hold O's motion)."""
    mo = moments(b)
    c, cd, cdd = offsets(scene, mo)
    w, wd = omega, omega_dot
    c_abs = cdd + 2.0 * np.cross(w, cd) + np.cross(wd, c) + np.cross(w, np.cross(w, c))
    base = carrier if carrier is not None else -c_abs if force is None \
        else force / (scene.M + mo.m) - c_abs
    rel = b.a + 2.0 * np.cross(w[None], b.v) + np.cross(wd[None], b.r) \
        + np.cross(w[None], np.cross(w[None], b.r))
    F = b.masses[:, None, None] * (base[None] + rel)
    points = np.einsum("jni,jni->jn", F, b.v)
    rate, acc = b.psi[:, :, 1], b.psi[:, :, 2]
    rotors = b.inertias[:, None] * rate * (acc + np.einsum("ki,ni->kn", b.axes, wd))
    return np.concatenate([points, rotors])


def impulsive_work(scene, b: Bodies, i: int, q_before, q_after) -> np.ndarray:
    """(N + R,): each drive's work in the impulse between the general states ``q_before``
    and ``q_after`` at row ``i`` (the laws' rates do not jump)."""
    G = layout.GENERAL
    bi = b.rows(i, i + 1)
    q = np.stack([q_before, q_after])
    A = q[:, G.A].reshape(2, 3, 3)
    V_O, V_j = body_velocities(scene, Bodies(bi.names, bi.masses, np.repeat(bi.r, 2, 1),
                                             np.repeat(bi.v, 2, 1), np.repeat(bi.a, 2, 1),
                                             bi.axes, bi.inertias, np.repeat(bi.psi, 2, 1)),
                                q[:, G.omega], A, q[:, G.com_velocity])
    points = bi.masses * np.einsum("ji,ji->j", V_j[:, 1] - V_j[:, 0], bi.v[:, 0])
    dw = q_after[G.omega] - q_before[G.omega]
    rotors = bi.inertias * bi.psi[:, 0, 1] * (b.axes @ dw)
    return np.concatenate([points, rotors])
