"""Planning tasks: a scene without a point law, plus a ``[plan]`` table.

The body, point mass, plane and initial state are validated by the runtime's own scene
parser (:func:`derive.runtime.scene.parse_scene`, with the point held at ``start`` as a
placeholder law); the ``[plan]`` table is validated here.  Every failure is a
:class:`~derive.runtime.scene.SceneError` naming the field and the rule.

``[plan]`` keys (README section "Planning the point's motion"):

=================  ==========================================================================
goal               reorient | land | hop
horizon            s; reorient: the duration (objective = time: its upper bound); land and
                   hop: optional upper bound of the touchdown time / the period
target_matrix      a_ij at the end (reorient; land with at_touchdown = attitude)
at_touchdown       land: attitude | d_zero (d = CS x n = 0: the impact keeps omega, C2.4)
region             {center, radius}: P stays in this ball (body axes)
circle             {center = [c_x, c_y], radius, start_angle}: instead of a region, P moves
                   on this circle in the body plane z = 0
start              P at t = 0 (default: the region's centre)
max_acceleration   bound on |OP''|
rest_at_ends       P at rest at both ends (x' = x'' = 0); in a region it also returns to
                   its start (the law repeats); hop: at rest at the impact
objective          effort (integral of |OP''|^2) | time
apex_height        hop: the highest Z_C of each hop (the period follows from it)
require_stable     hop: fail unless the orbit is stable (default: prefer a stable one)
intervals          pieces of the law = multiple-shooting intervals (default 16)
substeps           RK4 steps per interval in the NLP (default 2)
tolerance          final accuracy of the defect-corrected plan (default 1e-10)
max_iterations     IPOPT iterations per solve (default 400)
=================  ==========================================================================
"""
from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..runtime.scene import Scene, SceneError, parse_scene

GOALS = ("reorient", "land", "hop")
OBJECTIVES = ("effort", "time")
TOUCHDOWN = ("attitude", "d_zero")
PLAN_KEYS = {"goal", "horizon", "target_matrix", "at_touchdown", "region", "circle",
             "start", "max_acceleration", "rest_at_ends", "objective", "apex_height",
             "require_stable", "intervals", "substeps", "tolerance", "max_iterations"}
TASK_KEYS = {"name", "body", "point", "plane", "initial", "run", "plan"}


@dataclass(frozen=True)
class Task:
    scene: Scene               # the runtime's scene (placeholder law: P held at start)
    doc: dict                  # the task's scene tables (body, point, plane, initial, run)
    goal: str
    horizon: float | None
    target: np.ndarray | None  # a_ij
    at_touchdown: str | None
    region_center: np.ndarray
    region_radius: float
    circle: tuple | None       # (c_x, c_y, R, start_angle)
    start: np.ndarray
    max_acceleration: float
    rest_at_ends: bool
    objective: str
    apex_height: float | None
    require_stable: bool
    intervals: int
    substeps: int
    tolerance: float
    max_iterations: int
    source: str = "task"

    @property
    def free_time(self) -> bool:
        return self.goal in ("land", "hop") or self.objective == "time"


def _where(key: str) -> str:
    return f"[plan].{key}"


