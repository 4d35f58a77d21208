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
