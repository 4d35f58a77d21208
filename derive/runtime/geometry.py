"""Numeric helpers of the scene's geometry (the lowest point, rotations)."""
from __future__ import annotations

import numpy as np

from .. import layout, shapes


def cross(a, b) -> np.ndarray:
    """a x b over the last axis, broadcast: np.cross's result without its axis handling,
    which costs ten times the product on the few rows a study's variant reads."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def lowest_point_numeric(scene, n) -> np.ndarray:
    """OS for the vertical ``n`` (body axes; rows or one): the support point of ``-n`` on
    the scene's shape (derive/shapes.py, the map derive.surfaces derives from)."""
    return shapes.of(scene.shape).lowest_rows(n, scene.center, scene.size)


def rotation_z(angle):
    """Rotation about the body z axis by ``angle`` (array-friendly): shape (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1),
                     np.stack([z, z, o], -1)], -2)


def rotation_x(angle):
    c, s = np.cos(angle), np.sin(angle)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1),
                     np.stack([z, s, c], -1)], -2)


def momentum_frame(K_fixed, A0):
    """The frame whose third axis is K (given in fixed axes) and the body's Euler angles
    in it, ``A0 = R_K Rz(psi) Rx(theta) Rz(phi)``: returns (|K|, R_K, psi, theta, phi)
    (psi = 0 chosen when theta = 0, where only psi + phi is defined)."""
    K_fixed = np.asarray(K_fixed, dtype=float)
    K = float(np.linalg.norm(K_fixed))
    e3 = K_fixed / K
    helper = np.array([1.0, 0.0, 0.0]) if abs(e3[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, e3)
    e1 /= np.linalg.norm(e1)
    R_K = np.column_stack([e1, np.cross(e3, e1), e3])     # K-frame axes in fixed axes
    B = R_K.T @ A0
    theta = float(np.arccos(np.clip(B[2, 2], -1.0, 1.0)))
    if np.sin(theta) > 1e-12:
        phi = float(np.arctan2(B[2, 0], B[2, 1]))
        psi = float(np.arctan2(B[0, 2], -B[1, 2]))
    else:
        phi, psi = 0.0, float(np.arctan2(B[1, 0], B[0, 0]))
    return K, R_K, psi, theta, phi


def kinetic_moment(scene, omega, jets) -> np.ndarray:
    """K about C in body axes along rows (E1.4 with the J of E1.5): ``omega`` (N, 3), the
    law's ``jets`` (9, N).  tests/test_runtime_models.py compares it with the derived
    ``general_kinetic_moment`` of the generated C."""
    r, v = jets[list(layout.JET_R)].T, jets[list(layout.JET_V)].T
    omega = np.asarray(omega, dtype=float)
    J = np.asarray(scene.J, dtype=float)
    rr = np.einsum("ij,ij->i", r, r)[:, None]
    rw = np.einsum("ij,ij->i", r, omega)[:, None]
    return J * omega + scene.reduced_mass * (rr * omega - r * rw + np.cross(r, v))


def heights(scene, t, Z, n) -> np.ndarray:
    """Height of the lowest point S above the plane along rows (Z_C and the vertical n in
    body axes given per row)."""
    s = lowest_point_numeric(scene, n)
    if scene.one_point:
        oc = scene.nu * scene.law.jets(t)[list(layout.JET_R)].T
    else:                                   # OC = s/(M + m) of every point
        from . import bodies
        oc = bodies.offsets(scene, bodies.moments(bodies.along(scene, t)))[0]
    return Z + np.einsum("ij,ij->i", n, s - oc)
