"""Planning tasks: a scene without a point law, plus a ``[plan]`` table.

Every field is read against the one schema (:data:`derive.scene.schema.TASK`: the
scene's body, point mass, plane, initial state and ``[run].g``, and ``[plan]``); the
scene's own rules run on it without a law (the point held at ``start``), and the rules
of ``[plan]`` below, each its text and its check like the scene's
(:class:`derive.scene.rules.Rule`).  Every failure is a
:class:`~derive.scene.SceneError` naming the field and the rule.  The fields of
``[plan]`` are in the README's table (``derive.scene.plan_table()``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..scene import Scene, SceneError, build_body
from ..scene.parse import read_document, read_file
from ..scene.rules import Rule
from ..scene.schema import TASK


@dataclass(frozen=True)
class Task:
    scene: Scene               # the task's scene: body, point mass, plane, initial state
    goal: str                  #   (no law: the planner makes it)
    horizon: float | None
    target: np.ndarray | None  # a_ij
    at_touchdown: str | None
    spin_weight: float         # land: the weight of |omega+|^2 after the impact
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


class _Plan:
    """What the rules of ``[plan]`` read (the field values) and derive."""

    def __init__(self, v: dict, given: set):
        self.v, self.given = v, given
        self.goal = v["[plan].goal"]
        self.center = self.radius = self.circle = self.start = None
        self.at_touchdown = None

    def __getitem__(self, key: str):
        return self.v[f"[plan].{key}"]

    def has(self, key: str) -> bool:
        return f"[plan].{key}" in self.given


def _tables(p: _Plan) -> None:
    tables = p.v["__tables__"]
    if p.goal in ("land", "hop") and "plane" not in tables:
        raise SceneError("[plane]", f"is required for {p.goal}")
    if p.goal == "reorient" and "plane" in tables:
        raise SceneError("[plane]", "reorient plans free flight: remove [plane]")


def _objective(p: _Plan) -> None:
    if p.goal == "hop" and p["objective"] == "time":
        raise SceneError("[plan].objective", "hop plans effort only: its period follows "
                                             "from apex_height")
    if p.goal == "reorient" and p["horizon"] is None:
        raise SceneError("[plan].horizon", "is required for reorient (the duration)")


def _where_p_moves(p: _Plan) -> None:
    region, circle = p["region"], p["circle"]
    if region is not None and circle is not None:
        raise SceneError("[plan].circle", "give region or circle, not both")
    if circle is not None:
        if p.goal == "hop":
            raise SceneError("[plan].circle", "hop plans P in a region, not on a circle")
        if p.has("start"):
            raise SceneError("[plan].start", "on a circle P starts at start_angle")
        (cx, cy), R, a0 = circle["center"], circle["radius"], circle["start_angle"]
        p.circle = (cx, cy, R, a0)
        p.start = np.array([cx + R * math.cos(a0), cy + R * math.sin(a0), 0.0])
        p.center, p.radius = np.array([cx, cy, 0.0]), R
        return
    if region is None:
        raise SceneError("[plan].region", "is required (or circle): where P may move")
    p.center, p.radius = np.array(region["center"]), region["radius"]
    p.start = np.array(p["start"]) if p["start"] is not None else p.center.copy()
    if np.linalg.norm(p.start - p.center) > p.radius * (1 + 1e-12):
        raise SceneError("[plan].start", "must lie in the region")


def _attitude(p: _Plan) -> None:
    target = p["target_matrix"]
    if p.goal == "reorient" and target is None:
        raise SceneError("[plan].target_matrix", "is required for reorient")
    if p.goal == "land":
        p.at_touchdown = p["at_touchdown"] or ("attitude" if target is not None else "d_zero")
        if p.at_touchdown == "attitude" and target is None:
            raise SceneError("[plan].target_matrix", "is required for at_touchdown = "
                                                     "\"attitude\"")
        if p.at_touchdown == "d_zero" and target is not None:
            raise SceneError("[plan].target_matrix", "is not used with at_touchdown = "
                                                     "\"d_zero\"")
    elif p.has("at_touchdown"):
        raise SceneError("[plan].at_touchdown", "belongs to goal = \"land\"")
    if p.goal != "land" and p.has("spin_weight"):
        raise SceneError("[plan].spin_weight", "belongs to goal = \"land\"")
    if p.goal == "hop" and target is not None:
        raise SceneError("[plan].target_matrix", "a hop has no target attitude")


def _hop(p: _Plan) -> None:
    if p.goal == "hop" and p["apex_height"] is None:
        raise SceneError("[plan].apex_height", "is required for hop")
    if p.goal != "hop":
        for key in ("apex_height", "require_stable"):
            if p.has(key):
                raise SceneError(f"[plan].{key}", "belongs to goal = \"hop\"")


PLAN_RULES = (
    Rule("[plane]: given for land and hop, absent for reorient (free flight)", _tables),
    Rule("[plan].objective: time only for reorient; [plan].horizon: required for reorient",
         _objective),
    Rule("[plan]: region or circle, not both (circle not for hop); start inside the region, "
         "not with a circle", _where_p_moves),
    Rule("[plan].target_matrix: required for reorient and for land at_touchdown = "
         "\"attitude\", absent for a hop; at_touchdown and spin_weight only for land",
         _attitude),
    Rule("[plan].apex_height: required for hop; apex_height and require_stable only for hop",
         _hop),
)


def _no_law(doc: dict) -> None:
    """A task's [point] and [run] say what a task has instead of 'not a known key'."""
    if "plan" not in doc:
        raise SceneError("[plan]", "is required (a task plans the point's law)")
    point, run = doc.get("point"), doc.get("run")
    if isinstance(point, dict):
        for key in ("law", "table", "samples", "ends"):
            if key in point:
                raise SceneError(f"[point].{key}", "a task has no law: the [plan] table "
                                                   "plans it")
    if isinstance(run, dict):
        extra = sorted(set(run) - {"g"})
        if extra:
            raise SceneError(f"[run].{extra[0]}", "a task's [run] has only g (the plan sets "
                                                  "the duration and the integration)")


