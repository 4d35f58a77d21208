"""Planning tasks: a scene without a point law, plus a ``[plan]`` table.

Every field is read against the one schema (:data:`derive.scene.schema.TASK`: the
scene's body, point mass, plane, initial state and ``[run].g``, and ``[plan]``); the
scene's own rules run on it without a law (the point held at ``start``), and the rules
of ``[plan]`` below, each its text and its check like the scene's
(:class:`derive.scene.rules.Rule`).  Every failure is a
:class:`~derive.scene.SceneError` naming the field and the rule.  The fields of
``[plan]`` are in the README's table (``derive.scene.plan_table()``).

A task of several internal bodies (``[[point]]`` and ``[[rotor]]``, issue 32) names the
bodies whose laws the plan makes in ``[plan].decide``; the others give their law (a
formula).  Its scene is a scene of the parser's, the decided bodies held where they start
(a point at ``start``, a rotor at psi = 0), so that every rule of a scene with those bodies
(their laws proved over the plan's span, C's start) runs on it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..scene import Scene, SceneError, build_body, parse_scene
from ..scene.bodies import describe, point_elements, rotor_elements
from ..scene.parse import read_document, read_file
from ..scene.rules import Rule
from ..scene.schema import TASK, body_name


@dataclass(frozen=True)
class Decided:
    """A body whose law the plan makes: ``kind`` point or rotor, ``index`` its place in
    ``scene.points`` or ``scene.rotors`` (from 0), ``name`` as [plan].decide says it."""
    kind: str
    index: int

    @property
    def name(self) -> str:
        return f"{self.kind} {self.index + 1}"


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
    # a task of [[point]] and [[rotor]] (the moments models): the decided bodies, points
    # first then rotors (each in its order), and the rotors' limits; () for a [point]
    # task (its point decided, the paper's model)
    decided: tuple = ()
    max_rotor_rate: float | None = None
    max_rotor_acceleration: float | None = None
    # travel: the guide P moves along (body axes, a unit vector) and the bound on |OP'|
    direction: np.ndarray | None = None
    max_velocity: float | None = None

    @property
    def bodies(self) -> bool:
        """The task has [[point]] or [[rotor]]: planned through the moments models."""
        return bool(self.decided)

    @property
    def decided_points(self) -> tuple:
        return tuple(d for d in self.decided if d.kind == "point")

    @property
    def decided_rotors(self) -> tuple:
        return tuple(d for d in self.decided if d.kind == "rotor")


class _Plan:
    """What the rules of ``[plan]`` read (the field values) and derive."""

    def __init__(self, v: dict, given: set):
        self.v, self.given = v, given
        self.goal = v["[plan].goal"]
        self.center = self.radius = self.circle = self.start = None
        self.at_touchdown = None
        # several bodies ([[point]], [[rotor]]): their elements and the decided ones
        self.bodies = "[[point]]" in v or "[[rotor]]" in v
        self.points = point_elements(v) if self.bodies else ()
        self.rotors = rotor_elements(v) if self.bodies else ()
        self.decided: tuple = ()

    @property
    def decides_point(self) -> bool:
        return not self.bodies or any(d.kind == "point" for d in self.decided)

    @property
    def decides_rotor(self) -> bool:
        return any(d.kind == "rotor" for d in self.decided)

    def __getitem__(self, key: str):
        return self.v[f"[plan].{key}"]

    def has(self, key: str) -> bool:
        return f"[plan].{key}" in self.given


def _decide(p: _Plan) -> None:
    if not p.bodies:
        if p.has("decide"):
            raise SceneError("[plan].decide", "belongs to a task with [[point]] or [[rotor]] "
                                              "(a [point] task plans its point)")
        return
    if not p.has("decide"):
        raise SceneError("[plan].decide", "is required with [[point]] or [[rotor]]: name the "
                                          "bodies the plan decides, e.g. [\"rotor 1\"]")
    elements = {"point": p.points, "rotor": p.rotors}
    chosen = set()
    for i, name in enumerate(p["decide"]):
        kind, k = body_name(name)
        if k > len(elements[kind]):
            raise SceneError(f"[plan].decide[{i}]", f"names {name!r}, but the task has "
                                                    f"{describe(len(p.points), len(p.rotors))}")
        chosen.add((kind, k - 1))
    for kind, els in elements.items():
        for k, el in enumerate(els):
            if (kind, k) in chosen and el.values["law"] is not None:
                raise SceneError(el.where("law"), f"the plan makes it ([plan].decide names "
                                                  f"\"{kind} {k + 1}\"): remove it")
            if (kind, k) not in chosen and el.values["law"] is None:
                raise SceneError(el.where("law"), f"is required: the plan does not decide "
                                                  f"this body ([plan].decide has no "
                                                  f"\"{kind} {k + 1}\")")
    p.decided = tuple(Decided(kind, k) for kind in ("point", "rotor")
                      for k in range(len(elements[kind])) if (kind, k) in chosen)


def _bounds(p: _Plan) -> None:
    """The bounds of the decided bodies, each required when it acts and refused when it
    does not."""
    for key, needed, what in (("max_acceleration", p.decides_point, "point"),
                              ("max_rotor_rate", p.decides_rotor, "rotor"),
                              ("max_rotor_acceleration", p.decides_rotor, "rotor")):
        if needed and p[key] is None:
            raise SceneError(f"[plan].{key}", "is required")
        if not needed and p.has(key):
            raise SceneError(f"[plan].{key}", f"bounds a decided {what}, and "
                             + ("[plan].decide names none" if p.bodies else
                                "a [point] task decides its point alone"))
    if not p.bodies:
        return
    if p.goal == "hop":
        raise SceneError("[plan].goal", "hop plans one [point]'s law (the vertical model): a "
                                        "task with [[point]] or [[rotor]] reorients or lands")
    if p.has("circle"):
        raise SceneError("[plan].circle", "P on a circle is planned for a [point] task: a "
                                          "task with [[point]] or [[rotor]] gives region")
    if p["at_touchdown"] == "d_zero":
        raise SceneError("[plan].at_touchdown", "d_zero is planned for a [point] task: a task "
                                                "with [[point]] or [[rotor]] lands with "
                                                "target_matrix (at_touchdown = \"attitude\")")
    if "[initial].carrier_velocity" in p.given:
        raise SceneError("[initial].carrier_velocity", "a task gives C's velocity "
                                                       "(com_velocity)")
    if not p.decides_point:
        for key in ("region", "start"):
            if p.has(key):
                raise SceneError(f"[plan].{key}", "places a decided point, and [plan].decide "
                                                  "names none")


def _tables(p: _Plan) -> None:
    tables = p.v["__tables__"]
    if p.goal == "travel" and "plane" not in tables:
        raise SceneError("[plane]", "is required for travel (the floor the body crawls on)")
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
    if not p.decides_point:
        return
    region, circle = p["region"], p["circle"]
    if region is not None and circle is not None:
        raise SceneError("[plan].circle", "give region or circle, not both")
    if p.goal == "travel" and circle is not None:
        raise SceneError("[plan].circle", "travel moves P along a line (direction, through "
                                          "region.center): give region")
    if p.goal == "travel" and p.has("start"):
        raise SceneError("[plan].start", "travel plans a periodic law: its phase is the "
                                         "plan's, P's guide is region.center along direction")
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
    if p.goal in ("hop", "travel") and target is not None:
        raise SceneError("[plan].target_matrix", f"a {p.goal} has no target attitude")


def _hop(p: _Plan) -> None:
    if p.goal == "hop" and p["apex_height"] is None:
        raise SceneError("[plan].apex_height", "is required for hop")
    if p.goal != "hop":
        for key in ("apex_height", "require_stable"):
            if p.has(key):
                raise SceneError(f"[plan].{key}", "belongs to goal = \"hop\"")


# the keys travel does not read: the law's class, its search and its bounds are its own
TRAVEL_UNREAD = {
    "horizon": "the period is the plan's (the bounds fix it)",
    "rest_at_ends": "the law is periodic",
    "objective": "the objective is the mean speed",
    "intervals": "the law is five phases of constant acceleration with linear corners",
    "substeps": "each candidate is run by the base model's C runtime, not RK4",
    "tolerance": "the search stops at max_iterations or when its simplex has shrunk",
}
FRICTION_KEYS = ("friction", "static_friction", "pressure")


def _travel(p: _Plan) -> None:
    if p.goal != "travel":
        for key in ("direction", "max_velocity"):
            if p.has(key):
                raise SceneError(f"[plan].{key}", "belongs to goal = \"travel\"")
        for key in FRICTION_KEYS:
            if f"[plane].{key}" in p.given:
                raise SceneError(f"[plane].{key}", "belongs to goal = \"travel\" (the other "
                                                   "goals plan over a smooth plane)")
        return
    if p.bodies:
        raise SceneError("[plan].goal", "travel plans one [point]'s law (a [point] task)")
    for table in ("control", "disturbance"):
        if table in p.v["__tables__"]:
            raise SceneError(f"[{table}]", "travel plans an open-loop periodic law: derive "
                                           "control does not close a loop around it")
    for key, why in TRAVEL_UNREAD.items():
        if p.has(key):
            raise SceneError(f"[plan].{key}", f"is not read by travel: {why}")
    d = p["direction"]
    if d is None:
        raise SceneError("[plan].direction", "is required for travel: the guide P moves "
                                             "along, in body axes")
    if np.linalg.norm(d) < 1e-12:
        raise SceneError("[plan].direction", "must not be zero")
    # the base model's own conditions first: the scene's rules would otherwise ask for what
    # a body off its face needs ([plane].restitution) and name that field instead
    if p.v["[body].shape"] not in ("box", "cylinder"):
        raise SceneError("[body].shape", "travel plans a body on its face (the base model): "
                                         "a box or a cylinder")
    if "plane" in p.v["__tables__"] and not p.v["[plane].friction"] > 0.0:
        raise SceneError("[plane].friction", "travel needs friction > 0: it holds the body "
                                             "while its point returns")


PLAN_RULES = (
    Rule("[plan].decide: required with [[point]] or [[rotor]] and refused without; each name "
         "an element of the task; a decided body gives no law, every other one its law (a "
         "formula)", _decide),
    Rule("[plan].max_acceleration: required when a point is decided (a [point] task: "
         "always), refused otherwise; max_rotor_rate and max_rotor_acceleration: required "
         "when a rotor is decided, refused otherwise; with [[point]] or [[rotor]]: goal "
         "reorient or land (with target_matrix), a region (no circle), region and start "
         "only when a point is decided", _bounds),
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
    Rule("travel: [plan].direction required (not zero), [plane] given, one [point]; "
         "horizon, rest_at_ends, objective, intervals, substeps, tolerance refused; "
         "direction, max_velocity and [plane].friction, static_friction, pressure only "
         "for travel", _travel),
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
    for name in ("point", "rotor"):
        items = doc.get(name)
        for i, el in enumerate(items if isinstance(items, list) else (), start=1):
            for key in ("table", "samples", "ends"):
                if isinstance(el, dict) and key in el:
                    raise SceneError(f"[[{name}]] {i}: {key}", "a task's body keeps a law "
                                     "given as a formula (law), or the plan makes it "
                                     "([plan].decide)")
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
    if p.bodies:
        scene = _bodies_scene(doc, v, p, origin)
    else:
        scene = build_body(v, given, tuple(p.start), origin)
    if p.goal in ("land", "hop") and scene.shape == "none":
        raise SceneError("[body].shape", f"{p.goal} needs a shape that can touch the plane")
    if p.goal == "hop" and scene.g <= 0:
        raise SceneError("[run].g", "hop needs gravity (g > 0)")
    direction = None
    if p.goal == "travel":
        direction = _travel_scene(scene, np.asarray(p["direction"], dtype=float), p.start,
                                  origin)
    require_stable = p["require_stable"] if p["require_stable"] is not None else False
    rest = p["rest_at_ends"] if p["rest_at_ends"] is not None else p.goal != "hop"
    return Task(scene=scene, goal=p.goal, horizon=p["horizon"], target=p["target_matrix"],
                at_touchdown=p.at_touchdown, spin_weight=p["spin_weight"],
                region_center=p.center, region_radius=p.radius,
                circle=p.circle, start=p.start, max_acceleration=p["max_acceleration"],
                rest_at_ends=rest, objective=p["objective"], apex_height=p["apex_height"],
                require_stable=require_stable, intervals=p["intervals"],
                substeps=p["substeps"], tolerance=p["tolerance"],
                max_iterations=p["max_iterations"], source=origin, decided=p.decided,
                max_rotor_rate=p["max_rotor_rate"],
                max_rotor_acceleration=p["max_rotor_acceleration"],
                direction=direction, max_velocity=p["max_velocity"])


# where the base model's refusal points (choice.base_refusal's sentences)
_BASE_FIELDS = (("box or a cylinder", "[body].shape"), ("on [plane]", "[body].shape"),
                ("on_plane", "[initial].on_plane"),
                ("friction", "[plane].friction"), ("omega", "[initial].omega"),
                ("vertical velocity", "[initial].carrier_velocity"),
                ("attitude", "[initial].quaternion"))


def _travel_scene(scene: Scene, d: np.ndarray, start: np.ndarray, origin: str) -> np.ndarray:
    """The task's scene runs the base model (a box or cylinder on its face on a rough
    plane) and the guide is horizontal there: the unit direction, or a SceneError.  The
    scene the plan will write is parsed with the point held at the guide's middle."""
    from ..runtime.choice import base_refusal
    from .travel_scene import scene_document
    if scene.g <= 0:
        raise SceneError("[run].g", "travel needs gravity (g > 0): friction holds the body")
    for key, value in (("com_velocity", scene.com_velocity), ("omega", scene.omega)):
        if any(c != 0.0 for c in value):
            raise SceneError(f"[initial].{key}", "travel starts the body at rest on its face "
                                                 "(the periodic crawl it plans forgets the "
                                                 "start): give zeros or leave it out")
    why = "it needs a box or a cylinder on [plane]"
    if scene.shape != "none" and scene.plane:
        held = scene_document(scene, {"law": [repr(float(c)) for c in start]}, 1.0)
        why = base_refusal(parse_scene(held, origin))
    if why is not None:
        field = next((f for word, f in _BASE_FIELDS if word in why), "[plan].goal")
        raise SceneError(field, f"travel plans a body on its face (the base model), and {why}")
    d = d / np.linalg.norm(d)
    up = float((scene.A0 @ d)[2])
    if abs(up) > 1e-9:
        raise SceneError("[plan].direction", f"must be horizontal with the face on the plane "
                                             f"(its vertical part in fixed axes is {up:.3g})")
    return d


