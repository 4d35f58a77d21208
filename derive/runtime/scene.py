"""Scenes: the TOML files through which people use the runtime, and their validation.

Every rule failure raises :class:`SceneError` naming the field and the rule; nothing in
a scene is executed (laws go through :mod:`derive.runtime.lawparse`).  See the README
for the schema; :data:`DEFAULT_SCENE` is the built-in bouncing ball.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from .. import notation as nt
from .lawparse import LawError, parse_law

METHODS = ("rk4", "dopri5", "dop853")
OUTPUTS = ("pose", "omega", "height", "impacts", "momentum")
SHAPES = ("sphere", "ellipsoid", "none")
MODELS = ("auto", "general", "vertical", "attitude", "translational", "planar",
          "axisymmetric")

DEFAULT_SCENE = """\
# The built-in scene: a ball whose internal point moves, bouncing on the plane.
name = "bouncing-ball"

[body]
mass = 1.0                       # M > 0
inertia = [0.10, 0.12, 0.14]     # J_x, J_y, J_z > 0, each <= the sum of the other two
shape = "sphere"                 # "sphere" | "ellipsoid" | "none" (no contact possible)
radius = 0.5                     # sphere
center = [0.0, 0.0, 0.0]         # shape centre in body axes (default: O)

[point]
mass = 0.2                       # m > 0
law = ["0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"]   # x(t), y(t), z(t) in body axes

[plane]
restitution = 0.9                # 0 <= e <= 1

[initial]
time = 0.0
com = [0.0, 0.0, 1.5]            # X_C, Y_C, Z_C
com_velocity = [0.3, 0.0, 0.0]
omega = [0.5, -0.3, 1.0]         # body axes
quaternion = [1.0, 0.0, 0.0, 0.0]