def _num(plan: dict, key: str, default=None, *, required=False, positive=False,
         within: str = ""):
    """A number of ``plan`` (``within``: the name of the table ``plan`` is, for messages:
    ``region`` gives ``[plan].region.radius``)."""
    where = _where(f"{within}.{key}" if within else key)
    if key not in plan:
        if required:
            raise SceneError(where, "is required")
        return default
    v = plan[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise SceneError(where, f"must be a number, not {type(v).__name__}")
    v = float(v)
    if not math.isfinite(v):
        raise SceneError(where, "must be finite (no NaN or infinity)")
    if positive and v <= 0:
        raise SceneError(where, f"must be > 0 (got {v})")
    return v


def _vec(value, where: str, n: int) -> np.ndarray:
    if not isinstance(value, list) or len(value) != n:
        raise SceneError(where, f"must be a list of {n} numbers")
    out = []
    for k, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise SceneError(f"{where}[{k}]", "must be a finite number")
        out.append(float(v))
    return np.array(out)


def _int(plan: dict, key: str, default: int, lo: int, hi: int) -> int:
    v = plan.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise SceneError(_where(key), f"must be an integer in [{lo}, {hi}] (got {v!r})")
    return v


def _bool(plan: dict, key: str, default: bool) -> bool:
    v = plan.get(key, default)
    if not isinstance(v, bool):
        raise SceneError(_where(key), "must be true or false")
    return v


def _table(plan: dict, key: str, allowed: set) -> dict | None:
    if key not in plan:
        return None
    v = plan[key]
    if not isinstance(v, dict):
        raise SceneError(_where(key), "must be a table, e.g. { center = [...], radius = ... }")
    unknown = sorted(set(v) - allowed)
    if unknown:
        raise SceneError(f"{_where(key)}.{unknown[0]}",
                         f"is not a known key (known: {', '.join(sorted(allowed))})")
    return v


def _rotation(value, where: str) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 3:
        raise SceneError(where, "must be a list of 3 rows of 3 numbers (a_ij)")
    A = np.array([_vec(r, f"{where}[{k}]", 3) for k, r in enumerate(value)])
    err = float(np.max(np.abs(A @ A.T - np.eye(3))))
    if err > 1e-6:
        raise SceneError(where, f"must be orthonormal (A A^T - 1 is {err:.1e})")
    if np.linalg.det(A) < 0:
        raise SceneError(where, "must be a rotation (det = +1), not a reflection")
    u, _, vt = np.linalg.svd(A)
    return u @ vt


def parse_task(source, origin: str = "task") -> Task:
    """A :class:`Task` from TOML text or an already-parsed dict."""
    if isinstance(source, str):
        try:
            doc = tomllib.loads(source)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(origin, f"is not valid TOML ({exc})") from None
    elif isinstance(source, dict):
        doc = copy.deepcopy(source)
    else:
        raise SceneError(origin, "must be TOML text, a path or a dict")
    unknown = sorted(set(doc) - TASK_KEYS)
    if unknown:
        raise SceneError(unknown[0], f"is not a known key of a task "
                                     f"(known: {', '.join(sorted(TASK_KEYS))})")
    if "plan" not in doc:
        raise SceneError("[plan]", "is required (a task plans the point's law)")
    plan = doc["plan"]
    if not isinstance(plan, dict):
        raise SceneError("[plan]", "must be a table")
    bad = sorted(set(plan) - PLAN_KEYS)
    if bad:
        raise SceneError(_where(bad[0]), f"is not a known key (known: "
                                         f"{', '.join(sorted(PLAN_KEYS))})")
    point = doc.get("point")
    if isinstance(point, dict):
        for key in ("law", "table", "ends"):
            if key in point:
                raise SceneError(f"[point].{key}", "a task has no law: the [plan] table "
                                                   "plans it")
    run = doc.get("run", {})
    if not isinstance(run, dict):
        raise SceneError("[run]", "must be a table")
    extra = sorted(set(run) - {"g"})
    if extra:
        raise SceneError(f"[run].{extra[0]}", "a task's [run] has only g (the plan sets "
                                              "the duration and the integration)")

    goal = plan.get("goal")
    if goal not in GOALS:
        raise SceneError(_where("goal"), f"must be one of {', '.join(GOALS)}; got {goal!r}")
    objective = plan.get("objective", "effort")
    if objective not in OBJECTIVES:
        raise SceneError(_where("objective"), f"must be one of {', '.join(OBJECTIVES)}; "
                                              f"got {objective!r}")
    if goal == "hop" and objective == "time":
        raise SceneError(_where("objective"), "hop plans effort only: its period follows "
                                              "from apex_height")
    horizon = _num(plan, "horizon", None, positive=True)
    if goal == "reorient" and horizon is None:
        raise SceneError(_where("horizon"), "is required for reorient (the duration)")

    region = _table(plan, "region", {"center", "radius"})
    circle = _table(plan, "circle", {"center", "radius", "start_angle"})
    if region is not None and circle is not None:
        raise SceneError(_where("circle"), "give region or circle, not both")
    if circle is not None:
        if goal == "hop":
            raise SceneError(_where("circle"), "hop plans P in a region, not on a circle")
        cc = _vec(circle.get("center", [0.0, 0.0]), _where("circle.center"), 2)
        if "radius" not in circle:
            raise SceneError(_where("circle.radius"), "is required")
        cr = _num(circle, "radius", positive=True, within="circle")
        a0 = _num(circle, "start_angle", 0.0, within="circle")
        circ = (float(cc[0]), float(cc[1]), cr, a0)
        start = np.array([cc[0] + cr * math.cos(a0), cc[1] + cr * math.sin(a0), 0.0])
        if "start" in plan:
            raise SceneError(_where("start"), "on a circle P starts at start_angle")
        center, radius = np.array([cc[0], cc[1], 0.0]), cr
    else:
        if region is None:
            raise SceneError(_where("region"), "is required (or circle): where P may move")
        center = _vec(region.get("center", [0.0, 0.0, 0.0]), _where("region.center"), 3)
        if "radius" not in region:
            raise SceneError(_where("region.radius"), "is required")
        radius = _num(region, "radius", positive=True, within="region")
        circ = None
        start = _vec(plan["start"], _where("start"), 3) if "start" in plan else center.copy()
        if np.linalg.norm(start - center) > radius * (1 + 1e-12):
            raise SceneError(_where("start"), "must lie in the region")
    amax = _num(plan, "max_acceleration", required=True, positive=True)

    target = None
    if "target_matrix" in plan:
        target = _rotation(plan["target_matrix"], _where("target_matrix"))
    at_touchdown = None
    if goal == "reorient" and target is None:
        raise SceneError(_where("target_matrix"), "is required for reorient")
    if goal == "land":
        at_touchdown = plan.get("at_touchdown", "attitude" if target is not None else "d_zero")
        if at_touchdown not in TOUCHDOWN:
            raise SceneError(_where("at_touchdown"), f"must be one of {', '.join(TOUCHDOWN)}")
        if at_touchdown == "attitude" and target is None:
            raise SceneError(_where("target_matrix"), "is required for at_touchdown = "
                                                      "\"attitude\"")
        if at_touchdown == "d_zero" and target is not None:
            raise SceneError(_where("target_matrix"), "is not used with at_touchdown = "
                                                      "\"d_zero\"")
    elif "at_touchdown" in plan:
        raise SceneError(_where("at_touchdown"), "belongs to goal = \"land\"")
    if goal == "hop" and target is not None:
        raise SceneError(_where("target_matrix"), "a hop has no target attitude")
    apex = _num(plan, "apex_height", None, positive=True)
    if goal == "hop" and apex is None:
        raise SceneError(_where("apex_height"), "is required for hop")
    if goal != "hop":
        for key in ("apex_height", "require_stable"):
            if key in plan:
                raise SceneError(_where(key), "belongs to goal = \"hop\"")
    require_stable = _bool(plan, "require_stable", False)
    rest = _bool(plan, "rest_at_ends", goal != "hop")
    intervals = _int(plan, "intervals", 16, 4, 200)
    substeps = _int(plan, "substeps", 2, 1, 50)
    tolerance = _num(plan, "tolerance", 1e-10, positive=True)
    if tolerance > 1e-3:
        raise SceneError(_where("tolerance"), f"must be <= 1e-3 (got {tolerance})")
    max_iter = _int(plan, "max_iterations", 400, 10, 100000)

    # the scene tables, validated by the runtime's parser with P held at start
    scene_doc = {k: copy.deepcopy(v) for k, v in doc.items() if k != "plan"}
    if not isinstance(scene_doc.get("point"), dict):
        raise SceneError("[point]", "is required (a table with mass)")
    if goal in ("land", "hop") and "plane" not in scene_doc:
        raise SceneError("[plane]", f"is required for {goal}")
    if goal == "reorient" and "plane" in scene_doc:
        raise SceneError("[plane]", "reorient plans free flight: remove [plane]")
    probe = copy.deepcopy(scene_doc)
    probe["point"]["law"] = [repr(float(c)) for c in start]
    probe.setdefault("run", {})["duration"] = horizon or 1.0
    scene = parse_scene(probe, origin)
    if goal in ("land", "hop") and scene.shape == "none":
        raise SceneError("[body].shape", f"{goal} needs a shape that can touch the plane")
    if goal == "hop" and scene.g <= 0:
        raise SceneError("[run].g", "hop needs gravity (g > 0)")
    return Task(scene=scene, doc=scene_doc, goal=goal, horizon=horizon, target=target,
                at_touchdown=at_touchdown, region_center=center, region_radius=radius,
                circle=circ, start=start, max_acceleration=amax, rest_at_ends=rest,
                objective=objective, apex_height=apex, require_stable=require_stable,
                intervals=intervals, substeps=substeps, tolerance=tolerance,
                max_iterations=max_iter, source=origin)


def load_task(task) -> Task:
    """A :class:`Task` from a path, a dict or a Task."""
    if isinstance(task, Task):
        return task
    if isinstance(task, dict):
        return parse_task(task, "task")
    path = Path(task)
    if not path.is_file():
        raise SceneError(str(task), "no such task file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(str(task), f"cannot be read ({exc})") from None
    return parse_task(text, str(path))
