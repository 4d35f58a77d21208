"""The landing tasks and disturbances ``derive bench control`` draws: what users meet, not
the design's comfort zone (the sizes of a robustness trial of the re-planning
controller, issue 35).

* **A task** (:func:`task_doc`): a sphere or an ellipsoid (even odds), M uniform in
  [0.5, 2] kg, m/M in [0.2, 0.8], each moment of inertia the solid's times a factor in
  [0.6, 1.4] (drawn again until the three satisfy the triangle inequality); dropped from
  a height in [0.8, 4] m with a horizontal velocity up to 0.2 m/s, a spin of uniform
  direction and magnitude up to 1.5 rad/s, tilted by up to 25 deg about a horizontal
  axis; to land upright (the target attitude the identity, P in a region of radius
  0.15 m about O, |OP''| <= 60 m/s^2, the effort minimised), re-planned every 20 ms
  over 30 intervals.
* **A disturbance** (:func:`disturbance`) of one of four :data:`SIZES`: the plant's M,
  m, J_x, J_y, J_z each the model's times a factor uniform in 1 +- the size's error
  (drawn again until the plant's moments satisfy the triangle inequality); one push at
  a time uniform in [0.1, 0.9] of the planned fall, an impulse of uniform direction in
  space and magnitude uniform in the size's range, at a uniform point of the body's
  surface; and the noise of ``land_push.toml`` on what the controller reads.

Every draw is seeded by (seed, task, disturbance): the same seed gives the same draws in
any process and any order.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# size: (model error, push's smallest and largest impulse in N s), as the trial's
SIZES = ((0.05, 0.0, 0.02), (0.12, 0.02, 0.05), (0.25, 0.05, 0.10), (0.25, 0.10, 0.25))
PUSH_WINDOW = (0.1, 0.9)        # the push's time, in fractions of the planned fall
LATE = 0.5                      # a push at or after this fraction is late
NOISE = (0.01, 0.002, 0.001, 0.01)   # omega, attitude, C, C' (land_push.toml's)
REGION_RADIUS, MAX_ACCELERATION = 0.15, 60.0


def _unit(rng) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _triangle(J) -> bool:
    return all(J[i] <= J[(i + 1) % 3] + J[(i + 2) % 3] for i in range(3))


def task_doc(rng, k: int) -> dict:
    """The k-th landing task as a task document (derive control's TOML as a dict)."""
    shape = "sphere" if rng.uniform() < 0.5 else "ellipsoid"
    M = rng.uniform(0.5, 2.0)
    m = M * rng.uniform(0.2, 0.8)
    if shape == "sphere":
        R = rng.uniform(0.15, 0.25)
        size = {"radius": R}
        J0 = np.full(3, 0.4 * M * R * R)
    else:
        a = rng.uniform(0.15, 0.28, 3)
        size = {"semi_axes": a.tolist()}
        J0 = 0.2 * M * np.array([a[1] ** 2 + a[2] ** 2, a[0] ** 2 + a[2] ** 2,
                                 a[0] ** 2 + a[1] ** 2])
    while True:
        J = J0 * rng.uniform(0.6, 1.4, 3)
        if _triangle(J):
            break
    height = rng.uniform(0.8, 4.0)
    omega = _unit(rng) * rng.uniform(0.0, 1.5)
    tilt = math.radians(rng.uniform(0.0, 25.0))
    axis = np.r_[_unit(rng)[:2], 0.0]
    axis /= np.linalg.norm(axis)
    quaternion = [math.cos(tilt / 2), *(math.sin(tilt / 2) * axis)]
    return {"name": f"bench-task-{k}",
            "body": {"mass": M, "inertia": J.tolist(), "shape": shape, **size},
            "point": {"mass": m}, "plane": {"restitution": 0.5},
            "initial": {"com": [0.0, 0.0, height],
                        "com_velocity": [*rng.uniform(-0.2, 0.2, 2), 0.0],
                        "omega": omega.tolist(), "quaternion": quaternion},
            "plan": {"goal": "land", "target_matrix": np.eye(3).tolist(),
                     "region": {"center": [0.0, 0.0, 0.0], "radius": REGION_RADIUS},
                     "max_acceleration": MAX_ACCELERATION, "rest_at_ends": True,
                     "objective": "effort"},
            "control": {"mode": "replan", "period": 0.02, "intervals": 30}}


def describe(doc: dict) -> str:
    b, i = doc["body"], doc["initial"]
    return (f"{b['shape']} M {b['mass']:.2f} m {doc['point']['mass']:.2f}, drop "
            f"{i['com'][2]:.2f} m, spin {np.linalg.norm(i['omega']):.2f} rad/s")


@dataclass(frozen=True)
class Draw:
    """A disturbance and what the table sorts it by."""
    size: int
    fraction: float          # the push's time in fractions of the planned fall
    impulse: float           # N s
    disturbance: object      # derive.scene.scene.Disturbance

    @property
    def late(self) -> bool:
        return self.fraction >= LATE


def _surface_point(rng, doc: dict) -> np.ndarray:
    d = _unit(rng)
    b = doc["body"]
    if b["shape"] == "sphere":
        return b["radius"] * d
    a = np.asarray(b["semi_axes"])
    return d / math.sqrt(float(np.sum(d * d / (a * a))))


def disturbance(rng, doc: dict, size: int, fall: float, seed: int) -> Draw:
    """A disturbance of the given size for a task whose planned fall lasts ``fall`` s."""
    from ..scene.scene import Disturbance
    error, lo, hi = SIZES[size]
    J = np.asarray(doc["body"]["inertia"])
    while True:
        f = rng.uniform(1 - error, 1 + error, 5)
        if _triangle(J * f[2:5]):
            break
    fraction = rng.uniform(*PUSH_WINDOW)
    P = rng.uniform(lo, hi)
    impulse = P * _unit(rng)
    at = _surface_point(rng, doc)
    dist = Disturbance(seed=seed, mass_factor=float(f[0]), point_mass_factor=float(f[1]),
                       inertia_factor=tuple(float(x) for x in f[2:5]), noise=NOISE,
                       pushes=((fraction * fall, *impulse, *at),))
    return Draw(size, float(fraction), float(P), dist)


def noise_only(seed: int):
    """The model itself with the noise only (the noise's own effect on a landing)."""
    from ..scene.scene import Disturbance
    return Disturbance(seed=seed, noise=NOISE)