def parse_task(source, origin: str = "task") -> Task:
    """A :class:`Task` from TOML text or an already-parsed dict."""
    doc, _ = read_document(source, origin, "task")
    _no_law(doc)
    v, given = TASK.read(doc)
    p = _Plan(v, given)
    for rule in PLAN_RULES:
        rule.check(p)
    scene = build_body(v, given, tuple(p.start), origin)
    if p.goal in ("land", "hop") and scene.shape == "none":
        raise SceneError("[body].shape", f"{p.goal} needs a shape that can touch the plane")
    if p.goal == "hop" and scene.g <= 0:
        raise SceneError("[run].g", "hop needs gravity (g > 0)")
    require_stable = p["require_stable"] if p["require_stable"] is not None else False
    rest = p["rest_at_ends"] if p["rest_at_ends"] is not None else p.goal != "hop"
    return Task(scene=scene, goal=p.goal, horizon=p["horizon"], target=p["target_matrix"],
                at_touchdown=p.at_touchdown, spin_weight=p["spin_weight"],
                region_center=p.center, region_radius=p.radius,
                circle=p.circle, start=p.start, max_acceleration=p["max_acceleration"],
                rest_at_ends=rest, objective=p["objective"], apex_height=p["apex_height"],
                require_stable=require_stable, intervals=p["intervals"],
                substeps=p["substeps"], tolerance=p["tolerance"],
                max_iterations=p["max_iterations"], source=origin)


def load_task(task) -> Task:
    """A :class:`Task` from a path, a dict or a Task."""
    if isinstance(task, Task):
        return task
    if isinstance(task, dict):
        return parse_task(task, "task")
    path = Path(task)
    return parse_task(read_file(path, "task"), str(path))
