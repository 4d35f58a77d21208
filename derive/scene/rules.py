"""The rules across fields of a scene, each one object holding its text (what the README
and ``derive scene new`` say) and its check, in the order they are checked.

A rule reads and fills a :class:`Draft`: the validated field values (from
:meth:`derive.scene.schema.Schema.read`) and what earlier rules derived from them (the
shape's size, the law and its summary, ...).  The rules of the *static part* read no
field of ``[initial]`` but its time; the *state rules* read the initial state.  A scene
seen before with other initial numbers runs only the state rules
(:mod:`derive.scene.cache`).

A rule that reads a field a parameter study may vary in bulk (:data:`derive.scene.bulk.BULK`)
also has a form over columns (``Rule.bulk``): the same draft with those fields as NumPy
columns, one entry per variant, and the same predicate as its check, giving where it
fails instead of raising (:func:`check_bulk`).

A scene may be read without a law (a planning task, whose law the planner makes): the
rules that need the law then do not apply, and the point's position at the start, which
the start-above-the-plane rule reads, is given instead (``Draft.point_at``).

The internal bodies (``[point]`` or ``[[point]]``, ``[[rotor]]``) are read and proved by
:mod:`derive.scene.bodies`; a scene of one point keeps its law in ``Draft.law`` as
before, any other in ``Draft.bodies`` (the law of them all) with ``Draft.law`` None.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache, reduce
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .. import abi, shapes

from . import bodies
from .errors import SceneError
from .scene import body_size
from .law import LawSummary
from .schema import (ARRAY_ONLY, ARRAYS, AXIS_TOLERANCE, FIELDS, MAX_ROWS, MIN_DURATION,
                     REQUIRED, as_rotation)

REQUIRED_FIELDS = tuple(f for f in FIELDS if f.default is REQUIRED)
RESTITUTION = "[plane].restitution"      # required, but by a body started on a face
BASE_SHAPES = ("box", "cylinder")        # the shapes with a face to rest on (the base model)
# tables a scene may leave out: their required fields are required when they are given
OPTIONAL_TABLES = frozenset(("plane", "stability", "plan", "control", "disturbance"))


@dataclass
class Draft:
    """What the rules read (``v``, ``given``) and what they derive, in order."""
    v: dict
    given: set
    origin: str = "scene"
    base: Path | None = None
    with_law: bool = True                  # False: a scene without a law (a task)
    point_at: tuple | None = None          # OP at t0 when there is no law
    # derived by the static rules
    size: tuple = ()
    center: tuple = (0.0, 0.0, 0.0)
    plane: bool = False
    e: float = 1.0
    friction: float = 0.0
    restitution_model: str = "energetic"
    spin_friction: float = 0.0
    rolling_resistance: float = 0.0
    static_friction: float | None = None   # the base model's mu_s, pressure (None: not given)
    pressure: str | None = None
    t0: float = 0.0
    duration: float = 0.0
    law: Any = None                        # one point's law (None for other bodies)
    law_text: tuple = ()
    summary: LawSummary | None = None
    max_distance: float = 0.0
    point_elements: tuple = ()             # schema.Element of each point, each rotor
    rotor_elements: tuple = ()
    one_point: bool = True                 # the bodies are one point: law is its law
    points: tuple = ()                     # bodies.Point, bodies.Rotor: proved
    rotors: tuple = ()
    laws: tuple = ()                       # each point's (law, law_text, summary)
    bodies: Any = None                     # the law of every body (not one point)
    slowest: str = ""                      # the body of the shortest time scale
    # derived by the state rules
    A0: np.ndarray | None = None
    extra: dict = field(default_factory=dict)

    def for_state(self, v: dict, given: set) -> "Draft":
        """A copy of this (static) draft for the state rules of other field values (a
        shallow copy: dataclasses.replace re-runs __init__ and costs a tenth of a
        validation)."""
        d = object.__new__(Draft)
        d.__dict__.update(self.__dict__)
        d.v, d.given, d.A0, d.extra = v, given, None, {}
        return d

    @property
    def law_field(self) -> str:
        """The field the scene gave its law in (for messages; with several bodies, the
        body of the shortest time scale)."""
        if self.one_point:
            return bodies.law_field(self.point_elements[0])
        return self.slowest

    @property
    def body_size(self) -> float:
        return body_size(self.v["[body].shape"], self.size, self.v["[body].inertia"],
                         self.v["[body].mass"])


@dataclass(frozen=True)
class Rule:
    """A rule across fields: ``text`` (empty for the schema's own requirements) and
    ``check(draft)``, which raises :class:`SceneError` or derives into the draft.
    ``law``: the rule reads the law (skipped for a scene without one).  ``bulk(draft)``,
    for a rule that reads a field of :data:`derive.scene.bulk.BULK`: the check over a
    draft whose fields may be columns (a study's variants), deriving as ``check`` does and
    returning where the rule fails (a bool, or a bool per variant) instead of raising."""
    text: str
    check: Callable[[Draft], None]
    law: bool = False
    bulk: Callable[[Draft], Any] | None = None


def least(xs):
    """The least of a few numbers, or entry by entry of a few numbers and columns (the
    rules' min over a study's variants at once)."""
    try:
        return min(xs)
    except ValueError:                 # a column among them: its truth is ambiguous
        return reduce(np.minimum, xs)


def most(xs):
    """The greatest of a few numbers, or entry by entry (as :func:`least`)."""
    try:
        return max(xs)
    except ValueError:
        return reduce(np.maximum, xs)


# ---- the static part ---------------------------------------------------------------------
def _required(d: Draft) -> None:
    v, given = d.v, d.given
    for f in REQUIRED_FIELDS:
        if f.where not in v or v[f.where] is not REQUIRED or f.where == RESTITUTION:
            continue                  # (restitution: a state rule, _restitution)
        if f.table in OPTIONAL_TABLES and f.table not in v["__tables__"]:
            continue                  # a table given whole or not at all
        if f.table in ARRAYS and (f.table in ARRAY_ONLY or f"[[{f.table}]]" in v or (
                f.table not in v["__tables__"] and d.with_law)):
            continue                  # an array's elements are read whole; no point: none
        if f.table in ("body", "point") and not any(g.startswith(f"[{f.table}]")
                                                     for g in given):
            raise SceneError(f"[{f.table}]", "is required")
        raise SceneError(f.where, "is required" + (f" ({f.rule})" if f.choices else ""))
    d.plane = "plane" in v["__tables__"]
    d.e = (v[RESTITUTION] if RESTITUTION in given else math.nan) if d.plane else 1.0
    d.friction = v.get("[plane].friction", 0.0) if d.plane else 0.0
    d.restitution_model = v.get("[plane].restitution_model", "energetic") if d.plane \
        else "energetic"
    for key in ("spin_friction", "rolling_resistance"):
        value = v.get(f"[plane].{key}", 0.0) if d.plane else 0.0
        if value > 0.0 and not d.friction > 0.0:
            raise SceneError(f"[plane].{key}", "needs [plane].friction > 0 (the couple acts "
                                               "in the rough model's contact)")
        setattr(d, key, value)
    _face_keys(d)
    d.t0 = v["[initial].time"]
    if d.with_law:
        d.point_elements = bodies.point_elements(v)
        d.rotor_elements = bodies.rotor_elements(v)
        d.one_point = len(d.point_elements) == 1 and not d.rotor_elements


def _required_bulk(d: Draft) -> bool:
    """The same: of the fields a study varies in bulk it reads only e, to copy it."""
    _required(d)
    return False


def _face_keys(d: Draft) -> None:
    """[plane].static_friction (>= friction) and pressure: the base model's, kept as None
    where not given (choice.py refuses them by name on the other models)."""
    v, given = d.v, d.given
    d.static_friction = d.pressure = None
    if "[plane].static_friction" in given and d.plane:
        mu_s = v["[plane].static_friction"]
        if not mu_s >= d.friction:
            raise SceneError("[plane].static_friction", f"must be >= [plane].friction "
                                                        f"({mu_s:g} < {d.friction:g})")
        d.static_friction = mu_s
    if "[plane].pressure" in given and d.plane:
        d.pressure = v["[plane].pressure"]


def _exceeds_the_others(J, k: int):
    """J_k above the sum of the other two moments (by more than 1e-12 of it)."""
    return J[k] > (J[(k + 1) % 3] + J[(k + 2) % 3]) * (1 + 1e-12)


def _singular_inertia(J):
    return least(J) < 1e-9 * most(J)


def _inertia(d: Draft) -> None:
    J = d.v["[body].inertia"]
    for k, c in enumerate("xyz"):
        if _exceeds_the_others(J, k):
            raise SceneError(f"[body].inertia[{k}]",
                             f"J_{c} = {J[k]:g} exceeds the sum of the other two "
                             f"({J[(k + 1) % 3] + J[(k + 2) % 3]:g}): no mass distribution "
                             "has these principal moments")
    if _singular_inertia(J):
        raise SceneError("[body].inertia", "J is near-singular: the smallest moment is below "
                                           "1e-9 of the largest (R1 needs det J != 0)")


def _inertia_bulk(d: Draft):
    J = d.v["[body].inertia"]
    return (_exceeds_the_others(J, 0) | _exceeds_the_others(J, 1) | _exceeds_the_others(J, 2)
            | _singular_inertia(J))


def _shape(d: Draft) -> None:
    v = d.v
    name = v["[body].shape"]
    shape = shapes.SHAPES.get(name)
    mine = {s.key for s in shape.sizes} if shape else set()
    for size, names in shapes.size_fields():
        if size.key in mine:
            if v[f"[body].{size.key}"] is None:
                raise SceneError(f"[body].{size.key}", f'is required for shape = "{name}"')
        elif v[f"[body].{size.key}"] is not None:
            has = (f"{shapes.with_article(name)} has " + ", ".join(s.key for s in shape.sizes)
                   if shape else "a body of shape 'none' has no size")
            raise SceneError(f"[body].{size.key}",
                             f"belongs to {' and '.join(names)}; {has}")
    size = shapes.size_of(shape, {k: v[f"[body].{k}"] for k in mine}) if shape else ()
    center = v["[body].center"]
    if size and math.sqrt(sum(c * c for c in center)) > 100 * shape.reach(size):
        raise SceneError("[body].center", "is more than 100 sizes away from O")
    d.size, d.center = size, center


def _law_source(d: Draft) -> None:
    for el in d.point_elements:
        bodies.check_source(el)


def _as_for_one(check):
    """The bulk form of a rule that reads a point's element, whose mass may be a study's
    column, but not its mass: the check itself, the same for every variant."""
    def bulk(d: Draft) -> bool:
        check(d)
        return False
    return bulk


def _model_by_hand(d: Draft) -> None:
    if d.one_point:
        return
    what = bodies.describe(len(d.point_elements), len(d.rotor_elements))
    model = d.v["[run].model"]
    if model not in ("auto", "moments", "moments_rough"):
        raise SceneError("[run].model", f"{model!r} reads one point's law; a scene of {what} "
                         "takes auto, moments or moments_rough (its bodies through their "
                         "moments)")
    if "control" in d.v["__tables__"] and d.v["[control].mode"] != "replan":
        raise SceneError("[control]", f"closes its loop around one point's law (each "
                         f"controller of mode {d.v['[control].mode']} reads and sets it): a "
                         f"scene of {what} has none to set (the re-planning controller, "
                         "mode = \"replan\", drives a task's decided bodies; pushes act "
                         "without [control]: [disturbance].pushes)")
    if "stability" in d.v["__tables__"]:
        raise SceneError("[stability]", f"is read by `derive stability` only, which "
                         f"analyses one point's law (its formulas), and this scene has "
                         f"{what}: remove it (`derive simulate` runs the scene)")


def _run_span(d: Draft) -> None:
    v = d.v
    t0, duration = d.t0, v["[run].duration"]
    t1 = t0 + duration
    if duration < MIN_DURATION:
        raise SceneError("[run].duration", f"must be at least {MIN_DURATION:g} s (got "
                                           f"{duration:g}): no step of the runtime resolves it")
    if not math.isfinite(t1) or (t1 - t0) < 1e-9 * duration:
        raise SceneError("[run].duration", f"is lost in the magnitude of the start time "
                                           f"{t0:g}")
    out_dt = v["[run].output_dt"]
    if out_dt > 0 and duration / out_dt > MAX_ROWS:
        raise SceneError("[run].output_dt", f"gives {duration / out_dt:.3g} rows (at most "
                                            f"{MAX_ROWS:.0e}); use a larger output_dt")
    d.duration = duration


def _law(d: Draft) -> None:
    """Every body's law compiled (a formula) or built (a table), and proved over the run;
    for a scene that is not one point, the law of them all."""
    t0, t1 = d.t0, d.t0 + d.duration
    laws = [bodies.point_law(el, t0, t1, d.base) for el in d.point_elements]
    d.rotors = tuple(bodies.rotor(el, t0, t1, d.base) for el in d.rotor_elements)
    if d.one_point:
        d.law, d.law_text, d.summary = laws[0]
    d.laws = tuple(laws)


def _points(d: Draft) -> None:
    """Each point proved over the run (P within its max_distance: bodies.point), and what
    several bodies' law and summary are."""
    t0, t1 = d.t0, d.t0 + d.duration
    size = d.body_size
    d.points = tuple(bodies.point(el, *law, t0, t1, size)
                     for el, law in zip(d.point_elements, d.laws))
    if d.one_point:
        d.max_distance = d.points[0].max_distance
    else:
        d.summary, d.slowest = bodies.summary_of(d.points, d.rotors)
        d.max_distance = max((p.max_distance for p in d.points), default=0.0)
        d.bodies = bodies.law_of(d.points, d.rotors)


def point_mass(d: Draft):
    """The one point's mass: [point].mass (a study's column where it varies it), or the
    single [[point]]'s."""
    m = d.v.get("[point].mass")
    return m if isinstance(m, (float, int, np.ndarray)) else d.points[0].mass


def _singular_along_the_law(d: Draft):
    """R1: J = diag(J) + mu (|r|^2 1 - r r^T) non-singular along the law; its eigenvalues
    are at least min(J) (the added term is positive semi-definite), so only the ratio to
    the largest can degrade: bounded through max |OP| (several points: the inertia they
    add about the centre of mass is at most sum m_j max |OP_j|^2).  (``<=``, not ``not
    >``: every number here is finite and positive, and it reads columns too.)"""
    v = d.v
    J, M = v["[body].inertia"], v["[body].mass"]
    if d.one_point:
        m = point_mass(d)
        largest = most(J) + M * m / (M + m) * d.summary.max_radius ** 2
    else:
        largest = most(J) + sum(p.mass * p.summary.max_radius ** 2 for p in d.points)
    return least(J) <= 1e-12 * largest


def _reach(d: Draft) -> None:
    _points(d)
    if _singular_along_the_law(d):
        raise SceneError("[body].inertia", "J of E1.5 is near-singular along the law "
                                           "(smallest/largest below 1e-12); R1 needs det J != 0")


def _reach_bulk(d: Draft):
    """(A study varies M and J in bulk only where the body has a shape: then the body's
    size, and max_distance, do not read them.)"""
    _points(d)
    return _singular_along_the_law(d)


def _time_scale(d: Draft) -> None:
    v = d.v
    if d.plane and v["[body].shape"] != "none" and v["[run].method"] != "rk4" \
            and d.duration / d.summary.time_scale > v["[run].max_steps"]:
        # with the plane a step is at most the law's time scale (driver.options): the run
        # could only end at max_steps, after minutes of work
        moves = "turns the rotor" if d.law_field.startswith("[[rotor]]") else "moves P"
        raise SceneError(d.law_field,
                         f"{moves} on a time scale of {d.summary.time_scale:.3g} s "
                         f"(sqrt(amplitude / max |OP''|)); with the plane a step is "
                         f"at most that, so {d.duration:g} s need at least "
                         f"{d.duration / d.summary.time_scale:.3g} steps, beyond [run]."
                         f"max_steps = {v['[run].max_steps']}: shorten "
                         "[run].duration or slow the law")


STATIC_RULES = (
    Rule("", _required, bulk=_required_bulk),
    Rule("[body].inertia: each moment at most the sum of the other two (a real mass "
         "distribution), the smallest at least 1e-9 of the largest", _inertia,
         bulk=_inertia_bulk),
    Rule("[body]: the size fields of its shape and no others (" + "; ".join(
        f"{' and '.join(s.key for s in sh.sizes)} for {sh.name}"
        for sh in shapes.SHAPES.values()) + "; nothing for none); the centre within 100 "
         "sizes of O", _shape),
    Rule("[point] and each [[point]]: exactly one of law, table, samples; ends only with a "
         "table or samples", _law_source, law=True, bulk=_as_for_one(_law_source)),
    Rule(f"[[point]] and [[rotor]]: at most {ARRAYS['point']} points and {ARRAYS['rotor']} "
         "rotors; a scene that is not one point takes [run].model auto, moments or "
         "moments_rough (the others read one point's law), no [control] but mode "
         "replan (hop's and mirror's controllers read and set one point's law) and no "
         "[stability] (derive stability, its only reader, analyses one point's law)",
         _model_by_hand, law=True),
    Rule("[run]: a duration that a step resolves and that is not lost in the start time; "
         "at most 1e7 output rows (duration/output_dt)", _run_span, law=True),
    Rule("[point].law[k]: x, y, z and their first two derivatives finite and continuous "
         "over the whole run (proved by interval arithmetic: no vanishing denominator, log, "
         "sqrt or non-integer power of a non-positive number, asin/acos outside (-1, 1) or "
         "tan pole); [point].table: a periodic table repeats; otherwise the run stays "
         "inside its times; the same for each [[point]], and for each [[rotor]]'s psi "
         "(exactly one of law and table; ends only with a table); "
         f"each [[rotor]]'s axis a unit vector (|a| within {AXIS_TOLERANCE:g} of 1, then "
         "normalised)",
         _law, law=True, bulk=_as_for_one(_law)),
    Rule("[point]: P stays within max_distance of O (each [[point]] within its own); J of "
         "E1.5 stays non-singular (R1); the tables of several bodies all periodic (with "
         "the same first and last times) or none; the formulas of all bodies at most "
         f"{abi.LAW_MAX_NODES} operations together", _reach, law=True, bulk=_reach_bulk),
    Rule("[point] with the plane: duration / the law's time scale (sqrt(amplitude / max "
         "|OP''|), the longest step then; with several bodies the shortest of theirs) at "
         "most [run].max_steps", _time_scale, law=True),
)


# ---- the state rules ---------------------------------------------------------------------
def rotation_from_quaternion(qv) -> np.ndarray:
    w, x, y, z = qv
    r = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w * r, x * r, y * r, z * r
    return np.array((
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))).reshape(3, 3)


def _orientation(d: Draft) -> None:
    v, given = d.v, d.given
    if "[initial].quaternion" in given and "[initial].matrix" in given:
        raise SceneError("[initial].quaternion", "give either quaternion or matrix, not both")
    if v["[initial].matrix"] is not None:
        d.A0 = as_rotation(v["[initial].matrix"], "[initial].matrix")
        return
    qv = v["[initial].quaternion"]
    w, x, y, z = qv
    if math.sqrt(w * w + x * x + y * y + z * z) < 1e-12:
        raise SceneError("[initial].quaternion", "must not have zero norm")
    d.A0 = rotation_from_quaternion(qv)


@lru_cache(maxsize=256)
def _law_position(law, t: float) -> tuple:
    """OP at one time (a pure function of the program, itself cached by its text)."""
    return tuple(float(c) for c in law.point(t)[:3])


def point_position(law, t0: float) -> tuple:
    if law.kind == "program":
        return _law_position(law, t0)
    return tuple(law.point(t0)[:3].tolist())    # (tables are not cached: they are large)


def start_height(shape: str, size: tuple, center: tuple, nu: float, A0, com, r) -> float:
    """The height of S above the plane at the start: S the support point of -n on the
    shape (derive/shapes.py), n the vertical in body axes, C at ``com``, P at ``r``."""
    n = A0[2].tolist()
    s = shapes.of(shape).lowest(n, center, size)
    return com[2] + sum(n[k] * (s[k] - nu * r[k]) for k in range(3))


def _below(h, body_size: float):
    return h < -1e-12 * body_size


def _start_height(d: Draft):
    """The height of S at the start: of one scene, or a column of a study's variants
    (the masses and C's position columns; the attitude and the shape are one)."""
    v = d.v
    M = v["[body].mass"]
    if d.with_law and not d.one_point:          # C from the points' first moment
        return start_height(v["[body].shape"], d.size, d.center, 1.0, d.A0, d.extra["com"],
                            bodies.centre_offset(d.points, M, d.t0))
    r = point_position(d.law, d.t0) if d.law is not None else d.point_at
    m = v["[point].mass"] if d.law is None else point_mass(d)
    return start_height(v["[body].shape"], d.size, d.center, m / (M + m), d.A0,
                        d.extra["com"], r)


def _above_plane(d: Draft) -> None:
    if not d.plane or d.v["[body].shape"] == "none":
        return
    h = _start_height(d)
    if _below(h, d.body_size):
        raise SceneError("[initial].com", f"the lowest point S starts below the plane "
                                          f"(height {h:.6g}); raise Z_C")


def _above_plane_bulk(d: Draft):
    if not d.plane or d.v["[body].shape"] == "none":
        return False
    return _below(_start_height(d), d.body_size)


def spin(omega):
    """|omega| (at least 1e-300), of one omega or of columns (x, y, z) of a study's."""
    try:
        return max(math.hypot(*omega), 1e-300)
    except TypeError:                  # columns: hypot one variant at a time, as above
        rows = np.stack(np.broadcast_arrays(*omega), axis=-1).tolist()
        return np.maximum([math.hypot(*w) for w in rows], 1e-300)


def _rk4_step_of(d: Draft):
    step = d.v["[run].step"]
    if step is None:
        # RK4 has no error control: a step that resolves the spin and the point's motion
        step = least((d.duration / 2000.0, 0.04 / spin(d.v["[initial].omega"]),
                      d.summary.time_scale / 10.0))
    d.extra["step"] = step
    return step


def _too_many_rk4_steps(d: Draft, step):
    return d.v["[run].method"] == "rk4" and d.duration / step > 1e8


def _rk4_step(d: Draft) -> None:
    step = _rk4_step_of(d)
    if _too_many_rk4_steps(d, step):
        raise SceneError("[run].step", f"gives {d.duration / step:.3g} RK4 steps (at most 1e8)")


def _rk4_step_bulk(d: Draft):
    return _too_many_rk4_steps(d, _rk4_step_of(d))


def _internal_offset(d: Draft) -> tuple:
    """(OC, OC') at t0 in body axes: where the points put C, and how fast they move it."""
    M = d.v["[body].mass"]
    if not d.with_law:                       # a task: P where the plan starts it
        m = d.v["[point].mass"]
        return tuple(m / (M + m) * c for c in d.point_at), (0.0, 0.0, 0.0)
    total = M + sum(p.mass for p in d.points)
    oc, rate = [0.0] * 3, [0.0] * 3
    for p in d.points:
        u = p.law.point(d.t0)
        for k in range(3):
            oc[k] += p.mass * float(u[k]) / total
            rate[k] += p.mass * float(u[3 + k]) / total
    return tuple(oc), tuple(rate)


def _start(d: Draft) -> None:
    """``[initial].on_plane`` and ``carrier_velocity``: C's height and velocity at the
    start computed, so that a body at rest on the floor needs no hand computation (a new
    user had computed Z_C = 0.134 and V_C = 0.032 for the rolling robot; the naive values
    ran silently with a 1.6 cm drop)."""
    v, given = d.v, d.given
    com, vel = list(v["[initial].com"]), list(v["[initial].com_velocity"])
    on_plane, carrier = v["[initial].on_plane"], v["[initial].carrier_velocity"]
    if carrier is not None and "[initial].com_velocity" in given:
        raise SceneError("[initial].carrier_velocity", "give either com_velocity (C's) or "
                                                       "carrier_velocity (O's), not both")
    if carrier is not None and not d.with_law:
        raise SceneError("[initial].carrier_velocity", "a task gives C's velocity "
                                                       "([initial].com_velocity): O's "
                                                       "depends on the point's law, which "
                                                       "the planner makes")
    if on_plane:
        if not d.plane or v["[body].shape"] == "none":
            raise SceneError("[initial].on_plane", "needs [plane] and a body with a shape")
        if com[2] != 0.0:
            raise SceneError("[initial].com", f"Z_C is computed with on_plane = true: give "
                                              f"0 (got {com[2]!r})")
    if on_plane or carrier is not None:
        oc, rate = _internal_offset(d)
        A = d.A0
        if on_plane:
            n = A[2].tolist()
            s = shapes.of(v["[body].shape"]).lowest(n, d.center, d.size)
            com[2] = -sum(n[k] * (s[k] - oc[k]) for k in range(3))   # S at height 0
        if carrier is not None:
            w = v["[initial].omega"]
            body = [w[1] * oc[2] - w[2] * oc[1] + rate[0], w[2] * oc[0] - w[0] * oc[2] + rate[1],
                    w[0] * oc[1] - w[1] * oc[0] + rate[2]]
            vel = [carrier[i] + sum(A[i][k] * body[k] for k in range(3)) for i in range(3)]
    d.extra["com"] = tuple(float(c) for c in com)
    d.extra["com_velocity"] = tuple(float(c) for c in vel)


def _start_bulk(d: Draft):
    """A study's variants of a scene that computes C's start (on_plane, carrier_velocity)
    go one at a time (all marked); the others keep C's position and velocity as given."""
    v = d.v
    if v["[initial].on_plane"] or v["[initial].carrier_velocity"] is not None:
        return True
    d.extra["com"], d.extra["com_velocity"] = v["[initial].com"], v["[initial].com_velocity"]
    return False


def _restitution(d: Draft) -> None:
    """[plane].restitution is required with [plane], but by a box or a cylinder started on
    the plane (on_plane) of a rough plane: the base model, which meets no impact (without
    e it stops where the body lifts off; with it, the flight after the lift-off reads e:
    derive/runtime/handover.py); derive/runtime/choice.py refuses its absence on any other
    model."""
    v = d.v
    if not d.plane or RESTITUTION in d.given:
        return
    shape = v["[body].shape"]
    why = ("[initial].on_plane is not true" if not v["[initial].on_plane"] else
           f"[body].shape {shape!r} has no flat face" if shape not in BASE_SHAPES else
           f"[plane].friction = {d.friction:g}: a face rests and slides by friction"
           if not d.friction > 0 else None)
    if why is not None:
        raise SceneError(RESTITUTION, f"is required: {why}, so the base model cannot run it "
                                      "(only a box or a cylinder started on its face, "
                                      "on_plane, on a rough plane may leave it out)")


STATE_RULES = (
    Rule("[initial]: quaternion or matrix, not both", _orientation),
    Rule("[initial]: on_plane puts S on the plane (Z_C computed, needs [plane] and a shape); "
         "carrier_velocity gives O's velocity instead of com_velocity (C's)", _start,
         bulk=_start_bulk),
    Rule("[plane].restitution: required, but by a box or a cylinder started on its face "
         "(on_plane) on a rough plane (the base model, which has no impacts; read by the "
         "flight after a lift-off)",
         _restitution, bulk=_as_for_one(_restitution)),
    Rule("[run]: at most 1e8 RK4 steps", _rk4_step, law=True, bulk=_rk4_step_bulk),
    Rule("[initial]: S starts on or above the plane", _above_plane, bulk=_above_plane_bulk),
)


def check(rules: tuple, d: Draft) -> None:
    for rule in rules:
        if rule.law and not d.with_law:
            continue
        rule.check(d)


def check_bulk(rules: tuple, d: Draft):
    """The rules over a draft whose fields of :data:`derive.scene.bulk.BULK` may be
    columns: where each rule fails, or'ed (a bool, or a bool per variant).  A rule
    without a bulk form reads none of those fields (tests/test_bulk.py traces what every
    rule reads): it is checked as for one scene, and raises for all the variants."""
    bad = False
    for rule in rules:
        if rule.law and not d.with_law:
            continue
        if rule.bulk is None:
            rule.check(d)
        else:
            bad = bad | rule.bulk(d)
    return bad


def texts() -> list:
    """The README's list of rules across fields, in the order they are checked."""
    return [r.text for r in STATIC_RULES + STATE_RULES if r.text]
