"""Numeric helpers of the scene's geometry (the lowest point, rotations)."""
from __future__ import annotations

import numpy as np


def lowest_point_numeric(scene, n) -> np.ndarray:
    """OS for the vertical ``n`` (body axes): the ellipsoid's support point, a sphere
    being the equal-axes case (the same formula as derive.surfaces)."""
    n = np.asarray(n, dtype=float)
    c = np.asarray(scene.center, dtype=float)
    axes = np.full(3, scene.size[0]) if scene.shape == "sphere" else np.asarray(scene.size)
    D2n = axes ** 2 * n
    return c - D2n / np.sqrt(n @ D2n)


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