PROOF_MARGIN = 1.1     # the kept laws are proved over this times the horizon


def _bodies_scene(doc: dict, v: dict, p: _Plan, origin: str) -> Scene:
    """The scene of a task of several bodies, read by the scene parser: the kept bodies
    with their laws, the decided ones held where they start (a point at ``start``, a
    rotor at psi = 0), proved over the plan's span (the horizon; for a free duration
    without a horizon every kept law must be constant)."""
    decided = {(d.kind, d.index) for d in p.decided}
    start = [repr(float(c)) for c in p.start] if p.start is not None else ["0", "0", "0"]
    points = [{"mass": el.values["mass"],
               "law": start if ("point", k) in decided else list(el.values["law"])}
              for k, el in enumerate(p.points)]
    rotors = [{"axis": list(el.values["axis"]), "inertia": el.values["inertia"],
               "law": "0" if ("rotor", k) in decided else el.values["law"]}
              for k, el in enumerate(p.rotors)]
    span = p["horizon"] * PROOF_MARGIN if p["horizon"] is not None else 1.0
    sd = {"name": v["name"], "body": doc["body"], "initial": doc.get("initial", {}),
          "run": {"g": v["[run].g"], "duration": span, "method": "dop853"}}
    if "plane" in doc:
        sd["plane"] = doc["plane"]
    for table in ("control", "disturbance"):     # derive control's (mode replan)
        if table in doc:
            sd[table] = doc[table]
    if points:
        sd["point"] = points
    if rotors:
        sd["rotor"] = rotors
    scene = parse_scene(sd, origin)
    if p["horizon"] is None and (p.goal != "reorient"):
        kept = [b for b in (*scene.points, *scene.rotors)
                if b.summary.max_speed > 0 or b.summary.max_acceleration > 0]
        if kept:
            raise SceneError("[plan].horizon", f"is required when a body keeps a law that "
                                               f"moves ({kept[0].name}) and the plan's "
                                               "duration is free: the span its law is "
                                               "proved over")
    return scene


def load_task(task) -> Task:
    """A :class:`Task` from a path, a dict or a Task."""
    if isinstance(task, Task):
        return task
    if isinstance(task, dict):
        return parse_task(task, "task")
    path = Path(task)
    return parse_task(read_file(path, "task"), str(path))