[run]
duration = 5.0
method = "dopri5"                # rk4 | dopri5 | dop853
rtol = 1e-10
atol = 1e-12
g = 9.81
outputs = ["pose", "impacts"]    # any of: pose, omega, height, impacts, momentum
"""


class SceneError(ValueError):
    """A scene that breaks a rule: ``field`` names where, ``rule`` says what."""

    def __init__(self, where: str, rule: str):
        super().__init__(f"{where}: {rule}")
        self.where, self.rule = where, rule


@dataclass(frozen=True)
class Stability:
    """``[stability]``: what ``derive stability`` analyses (see the README)."""
    period: float | None = None          # free flight: default, the law's period
    impacts_every: int = 1               # on the plane: one impact per n law periods
    long_periods: int = 0                # critical cases: perturbed runs this long
    perturbations: tuple = (1e-6, 1e-4, 1e-2)  # their sizes


@dataclass(frozen=True)
class Scene:
    name: str
    M: float
    J: tuple                   # J_x, J_y, J_z
    shape: str                 # sphere | ellipsoid | none
    size: tuple                # (radius,) or semi-axes
    center: tuple
    m: float
    law_text: tuple
    law: tuple                 # SymPy expressions in t
    plane: bool
    e: float
    t0: float
    com: tuple
    com_velocity: tuple
    omega: tuple
    A0: np.ndarray = field(compare=False)   # a_ij = cos(fixed i, body j)
    duration: float = 5.0
    method: str = "dopri5"
    rtol: float = 1e-10
    atol: float = 1e-12
    g: float = 9.81
    outputs: tuple = ("pose", "impacts")
    step: float = 0.0          # RK4 step; 0: duration/2000
    max_events: int = 100000
    max_steps: int = 10_000_000
    output_dt: float = 0.0
    keep_orthonormal: bool = False
    model: str = "auto"
    zeno_dt: float = 1e-9
    source: str = ""
    stability: Stability = Stability()

    @property
    def contact_possible(self) -> bool:
        return self.plane and self.shape != "none"

    @property
    def mu(self) -> float:
        return self.M * self.m / (self.M + self.m)

    @property
    def p(self) -> tuple:
        return (self.M, self.m, *self.J, self.g)


# ---- field checks ---------------------------------------------------------------------
ALLOWED = {
    "": {"name", "body", "point", "plane", "initial", "run", "stability"},
    "body": {"mass", "inertia", "shape", "radius", "semi_axes", "center"},
    "point": {"mass", "law"},
    "plane": {"restitution"},
    "initial": {"time", "com", "com_velocity", "omega", "quaternion", "matrix"},
    "run": {"duration", "method", "rtol", "atol", "g", "outputs", "step", "max_events",
            "max_steps", "output_dt", "keep_orthonormal", "model", "zeno_dt"},
    "stability": {"period", "impacts_every", "long_periods", "perturbations"},
}


def _where(table: str, key: str) -> str:
    return f"[{table}].{key}" if table else key


def _number(table: dict, name: str, key: str, default: Any = None, *, required=False):
    if key not in table:
        if required:
            raise SceneError(_where(name, key), "is required")
        return default
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(_where(name, key), f"must be a number, not {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise SceneError(_where(name, key), "must be finite (no NaN or infinity)")
    return value


def _vector(table: dict, name: str, key: str, n: int, default=None, *, required=False):
    if key not in table:
        if required:
            raise SceneError(_where(name, key), "is required")
        return default
    value = table[key]
    if not isinstance(value, list) or len(value) != n:
        raise SceneError(_where(name, key), f"must be a list of {n} numbers")
    out = []
    for k, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SceneError(f"{_where(name, key)}[{k}]",
                             f"must be a number, not {type(v).__name__}")
        if not math.isfinite(float(v)):
            raise SceneError(f"{_where(name, key)}[{k}]", "must be finite (no NaN or infinity)")
        out.append(float(v))
    return tuple(out)


def _string(table: dict, name: str, key: str, choices, default):
    if key not in table:
        return default
    value = table[key]
    if not isinstance(value, str):
        raise SceneError(_where(name, key), f"must be a string, not {type(value).__name__}")
    if choices is not None and value not in choices:
        raise SceneError(_where(name, key), f"must be one of {', '.join(choices)}; "
                                            f"got {value!r}")
    return value


def _table(doc: dict, key: str, required: bool) -> dict:
    if key not in doc:
        if required:
            raise SceneError(f"[{key}]", "is required")
        return {}
    value = doc[key]
    if not isinstance(value, dict):
        raise SceneError(f"[{key}]", "must be a table")
    unknown = sorted(set(value) - ALLOWED[key])
    if unknown:
        raise SceneError(f"[{key}].{unknown[0]}",
                         f"is not a known key (known: {', '.join(sorted(ALLOWED[key]))})")
    return value


def _rotation_from_quaternion(qv) -> np.ndarray:
    w, x, y, z = np.asarray(qv) / np.linalg.norm(qv)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _orientation(init: dict) -> np.ndarray:
    if "quaternion" in init and "matrix" in init:
        raise SceneError("[initial].quaternion", "give either quaternion or matrix, not both")
    if "matrix" in init:
        rows = init["matrix"]
        if not isinstance(rows, list) or len(rows) != 3:
            raise SceneError("[initial].matrix", "must be a list of 3 rows of 3 numbers")
        A = np.array([_vector({"row": r}, "initial", "row", 3, required=True) for r in rows])
        err = np.max(np.abs(A @ A.T - np.eye(3)))
        if err > 1e-6:
            raise SceneError("[initial].matrix", f"must be orthonormal (A A^T - 1 is {err:.1e})")
        if np.linalg.det(A) < 0:
            raise SceneError("[initial].matrix", "must be a rotation (det = +1), not a reflection")
        u, _, vt = np.linalg.svd(A)
        return u @ vt
    qv = _vector(init, "initial", "quaternion", 4, (1.0, 0.0, 0.0, 0.0))
    norm = math.sqrt(sum(c * c for c in qv))
    if norm < 1e-12:
        raise SceneError("[initial].quaternion", "must not have zero norm")
    return _rotation_from_quaternion(qv)


def _law(point: dict) -> tuple:
    if "law" not in point:
        raise SceneError("[point].law", "is required (three strings: x(t), y(t), z(t))")
    law = point["law"]
    if not isinstance(law, list) or len(law) != 3:
        raise SceneError("[point].law", "must be a list of three strings: x(t), y(t), z(t)")
    exprs = []
    for k, text in enumerate(law):
        if not isinstance(text, str):
            raise SceneError(f"[point].law[{k}]", f"must be a string, not {type(text).__name__}")
        try:
            exprs.append(parse_law(text))
        except LawError as exc:
            raise SceneError(f"[point].law[{k}]", f"{exc} in {text!r}") from None
    return tuple(law), tuple(exprs)


def _integer(table: dict, name: str, key: str, default: int, lo: int, hi: int) -> int:
    value = _number(table, name, key, float(default))
    if value != int(value) or not lo <= value <= hi:
        raise SceneError(_where(name, key), f"must be an integer in [{lo}, {hi}] (got {value:g})")
    return int(value)


def _stability(table: dict) -> Stability:
    period = _number(table, "stability", "period", None)
    if period is not None and period <= 0:
        raise SceneError("[stability].period", f"must be > 0 (got {period})")
    every = _integer(table, "stability", "impacts_every", 1, 1, 64)
    long_periods = _integer(table, "stability", "long_periods", 0, 0, 1_000_000)
    sizes = table.get("perturbations", [1e-6, 1e-4, 1e-2])
    if not isinstance(sizes, list) or not sizes:
        raise SceneError("[stability].perturbations", "must be a non-empty list of numbers")
    out = []
    for k, v in enumerate(sizes):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= 0.1:
            raise SceneError(f"[stability].perturbations[{k}]",
                             f"must be a number in (0, 0.1] (got {v!r})")
        out.append(float(v))
    return Stability(period, every, long_periods, tuple(out))


def parse_scene(source: str | dict, origin: str = "scene") -> Scene:
    """Validate a scene given as TOML text or as an already-parsed dict."""
    if isinstance(source, str):
        try:
            doc = tomllib.loads(source)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(origin, f"is not valid TOML ({exc})") from None
    elif isinstance(source, dict):
        doc = source
    else:
        raise SceneError(origin, "must be TOML text, a path or a dict")
    unknown = sorted(set(doc) - ALLOWED[""])
    if unknown:
        known = ", ".join(sorted(ALLOWED[""]))
        raise SceneError(unknown[0], f"is not a known key (known: {known})")
    name = doc.get("name", "scene")
    if not isinstance(name, str) or not name.strip():
        raise SceneError("name", "must be a non-empty string")

    body = _table(doc, "body", True)
    M = _number(body, "body", "mass", required=True)
    if M <= 0:
        raise SceneError("[body].mass", f"must be > 0 (got {M})")
    J = _vector(body, "body", "inertia", 3, required=True)
    for k, c in enumerate("xyz"):
        if J[k] <= 0:
            raise SceneError(f"[body].inertia[{k}]", f"J_{c} must be > 0 (got {J[k]})")
    for k, c in enumerate("xyz"):
        others = J[(k + 1) % 3] + J[(k + 2) % 3]
        if J[k] > others * (1 + 1e-12):
            raise SceneError(f"[body].inertia[{k}]",
                             f"J_{c} = {J[k]} exceeds the sum of the other two ({others}): "
                             "no mass distribution has these principal moments")
    shape = _string(body, "body", "shape", SHAPES, None)
    if shape is None:
        raise SceneError("[body].shape", f"is required (one of {', '.join(SHAPES)})")
    if shape == "sphere":
        if "semi_axes" in body:
            raise SceneError("[body].semi_axes", "belongs to an ellipsoid; a sphere has radius")
        radius = _number(body, "body", "radius", required=True)
        if radius <= 0:
            raise SceneError("[body].radius", f"must be > 0 (got {radius})")
        size: tuple = (radius,)
    elif shape == "ellipsoid":
        if "radius" in body:
            raise SceneError("[body].radius", "belongs to a sphere; an ellipsoid has semi_axes")
        size = _vector(body, "body", "semi_axes", 3, required=True)
        for k, a in enumerate(size):
            if a <= 0:
                raise SceneError(f"[body].semi_axes[{k}]", f"must be > 0 (got {a})")
    else:
        for key in ("radius", "semi_axes"):
            if key in body:
                raise SceneError(f"[body].{key}", "a body of shape 'none' has no size")
        size = ()
    center = _vector(body, "body", "center", 3, (0.0, 0.0, 0.0))

    point = _table(doc, "point", True)
    m = _number(point, "point", "mass", required=True)
    if m <= 0:
        raise SceneError("[point].mass", f"must be > 0 (got {m})")
    law_text, law = _law(point)

    plane_table = _table(doc, "plane", False)
    plane = "plane" in doc
    e = _number(plane_table, "plane", "restitution", 1.0)
    if plane and "restitution" not in plane_table:
        raise SceneError("[plane].restitution", "is required when [plane] is given")
    if not 0.0 <= e <= 1.0:
        raise SceneError("[plane].restitution", f"must be in [0, 1] (got {e})")

    init = _table(doc, "initial", False)
    t0 = _number(init, "initial", "time", 0.0)
    com = _vector(init, "initial", "com", 3, (0.0, 0.0, 0.0))
    com_v = _vector(init, "initial", "com_velocity", 3, (0.0, 0.0, 0.0))
    omega = _vector(init, "initial", "omega", 3, (0.0, 0.0, 0.0))
    A0 = _orientation(init)

    run = _table(doc, "run", False)
    duration = _number(run, "run", "duration", 5.0)
    if duration <= 0:
        raise SceneError("[run].duration", f"must be > 0 (got {duration})")
    method = _string(run, "run", "method", METHODS, "dopri5")
    rtol = _number(run, "run", "rtol", 1e-10)
    atol = _number(run, "run", "atol", 1e-12)
    if not 1e-16 <= rtol < 1:
        raise SceneError("[run].rtol", f"must be in [1e-16, 1) (got {rtol})")
    if not 0 < atol < 1:
        raise SceneError("[run].atol", f"must be in (0, 1) (got {atol})")
    g = _number(run, "run", "g", 9.81)
    if g < 0:
        raise SceneError("[run].g", f"must be >= 0 (got {g})")
    outputs = run.get("outputs", ["pose", "impacts"])
    if not isinstance(outputs, list) or not all(isinstance(o, str) for o in outputs):
        raise SceneError("[run].outputs", f"must be a list of strings from {', '.join(OUTPUTS)}")
    for o in outputs:
        if o not in OUTPUTS:
            raise SceneError("[run].outputs", f"{o!r} is not one of {', '.join(OUTPUTS)}")
    step = _number(run, "run", "step", duration / 2000.0)
    if step <= 0:
        raise SceneError("[run].step", f"must be > 0 (got {step})")
    max_events = _number(run, "run", "max_events", 100000.0)
    max_steps = _number(run, "run", "max_steps", 1e7)
    for key, value in (("max_events", max_events), ("max_steps", max_steps)):
        if value < 1 or value != int(value):
            raise SceneError(f"[run].{key}", f"must be a positive integer (got {value})")
    output_dt = _number(run, "run", "output_dt", 0.0)
    if output_dt < 0:
        raise SceneError("[run].output_dt", f"must be >= 0 (got {output_dt})")
    keep = run.get("keep_orthonormal", False)
    if not isinstance(keep, bool):
        raise SceneError("[run].keep_orthonormal", "must be true or false")
    model = _string(run, "run", "model", MODELS, "auto")
    zeno_dt = _number(run, "run", "zeno_dt", 1e-9)
    if not 0 < zeno_dt < 1:
        raise SceneError("[run].zeno_dt", f"must be in (0, 1) (got {zeno_dt})")

    stability = _stability(_table(doc, "stability", False))

    scene = Scene(name=name, M=M, J=J, shape=shape, size=size, center=center, m=m,
                  law_text=law_text, law=law, plane=plane, e=e, t0=t0, com=com,
                  com_velocity=com_v, omega=omega, A0=A0, duration=duration, method=method,
                  rtol=rtol, atol=atol, g=g, outputs=tuple(dict.fromkeys(outputs)),
                  step=step, max_events=int(max_events), max_steps=int(max_steps),
                  output_dt=output_dt, keep_orthonormal=keep, model=model, zeno_dt=zeno_dt,
                  source=origin, stability=stability)
    _check_along_law(scene)
    _check_start_above_plane(scene)
    return scene


def load_scene(scene) -> Scene:
    """A :class:`Scene` from a path, TOML text, a dict or a Scene."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        return parse_scene(scene, "scene")
    path = Path(scene)
    if not path.is_file():
        raise SceneError(str(scene), "no such scene file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(str(scene), f"cannot be read ({exc})") from None
    return parse_scene(text, str(path))


# ---- checks along the law ---------------------------------------------------------------
def law_functions(scene: Scene):
    """NumPy callables for x, x', x'' of each coordinate (from the parsed expressions)."""
    t = nt.t
    exprs = [[c, sp.diff(c, t), sp.diff(c, t, 2)] for c in scene.law]
    flat = [e for trio in exprs for e in trio]
    fn = sp.lambdify(t, flat, modules="numpy")

    def evaluate(ts):
        ts = np.asarray(ts, dtype=float)
        with np.errstate(all="ignore"):
            values = fn(ts)
        return np.array([np.broadcast_to(np.asarray(v, dtype=float), ts.shape)
                         for v in values])     # (9, len(ts)): x, x', x'', y, ...
    return evaluate


def _check_along_law(scene: Scene) -> None:
    ts = np.linspace(scene.t0, scene.t0 + scene.duration, 2001)
    values = law_functions(scene)(ts)
    names = ("x", "x'", "x''", "y", "y'", "y''", "z", "z'", "z''")
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise SceneError(f"[point].law[{row // 3}]",
                         f"is not twice differentiable on the run: {names[row]} is not finite "
                         f"at t = {ts[col]:.6g}")
    r = values[[0, 3, 6]]
    mu = scene.mu
    worst, where = np.inf, scene.t0
    for k in range(0, ts.size, 10):
        rk = r[:, k]
        J = np.diag(scene.J) + mu * ((rk @ rk) * np.eye(3) - np.outer(rk, rk))
        ev = np.linalg.eigvalsh(J)
        ratio = ev[0] / ev[-1]
        if ratio < worst:
            worst, where = ratio, ts[k]
    if not worst > 1e-12:
        raise SceneError("[body].inertia",
                         f"J is singular along the law (smallest/largest eigenvalue "
                         f"{worst:.1e} at t = {where:.6g}); R1 needs det J != 0")


def _check_start_above_plane(scene: Scene) -> None:
    if not scene.contact_possible:
        return
    from .geometry import lowest_point_numeric
    n = scene.A0[2]
    s = lowest_point_numeric(scene, n)
    r0 = law_functions(scene)(np.array([scene.t0]))[[0, 3, 6], 0]
    nu = scene.m / (scene.m + scene.M)
    h = scene.com[2] + n @ (s - nu * r0)
    scale = max(max(scene.size), 1e-3)
    if h < -1e-12 * scale:
        raise SceneError("[initial].com", f"the lowest point S starts below the plane "
                                          f"(height {h:.6g}); raise Z_C")
