"""The internal bodies of a scene: its points (``[point]``, or ``[[point]]`` for zero or
more) and its rotors (``[[rotor]]``), each read, validated and its law proved over the
run (:mod:`derive.scene.rules` calls these in its rules); and, for a scene that is not
one point, the law of them all (:class:`~derive.scene.law.bodies.BodiesLaw`).

A rotor is a wheel turning about a fixed axis of the body: its ``axis`` (a unit vector
in body axes), its axial ``inertia`` and its ``law``, the angle psi(t) relative to the
body (its mass and transverse moments belong to ``[body]``, counted as if it were
locked).  Messages name the element: ``[point].law[1]`` for the single table,
``[[point]] 2: law[1]`` and ``[[rotor]] 1: axis`` for the elements of an array.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from . import law as lawmod
from . import table as tablemod
from .errors import LawError, SceneError
from .law import CoordinateError, LawSummary
from .law.bodies import BodiesLaw, combine
from .law.parse import compile_angle
from .schema import AXIS_TOLERANCE, SCENE, Element


@dataclass(frozen=True)
class Point:
    """A point of the scene: its mass and law (a Program or a TableLaw), proved."""
    name: str                  # "[point]" or "[[point]] 2": how messages name it
    mass: float
    law: Any
    law_text: tuple            # the three formulas, () for a table
    summary: LawSummary
    max_distance: float


@dataclass(frozen=True)
class Rotor:
    """A rotor: its unit axis in body axes, axial moment and angle law psi(t), proved."""
    name: str
    axis: tuple
    inertia: float
    law: Any                   # a Program of one output, or a TableLaw (psi in its x)
    law_text: str              # the formula ("" for a table)
    summary: LawSummary        # of psi: max |psi|, |psi'|, |psi''|, its time scale


_POINT_FIELDS = tuple((f.key, f.where) for f in SCENE.by_table["point"].values())


def point_elements(v: dict) -> tuple:
    """The points a scene gave: the elements of ``[[point]]``, the single ``[point]``
    (index 0), or none."""
    if "[[point]]" in v:
        return v["[[point]]"]
    if "point" not in v["__tables__"]:
        return ()
    values = {key: v[where] for key, where in _POINT_FIELDS}
    return (Element("point", 0, values, {k for k, x in values.items() if x is not None}),)


def rotor_elements(v: dict) -> tuple:
    return v.get("[[rotor]]", ())


def describe(n_points: int, n_rotors: int) -> str:
    """'2 points and 1 rotor', 'no point and no rotor'."""
    def some(n, what):
        return f"{n} {what}{'s' if n != 1 else ''}" if n else f"no {what}"
    return f"{some(n_points, 'point')} and {some(n_rotors, 'rotor')}"


# ---- a point's law -----------------------------------------------------------------------
def law_field(el: Element) -> str:
    """The field an element gave its law in (for messages)."""
    for key in ("samples", "table"):
        if el.values.get(key) is not None:
            return el.where(key)
    return el.where("law")


def check_source(el: Element) -> None:
    """Exactly one of law, table, samples; ends only with a table or samples."""
    sources = [k for k in ("law", "table", "samples") if el.values[k] is not None]
    if len(sources) != 1:
        raise SceneError(el.where("law"), "give exactly one of law (three formulas), table "
                         "(a CSV file) or samples (rows [t, x, y, z])" +
                         (f"; got {', '.join(sources)}" if sources else ""))
    if el.values["ends"] != "free" and "ends" in el.given and el.values["law"] is not None:
        raise SceneError(el.where("ends"), "applies to a table or samples, not to a law")


@lru_cache(maxsize=1024)
def _analyse_program(program, t0: float, t1: float) -> LawSummary:
    """The proof and the summary of a formula law over a run (cached by the program
    object, which compile_law caches by the law's text, and the run's span); a failure
    is a CoordinateError naming the output."""
    sing = lawmod.find_singularity(program, t0, t1)
    if sing is not None:
        raise CoordinateError(sing.coordinate, f"is not twice differentiable on the run: "
                                               f"{sing.what} near t = {sing.t:.9g}")
    ts = np.linspace(t0, t1, lawmod.SAMPLES)
    jets = program.jets(ts)
    bad = ~np.isfinite(jets)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        names = ("x", "x'", "x''", "y", "y'", "y''", "z", "z'", "z''") \
            if len(jets) == 9 else ("psi", "psi'", "psi''")
        raise CoordinateError(int(row) // 3, f"{names[row]} is not finite at t = "
                                             f"{ts[col]:.9g} (overflow)")
    return lawmod.summarise(jets)


def _read_table_file(el: Element, base: Path | None,
                     names: tuple = ("t", "x", "y", "z")) -> list:
    rel, where = el.values["table"], el.where("table")
    path = Path(rel)
    if base is None or path.is_absolute() or ".." in path.parts:
        raise SceneError(where, "must be a relative path below the scene file's folder "
                                "(scenes given as text or dicts use samples)")
    full = base / path
    try:
        inside = full.resolve().is_relative_to(Path(base).resolve())
    except (OSError, RuntimeError, ValueError):
        inside = False
    if not inside:
        raise SceneError(where, f"{rel!r} leads outside the scene file's folder (through a "
                                "symbolic link)")
    if not full.is_file():
        raise SceneError(where, f"no such file {rel!r} beside the scene")
    if full.stat().st_size > tablemod.MAX_BYTES:
        raise SceneError(where, f"is larger than {tablemod.MAX_BYTES} bytes")
    try:
        text = full.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(where, f"{rel!r} is not UTF-8 text (byte {exc.start})") from None
    except OSError as exc:
        raise SceneError(where, f"cannot be read ({type(exc).__name__})") from None
    return tablemod.read_rows(text, rel, names)


def point_law(el: Element, t0: float, t1: float, base: Path | None) -> tuple:
    """(law, law_text, summary): the law compiled (a formula) or built (a table), and
    proved over the run [t0, t1]."""
    texts = el.values["law"]
    if texts is not None:
        try:
            program = lawmod.compile_law(texts)
        except CoordinateError as exc:
            raise SceneError(el.where(f"law[{exc.k}]"), str(exc)) from None
        except LawError as exc:
            raise SceneError(el.where("law"), str(exc)) from None
        try:
            return program, texts, _analyse_program(program, t0, t1)
        except CoordinateError as exc:
            raise SceneError(el.where(f"law[{exc.k}]"), str(exc)) from None
    kind = "samples" if el.values["samples"] is not None else "table"
    try:
        if kind == "samples":
            law = tablemod.build(el.values["samples"], el.values["ends"], "samples")
        else:
            rel = el.values["table"]
            law = tablemod.build(_read_table_file(el, base), el.values["ends"], rel)
        law.check_run(t0, t1)
    except LawError as exc:
        raise SceneError(el.where(kind), str(exc)) from None
    return law, (), law.summary(t0, t1)


def far_coordinate(law, t0: float, t1: float) -> int:
    """The coordinate of a formula law that goes farthest from O over the run."""
    with np.errstate(all="ignore"):
        ts = np.linspace(t0, t1, lawmod.SAMPLES)
        r = law.jets(ts)[[0, 3, 6]]
        far = np.nan_to_num(np.abs(r), nan=np.inf).max(axis=1)
    return int(np.argmax(far))


def point(el: Element, law, law_text: tuple, summary: LawSummary, t0: float, t1: float,
          body_size: float) -> Point:
    """The point, its reach checked: P within max_distance of O (10 body sizes unless
    the element's max_distance says otherwise)."""
    max_distance = el.values["max_distance"] or 10.0 * body_size
    if summary.max_radius > max_distance:
        where = el.where(f"law[{far_coordinate(law, t0, t1)}]") if law_text \
            else law_field(el)
        raise SceneError(where, f"takes P {summary.max_radius:.3g} from O, beyond "
                                f"max_distance = {max_distance:.3g} (10 body sizes unless "
                                f"{el.where('max_distance')} says otherwise)")
    return Point(el.name, el.values["mass"], law, law_text, summary, max_distance)


# ---- a rotor -----------------------------------------------------------------------------
def unit_axis(el: Element) -> tuple:
    """The axis normalised, if |a| is within AXIS_TOLERANCE of 1 (the rounding of printed
    digits), else refused."""
    a = el.values["axis"]
    norm = math.sqrt(sum(c * c for c in a))
    if not abs(norm - 1.0) <= AXIS_TOLERANCE:
        raise SceneError(el.where("axis"), f"must be a unit vector (|a| = {norm:.9g}; "
                                           f"within {AXIS_TOLERANCE:g} of 1)")
    return tuple(c / norm for c in a)


def rotor(el: Element, t0: float, t1: float, base: Path | None = None) -> Rotor:
    """The rotor, its axis a unit vector and its angle's law (a formula, or a table of
    t, psi: a spline with psi in its x, y = z = 0) proved over the run."""
    axis = unit_axis(el)
    text, table = el.values["law"], el.values.get("table")
    if text is None and table is None:
        raise SceneError(el.where("law"), "is required (a formula; or give table, a CSV "
                                          "file of t, psi)")
    if text is not None and table is not None:
        raise SceneError(el.where("table"), "give law (a formula) or table, not both")
    if text is not None and "ends" in el.given:
        raise SceneError(el.where("ends"), "applies to a table, not to a law")
    if table is not None:
        try:
            rows = _read_table_file(el, base, ("t", "psi"))
            zero = np.zeros((len(rows), 2))
            law = tablemod.build(np.column_stack([rows, zero]), el.values["ends"], table)
            law.check_run(t0, t1)
        except LawError as exc:
            raise SceneError(el.where("table"), str(exc)) from None
        return Rotor(el.name, axis, el.values["inertia"], law, "", law.summary(t0, t1))
    try:
        program = compile_angle(text)
        summary = _analyse_program(program, t0, t1)
    except LawError as exc:
        raise SceneError(el.where("law"), str(exc)) from None
    return Rotor(el.name, axis, el.values["inertia"], program, text, summary)


# ---- all of them -------------------------------------------------------------------------
def law_of(points: tuple, rotors: tuple) -> BodiesLaw:
    """The law of every body, for the runtime (named when the bodies cannot share it)."""
    try:
        return combine(tuple(p.law for p in points), tuple(r.law for r in rotors))
    except CoordinateError as exc:
        tabled = [b for b in (*points, *rotors) if b.law.kind != "program"]
        el = tabled[exc.k]
        raise SceneError(f"{el.name}: {'samples' if el.law.source == 'samples' else 'table'}",
                         str(exc)) from None
    except LawError as exc:
        raise SceneError("[[point]]" if points else "[[rotor]]",
                         f"the laws of {describe(len(points), len(rotors))} {exc}") from None


def summary_of(points: tuple, rotors: tuple) -> tuple[LawSummary, str]:
    """One summary for the rules that read the motion (the farthest, fastest point; the
    shortest time scale of any body) and the name of the body whose time scale it is."""
    ps = [p.summary for p in points]
    bodies = [(b.summary.time_scale, b.name) for b in (*points, *rotors)]
    scale, name = min(bodies, default=(math.inf, "[[point]]"))
    return LawSummary(max((s.max_radius for s in ps), default=0.0),
                      max((s.max_speed for s in ps), default=0.0),
                      max((s.max_acceleration for s in ps), default=0.0),
                      max((s.amplitude for s in ps), default=0.0), scale), name


def centre_offset(points: tuple, M: float, t: float) -> tuple:
    """OC at t in body axes: sum m_j OP_j / (M + sum m_j) (rotors move no mass)."""
    total = M + sum(p.mass for p in points)
    oc = [0.0, 0.0, 0.0]
    for p in points:
        r = p.law.point(t)[:3]
        for k in range(3):
            oc[k] += p.mass * float(r[k])
    return tuple(c / total for c in oc)


def refuse_analysis(scene, what: str) -> None:
    """The analyses that read one point's law as formulas (``derive stability``: the
    period of the law, its symbolic form in the variational equations) refuse a scene
    that is not one point, naming its bodies; ``derive simulate`` runs any."""
    if scene.one_point:
        return
    where = "[[rotor]]" if scene.rotors else "[[point]]" if scene.points else "[point]"
    raise SceneError(where, f"{describe(len(scene.points), len(scene.rotors))}: {what} "
                            "reads one point's law (its formulas); `derive simulate` runs "
                            "the scene")


def summary_over(scene, t0: float, t1: float) -> LawSummary:
    """The summary of a scene's law over [t0, t1], as a scene of that run proves it: a
    run that goes on from another's state at t0 (the flight after a lift-off) reads its
    law there, as a scene written from that state by hand does, not over the whole run
    (the summary's time scale bounds the step)."""
    def one(law, text):
        return _analyse_program(law, t0, t1) if text else law.summary(t0, t1)
    if scene.internal is None:
        return one(scene.law, scene.law_text) if scene.law is not None else scene.law_summary
    points, rotors = scene.internal
    return summary_of(tuple(replace(p, summary=one(p.law, p.law_text)) for p in points),
                      tuple(replace(r, summary=one(r.law, r.law_text)) for r in rotors))[0]
