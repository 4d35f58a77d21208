"""Random physical states and laws shared by the cross-check tests."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from derive import shapes

# the inputs that carry a shape's size numbers: one field's key, or "size" for several
# (derive.models._size_input)
SIZE_INPUTS = {s.key for sh in shapes.SHAPES.values() for s in sh.sizes} | {"size"}


def rotation_from_quaternion(qv: np.ndarray) -> np.ndarray:
    w, x, y, z = qv / np.linalg.norm(qv)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


@dataclass
class Case:
    M: float
    m: float
    J: np.ndarray        # J_x, J_y, J_z
    g: float
    e: float
    A: np.ndarray        # a_ij = cos(fixed i, body j): fixed = A @ body
    omega: np.ndarray    # body axes
    r: np.ndarray        # OP, body axes
    v: np.ndarray        # V_r
    acc: np.ndarray      # relative acceleration
    s: np.ndarray        # OS
    R_C: np.ndarray      # fixed axes
    V_C: np.ndarray

    @property
    def p(self) -> np.ndarray:
        return np.array([self.M, self.m, *self.J, self.g])

    @property
    def u(self) -> np.ndarray:
        return np.concatenate([self.r, self.v, self.acc])

    @property
    def q_general(self) -> np.ndarray:
        return np.concatenate([self.R_C, self.V_C, self.omega, self.A.reshape(-1)])

    @property
    def q_vertical(self) -> np.ndarray:
        return np.concatenate([[self.R_C[2], self.V_C[2]], self.omega, self.A[2]])


def random_case(rng: np.random.Generator) -> Case:
    # principal moments of a real mass distribution: J_x = B + C etc., B, C > 0
    second = rng.uniform(0.02, 1.0, 3)
    J = np.array([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
    return Case(M=rng.uniform(0.5, 5.0), m=rng.uniform(0.05, 2.0), J=J, g=9.81,
                e=rng.uniform(0.0, 1.0), A=rotation_from_quaternion(rng.normal(size=4)),
                omega=rng.normal(0, 2, 3), r=rng.uniform(-1, 1, 3),
                v=rng.normal(0, 1, 3), acc=rng.normal(0, 3, 3), s=rng.uniform(-1, 1, 3),
                R_C=rng.normal(0, 1, 3), V_C=rng.normal(0, 1, 3))


def cases(n: int, seed: int = 2012) -> list[Case]:
    rng = np.random.default_rng(seed)
    return [random_case(rng) for _ in range(n)]


def rel_err(a, b) -> float:
    """Max-norm error of ``a`` relative to the max-norm of the reference ``b``."""
    a, b = np.asarray(a, float).ravel(), np.asarray(b, float).ravel()
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def inputs_for(spec, c, rng):
    """The inputs of a model function (a spec of derive.models) for the case ``c``."""
    values = []
    for vec in spec.inputs:
        if vec.name == "q":
            model = spec.name.split("_")[0]
            values.append({"general": c.q_general, "vertical": c.q_vertical,
                           "attitude": c.omega}[model])
        elif vec.name == "u":
            values.append(c.u)
        elif vec.name == "p":
            values.append(c.p)
        elif vec.name == "s":
            values.append(c.s)
        elif vec.name == "e":
            values.append(np.array([c.e]))
        elif vec.name == "sdot":
            values.append(rng.normal(size=3))
        elif vec.name == "omega":
            values.append(c.omega)
        elif vec.name == "n":
            values.append(c.A[2])
        elif vec.name == "center":
            values.append(rng.uniform(-0.5, 0.5, 3))
        elif vec.name in SIZE_INPUTS:               # a shape's size numbers, positive
            values.append(rng.uniform(0.1, 2.0, len(vec.entries)))
        elif vec.name == "A":                       # the momentum form (issue 13)
            values.append(c.A.ravel())
        elif vec.name in ("K", "k"):
            values.append(rng.normal(size=3))
        elif vec.name == "W":                       # exponential coordinates, |W| <= 1.25
            w = rng.normal(size=3)
            values.append(w * rng.uniform(0.0, 1.25) / np.linalg.norm(w))
        elif vec.name == "c":
            values.append(rng.normal(size=6))
        elif vec.name == "tau":
            values.append(rng.uniform(0.0, 3.0, 1))
        else:
            raise KeyError(vec.name)
    return values


def table_flight(ts: np.ndarray, duration: float, **run) -> dict:
    """A tumbling carrier in free flight (g = 0, no shape) whose point follows a periodic
    table sampled at the knots ``ts`` (one period of 2 pi / 3) from a smooth 3-D curve."""
    rows = np.column_stack([ts, 0.2 * np.sin(3 * ts), 0.1 * np.cos(3 * ts) ** 2,
                            0.05 * np.sin(6 * ts)])
    rows[-1, 1:] = rows[0, 1:]
    return {"name": "table-flight", "body": {"mass": 1.0, "inertia": [0.1, 0.12, 0.14],
                                             "shape": "none"},
            "point": {"mass": 0.5, "samples": rows.tolist(), "ends": "periodic"},
            "initial": {"omega": [0.3, -0.2, 0.5]},
            "run": {"duration": duration, "g": 0.0, **run}}


def random_law(rng, depth: int) -> str:
    """A random law of the grammar that is smooth for t in [0, 2] (denominators,
    log/sqrt arguments and asin/acos arguments kept away from their singular values)."""
    if depth == 0 or rng.random() < 0.25:
        return rng.choice(["t", f"{rng.uniform(-2, 2):.4g}", "pi", f"{rng.uniform(0.5, 3):.3g}*t"])
    a = random_law(rng, depth - 1)
    b = random_law(rng, depth - 1)
    k = rng.integers(0, 12)
    return [f"({a}) + ({b})", f"({a}) - ({b})", f"({a})*({b})",
            f"({a})/(2 + sin({b}))", f"sin({a})", f"cos({a})", f"exp(0.3*sin({a}))",
            f"log(3 + cos({a}))", f"sqrt(2 + sin({a}))", f"atan({a})", f"tanh({a})",
            f"({a})^2"][k]
