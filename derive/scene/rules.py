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
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache, reduce
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .. import layout, shapes

from . import law as lawmod
from . import table as tablemod
from .errors import SceneError
from .scene import body_size
from .law import CoordinateError, LawError, LawSummary
from .schema import FIELDS, MAX_ROWS, MIN_DURATION, REQUIRED, as_rotation

REQUIRED_FIELDS = tuple(f for f in FIELDS if f.default is REQUIRED)
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
    t0: float = 0.0
    duration: float = 0.0
    law: Any = None
    law_text: tuple = ()
    summary: LawSummary | None = None
    max_distance: float = 0.0
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
        """The field the scene gave its law in (for messages)."""
        if self.v.get("[point].samples") is not None:
            return "[point].samples"
        if self.v.get("[point].table") is not None:
            return "[point].table"
        return "[point].law"

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
        if f.where not in v or v[f.where] is not REQUIRED:
            continue
        if f.table in OPTIONAL_TABLES and f.table not in v["__tables__"]:
            continue                  # a table given whole or not at all
        if f.table in ("body", "point") and not any(g.startswith(f"[{f.table}]")
                                                     for g in given):
            raise SceneError(f"[{f.table}]", "is required")
        raise SceneError(f.where, "is required" + (f" ({f.rule})" if f.choices else ""))
    d.plane = "plane" in v["__tables__"]
    d.e = v["[plane].restitution"] if d.plane else 1.0
    d.friction = v.get("[plane].friction", 0.0) if d.plane else 0.0
    d.restitution_model = v.get("[plane].restitution_model", "energetic") if d.plane \
        else "energetic"
    for key in ("spin_friction", "rolling_resistance"):
        value = v.get(f"[plane].{key}", 0.0) if d.plane else 0.0
        if value > 0.0 and not d.friction > 0.0:
            raise SceneError(f"[plane].{key}", "needs [plane].friction > 0 (the couple acts "
                                               "in the rough model's contact)")
        setattr(d, key, value)
    d.t0 = v["[initial].time"]


def _required_bulk(d: Draft) -> bool:
    """The same: of the fields a study varies in bulk it reads only e, to copy it."""
    _required(d)
    return False


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
    v = d.v
    sources = [k for k in ("law", "table", "samples") if v[f"[point].{k}"] is not None]
    if len(sources) != 1:
        raise SceneError("[point].law", "give exactly one of law (three formulas), table (a "
                         "CSV file) or samples (rows [t, x, y, z])" +
                         (f"; got {', '.join(sources)}" if sources else ""))
    if v["[point].ends"] != "free" and "[point].ends" in d.given \
            and v["[point].law"] is not None:
        raise SceneError("[point].ends", "applies to a table or samples, not to a law")


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


@lru_cache(maxsize=1024)
def _analyse_program(program, t0: float, t1: float) -> LawSummary:
    """The proof and the summary of a formula law over a run (cached by the program
    object, which compile_law caches by the law's text, and the run's span)."""
    sing = lawmod.find_singularity(program, t0, t1)
    if sing is not None:
        raise SceneError(f"[point].law[{sing.coordinate}]",
                         f"is not twice differentiable on the run: {sing.what} near "
                         f"t = {sing.t:.9g}")
    ts = np.linspace(t0, t1, lawmod.SAMPLES)
    jets = program.jets(ts)
    bad = ~np.isfinite(jets)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        names = ("x", "x'", "x''", "y", "y'", "y''", "z", "z'", "z''")
        raise SceneError(f"[point].law[{row // 3}]",
                         f"{names[row]} is not finite at t = {ts[col]:.9g} (overflow)")
    return lawmod.summarise(jets)


def _compile_law(texts: tuple):
    try:
        return lawmod.compile_law(texts)
    except CoordinateError as exc:
        raise SceneError(f"[point].law[{exc.k}]", str(exc)) from None
    except LawError as exc:
        raise SceneError("[point].law", str(exc)) from None


def _read_table_file(rel: str, base: Path | None) -> list:
    path = Path(rel)
    if base is None or path.is_absolute() or ".." in path.parts:
        raise SceneError("[point].table", "must be a relative path below the scene "
                                          "file's folder (scenes given as text or dicts "
                                          "use samples)")
    full = base / path
    try:
        inside = full.resolve().is_relative_to(Path(base).resolve())
    except (OSError, RuntimeError, ValueError):
        inside = False
    if not inside:
        raise SceneError("[point].table", f"{rel!r} leads outside the scene file's "
                                          "folder (through a symbolic link)")
    if not full.is_file():
        raise SceneError("[point].table", f"no such file {rel!r} beside the scene")
    if full.stat().st_size > tablemod.MAX_BYTES:
        raise SceneError("[point].table", f"is larger than {tablemod.MAX_BYTES} bytes")
    try:
        text = full.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError("[point].table", f"cannot be read ({type(exc).__name__})") from None
    return tablemod.read_rows(text, rel)


def _law(d: Draft) -> None:
    """The law compiled (a formula) or built (a table), and proved over the run."""
    v = d.v
    t0, t1 = d.t0, d.t0 + d.duration
    if v["[point].law"] is not None:
        d.law_text = v["[point].law"]
        d.law = _compile_law(d.law_text)
        d.summary = _analyse_program(d.law, t0, t1)
        return
    kind = "samples" if v["[point].samples"] is not None else "table"
    try:
        if kind == "samples":
            d.law = tablemod.build(v["[point].samples"], v["[point].ends"], "samples")
        else:
            rel = v["[point].table"]
            d.law = tablemod.build(_read_table_file(rel, d.base), v["[point].ends"], rel)
        d.law.check_run(t0, t1)
    except LawError as exc:
        raise SceneError(f"[point].{kind}", str(exc)) from None
    d.summary = d.law.summary(t0, t1)


def _within_max_distance(d: Draft) -> None:
    v, summary = d.v, d.summary
    d.max_distance = v["[point].max_distance"] or 10.0 * d.body_size
    if summary.max_radius > d.max_distance:
        if d.law_text:
            with np.errstate(all="ignore"):
                ts = np.linspace(d.t0, d.t0 + d.duration, lawmod.SAMPLES)
                r = d.law.jets(ts)[list(layout.JET_R)]
                far = np.nan_to_num(np.abs(r), nan=np.inf).max(axis=1)
            where = f"[point].law[{int(np.argmax(far))}]"
        else:
            where = d.law_field
        raise SceneError(where, f"takes P {summary.max_radius:.3g} from O, beyond "
                                f"max_distance = {d.max_distance:.3g} (10 body sizes unless "
                                "[point].max_distance says otherwise)")


def _singular_along_the_law(d: Draft):
    """R1: J = diag(J) + mu (|r|^2 1 - r r^T) non-singular along the law; its eigenvalues
    are at least min(J) (the added term is positive semi-definite), so only the ratio to
    the largest can degrade: bounded through max |OP|.  (``<=``, not ``not >``: every
    number here is finite and positive, and it reads columns too.)"""
    v = d.v
    J, M, m = v["[body].inertia"], v["[body].mass"], v["[point].mass"]
    largest = most(J) + M * m / (M + m) * d.summary.max_radius ** 2
    return least(J) <= 1e-12 * largest


def _reach(d: Draft) -> None:
    _within_max_distance(d)
    if _singular_along_the_law(d):
        raise SceneError("[body].inertia", "J of E1.5 is near-singular along the law "
                                           "(smallest/largest below 1e-12); R1 needs det J != 0")


def _reach_bulk(d: Draft):
    """(A study varies M and J in bulk only where the body has a shape: then the body's
    size, and max_distance, do not read them.)"""
    _within_max_distance(d)
    return _singular_along_the_law(d)


def _time_scale(d: Draft) -> None:
    v = d.v
    if d.plane and v["[body].shape"] != "none" and v["[run].method"] != "rk4" \
            and d.duration / d.summary.time_scale > v["[run].max_steps"]:
        # with the plane a step is at most the law's time scale (driver.options): the run
        # could only end at max_steps, after minutes of work
        raise SceneError(d.law_field,
                         f"moves P on a time scale of {d.summary.time_scale:.3g} s "
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
    Rule("[point]: exactly one of law, table, samples; ends only with a table or samples",
         _law_source, law=True),
    Rule("[run]: a duration that a step resolves and that is not lost in the start time; "
         "at most 1e7 output rows (duration/output_dt)", _run_span, law=True),
    Rule("[point].law[k]: x, y, z and their first two derivatives finite and continuous "
         "over the whole run (proved by interval arithmetic: no vanishing denominator, log, "
         "sqrt or non-integer power of a non-positive number, asin/acos outside (-1, 1) or "
         "tan pole); [point].table: a periodic table repeats; otherwise the run stays "
         "inside its times", _law, law=True),
    Rule("[point]: P stays within max_distance of O; J of E1.5 stays non-singular (R1)",
         _reach, law=True, bulk=_reach_bulk),
    Rule("[point] with the plane: duration / the law's time scale (sqrt(amplitude / max "
         "|OP''|), the longest step then) at most [run].max_steps", _time_scale, law=True),
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
    r = point_position(d.law, d.t0) if d.law is not None else d.point_at
    M, m = v["[body].mass"], v["[point].mass"]
    return start_height(v["[body].shape"], d.size, d.center, m / (M + m), d.A0,
                        v["[initial].com"], r)


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


STATE_RULES = (
    Rule("[initial]: quaternion or matrix, not both", _orientation),
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
