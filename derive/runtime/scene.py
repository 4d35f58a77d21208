"""Scenes: the TOML files through which people use the runtime.  The schema is written
once, here (:data:`FIELDS` and :data:`RULES`); validation, defaults, the README's table
(``schema_table``), the template of ``derive scene new`` (``template``) and the built-in
scene all come from it.

A scene is untrusted input.  Nothing in it is executed or pasted into source: laws go
through :mod:`derive.runtime.law` (a whitelist parser into a program the C runtime
interprets), tables through :mod:`derive.runtime.table`, numbers are checked finite and
in range, and every failure raises :class:`SceneError` naming the field and the rule.
"""
from __future__ import annotations

import dataclasses
import marshal
import math
import numbers
import os
import re
import threading
import tomllib
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from . import law as lawmod
from .law import CoordinateError, LawError, LawSummary

class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED = _Required()     # a field's default when the scene must give it


_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")


def _printable(text: str) -> str:
    """Control, line-break and bidi characters of a scene escaped (\\x1b, \\n, ...): a
    message is one line and cannot drive the terminal."""
    return _UNPRINTABLE.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"),
                            str(text))


class SceneError(ValueError):
    """A scene that breaks a rule: ``where`` names the field, ``rule`` says what."""

    def __init__(self, where: str, rule: str):
        where, rule = _printable(where), _printable(rule)
        if len(where) > 120:                  # a stranger's 5000-character key or index
            where = where[:117] + "..."
        super().__init__(f"{where}: {rule}")
        self.where, self.rule = where, rule


# ---- the schema ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Field:
    table: str                 # "" for the top level
    key: str
    kind: str                  # number integer vector string choice choices bool laws
                               # matrix numbers samples
    default: Any               # REQUIRED, None (may be absent) or the default value
    doc: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False      # lo excluded
    size: int = 0              # vectors: the number of entries
    choices: tuple = ()
    example: Any = None        # what `derive scene new` writes (None: the default)
    when: str = ""             # the condition under which the field applies

    @cached_property
    def where(self) -> str:
        return f"[{self.table}].{self.key}" if self.table else self.key

    @property
    def rule(self) -> str:
        if self.choices:
            return "one of " + ", ".join(self.choices)
        if self.lo is None and self.hi is None:
            return ""
        lo = "(" if self.lo_open else "["
        if self.hi is None:
            return f"{'>' if self.lo_open else '>='} {self.lo:g}"
        return f"in {lo}{self.lo:g}, {self.hi:g}]"


F = Field
MAX_MASS = 1e9
MAX_LENGTH = 1e6
MAX_DURATION = 1e7
MAX_ROWS = 10_000_000
MIN_DURATION = 1e-12       # s: the runtime's steps (duration / 2000, / 4) stay normal floats
FIELDS = (
    F("", "name", "string", "scene", "a label for the outputs: at most 80 ASCII letters, "
      "digits, spaces and - _ . , : ; = + ( ) [ ] / # @ & '", example="my-scene"),
    F("body", "mass", "number", REQUIRED, "M, mass of the carrier", 0, MAX_MASS, True,
      example=1.0),
    F("body", "inertia", "vector", REQUIRED, "J_x, J_y, J_z, principal central moments of "
      "the carrier; each at most the sum of the other two", 0, MAX_MASS, True, size=3,
      example=[0.10, 0.12, 0.14]),
    F("body", "shape", "choice", REQUIRED, "the surface that meets the plane (none: no "
      "contact possible)", choices=("sphere", "ellipsoid", "none"), example="sphere"),
    F("body", "radius", "number", None, "sphere radius", 0, MAX_LENGTH, True,
      example=0.5, when='shape = "sphere"'),
    F("body", "semi_axes", "vector", None, "ellipsoid semi-axes along the body axes", 0,
      MAX_LENGTH, True, size=3, example=[0.5, 0.4, 0.3], when='shape = "ellipsoid"'),
    F("body", "center", "vector", [0.0, 0.0, 0.0], "centre of the shape in body axes",
      -MAX_LENGTH, MAX_LENGTH, size=3),
    F("point", "mass", "number", REQUIRED, "m, mass of the point", 0, MAX_MASS, True,
      example=0.2),
    F("point", "law", "laws", None, "x(t), y(t), z(t) in body axes: formulas in t, pi, "
      "numbers, + - * / ** ^ and sin cos tan exp log sqrt sinh cosh tanh asin acos atan",
      example=["0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"], when="one of law, table, samples"),
    F("point", "table", "string", None, "a CSV file (path relative to the scene) with "
      "columns t, x, y, z: the law as samples, interpolated by a cubic spline",
      when="one of law, table, samples"),
    F("point", "samples", "samples", None, "the law as rows [t, x, y, z] in the scene itself",
      when="one of law, table, samples"),
    F("point", "ends", "choice", "free", "a table's ends: periodic (the law repeats), rest "
      "(P at rest at both ends), free (not-a-knot; the run stays inside the table)",
      choices=("periodic", "rest", "free"), when="table or samples"),
    F("point", "max_distance", "number", None, "how far P may go from O (default: 10 body "
      "sizes)", 0, MAX_LENGTH, True),
    F("plane", "restitution", "number", REQUIRED, "e of Newton's law v_n+ = -e v_n- (E1.13)",
      0, 1, example=0.9, when="[plane] given (absent: free flight)"),
    F("initial", "time", "number", 0.0, "t0", -1e9, 1e9),
    F("initial", "com", "vector", [0.0, 0.0, 0.0], "X_C, Y_C, Z_C", -1e9, 1e9, size=3,
      example=[0.0, 0.0, 1.5]),
    F("initial", "com_velocity", "vector", [0.0, 0.0, 0.0], "X_C', Y_C', Z_C'", -1e6, 1e6,
      size=3, example=[0.3, 0.0, 0.0]),
    F("initial", "omega", "vector", [0.0, 0.0, 0.0], "angular velocity in body axes", -1e6,
      1e6, size=3, example=[0.5, -0.3, 1.0]),
    F("initial", "quaternion", "vector", [1.0, 0.0, 0.0, 0.0], "attitude as a unit "
      "quaternion (w, x, y, z), normalised; or give matrix", -1e9, 1e9, size=4),
    F("initial", "matrix", "matrix", None, "attitude as the matrix a_ij = cos(fixed axis i, "
      "body axis j), a rotation", -1.0 - 1e-6, 1.0 + 1e-6),
    F("run", "duration", "number", 5.0, "length of the run", 0, MAX_DURATION, True),
    F("run", "method", "choice", "lie", "integrator: lie (the momentum form: K and C's "
      "parabola constants of each flight, the attitude on SO(3); see the README), lie5, "
      "lie8, dopri5, dop853, rk4", choices=("lie", "lie5", "lie8", "dopri5", "dop853", "rk4")),
    F("run", "rtol", "number", 1e-10, "relative tolerance", 1e-15, 1e-2),
    F("run", "atol", "number", 1e-12, "absolute tolerance", 0, 1, True),
    F("run", "g", "number", 9.81, "gravity", 0, 1e4),
    F("run", "outputs", "choices", ["pose", "impacts"], "what the result holds",
      choices=("pose", "omega", "height", "impacts", "momentum")),
    F("run", "step", "number", None, "RK4 step (default: the least of duration/2000, "
      "0.04/|omega(0)| and a tenth of the law's time scale)", 0, MAX_DURATION, True),
    F("run", "max_events", "integer", 100_000, "stop after this many events", 1, 1e9),
    F("run", "max_steps", "integer", 10_000_000, "stop after this many steps", 1, 1e10),
    F("run", "output_dt", "number", 0.0, "rows every output_dt (0: one per step)", 0,
      MAX_DURATION),
    F("run", "keep_orthonormal", "bool", False, "project the attitude onto the rotations "
      "after every step"),
    F("run", "model", "choice", "auto", "the model (auto: the smallest that answers the "
      "scene)", choices=("auto", "general", "vertical", "attitude", "translational",
                         "planar", "axisymmetric")),
    F("run", "zeno_dt", "number", 1e-9, "accumulating impacts: enter contact when the "
      "remaining flights sum to less than zeno_dt x duration", 0, 1, True),
    F("stability", "period", "number", None, "free flight: the period (default: the law's)",
      0, MAX_DURATION, True),
    F("stability", "impacts_every", "integer", 1, "on the plane: one impact per n periods",
      1, 64),
    F("stability", "long_periods", "integer", 0, "perturbed runs this many periods long "
      "where the linear test is critical", 0, 1_000_000),
    F("stability", "perturbations", "numbers", [1e-6, 1e-4, 1e-2], "their sizes", 0, 0.1,
      True),
)
TABLES = ("", "body", "point", "plane", "initial", "run", "stability")
_BY_TABLE = {t: {f.key: f for f in FIELDS if f.table == t} for t in TABLES}
# the number fields with both bounds, by table: (lo, hi, lo_open) for _read's fast path
_SCALARS = {t: {f.key: (f.lo, f.hi, f.lo_open) for f in FIELDS
                if f.table == t and f.kind == "number" and f.hi is not None}
            for t in TABLES}
_REQUIRED = tuple(f for f in FIELDS if f.default is REQUIRED)
_TOP_KEYS = frozenset(TABLES[1:]) | frozenset(_BY_TABLE[""])

# cross-field rules, in the order they are checked (their text goes into the README)
RULES = (
    "[body].inertia: each moment at most the sum of the other two (a real mass "
    "distribution), the smallest at least 1e-9 of the largest",
    "[body]: radius for a sphere, semi_axes for an ellipsoid, neither for none; the centre "
    "within 100 sizes of O",
    "[point]: exactly one of law, table, samples; ends only with a table or samples",
    "[point].law[k]: x, y, z and their first two derivatives finite and continuous over "
    "the whole run (proved by interval arithmetic: no vanishing denominator, log, sqrt or "
    "non-integer power of a non-positive number, asin/acos outside (-1, 1) or tan pole)",
    "[point]: P stays within max_distance of O; J of E1.5 stays non-singular (R1)",
    "[point].table: a periodic table repeats; otherwise the run stays inside its times",
    "[initial]: quaternion or matrix, not both; S starts on or above the plane",
    "[run]: at most 1e7 output rows (duration/output_dt) and 1e8 RK4 steps",
    "[point] with the plane: duration / the law's time scale (sqrt(amplitude / max |OP''|),"
    " the longest step then) at most [run].max_steps",
)


# ---- the scene ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Stability:
    """``[stability]``: what ``derive stability`` analyses (see the README)."""
    period: float | None = None
    impacts_every: int = 1
    long_periods: int = 0
    perturbations: tuple = (1e-6, 1e-4, 1e-2)


@dataclass(frozen=True)
class Scene:
    name: str
    M: float
    J: tuple                   # J_x, J_y, J_z
    shape: str                 # sphere | ellipsoid | none
    size: tuple                # (radius,) or semi-axes
    center: tuple
    m: float
    law: Any                   # law.Program or table.TableLaw
    law_text: tuple            # the three strings, or () for a table
    plane: bool
    e: float
    t0: float
    com: tuple
    com_velocity: tuple
    omega: tuple
    A0: np.ndarray = field(compare=False)   # a_ij = cos(fixed i, body j)
    duration: float = 5.0
    method: str = "lie"
    rtol: float = 1e-10
    atol: float = 1e-12
    g: float = 9.81
    outputs: tuple = ("pose", "impacts")
    step: float = 0.0          # RK4 step
    max_events: int = 100000
    max_steps: int = 10_000_000
    output_dt: float = 0.0
    keep_orthonormal: bool = False
    model: str = "auto"
    zeno_dt: float = 1e-9
    source: str = ""
    stability: Stability = Stability()
    law_summary: LawSummary | None = field(default=None, compare=False)
    max_distance: float = 0.0
    doc_source: Any = field(default=None, compare=False, repr=False)   # see Scene.doc

    @classmethod
    def of_fields(cls, base: dict | None = None, **values) -> "Scene":
        """The constructor of :func:`build_scene`: every field given (in ``base`` and
        ``values``), set at once (the frozen dataclass's ``__init__`` sets them one by
        one through ``object.__setattr__``, a tenth of a validation's time)."""
        obj = object.__new__(cls)
        d = obj.__dict__
        if base:
            d.update(base)
        d.update(values)
        if len(d) != len(_SCENE_FIELDS) or not d.keys() <= _SCENE_FIELDS:
            raise TypeError(f"Scene.of_fields needs every field: {sorted(_SCENE_FIELDS)}")
        return obj

    @property
    def doc(self) -> dict:
        """The scene as a dict of the schema, as it was when parsed (a fresh copy on
        every read, so that a caller who edits the dict it gave changes no Scene; {} for a
        Scene made otherwise).  A Scene changed with ``dataclasses.replace`` keeps the
        dict it was parsed from."""
        return self.doc_source.get() if self.doc_source is not None else {}

    @property
    def contact_possible(self) -> bool:
        return self.plane and self.shape != "none"

    @property
    def mu(self) -> float:
        return self.M * self.m / (self.M + self.m)

    @property
    def nu(self) -> float:
        return self.m / (self.M + self.m)

    @property
    def p(self) -> tuple:
        return (self.M, self.m, *self.J, self.g)

    @property
    def body_size(self) -> float:
        """The shape's largest semi-axis, or sqrt(J_max/M) for a body with no shape."""
        if self.size:
            return float(max(self.size))
        return math.sqrt(max(self.J) / self.M)

    def jets(self, ts) -> np.ndarray:
        """The point law at ``ts``: (9, N) x, x', x'', y, y', y'', z, z', z''."""
        return self.law.jets(ts)


_SCENE_FIELDS = frozenset(f.name for f in dataclasses.fields(Scene))


# ---- values -------------------------------------------------------------------------------
def _type_name(value) -> str:
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "a list", dict: "a table"}.get(type(value), type(value).__name__)


def _num(f: Field, value, where: str | None = None) -> float:
    where = where or f.where
    if type(value) is float and f.lo is not None and (f.hi is None or value <= f.hi) and \
            (value > f.lo if f.lo_open else value >= f.lo):
        return value                        # the common case, checked in one line
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SceneError(where, f"must be a number, not {_type_name(value)}")
    if isinstance(value, numbers.Integral):              # int, NumPy integers
        value = int(value)
    if isinstance(value, int) and abs(value) > 2 ** 53:
        shown = f"{value:.3e}" if abs(value).bit_length() <= 1000 else \
            f"about 2^{abs(value).bit_length() - 1}"
        raise SceneError(where, f"is too large ({shown} exceeds 2^53)")
    x = float(value)
    if not math.isfinite(x):
        raise SceneError(where, "must be finite (no NaN or infinity)")
    if f.lo is not None:
        low_bad = x <= f.lo if f.lo_open else x < f.lo
        high_bad = f.hi is not None and x > f.hi
        if (low_bad or high_bad) and f.hi is not None and f.hi <= 1.0:
            raise SceneError(where, f"must be {f.rule} (got {x!r})")     # a fraction
        if low_bad:
            raise SceneError(where, f"must be {'>' if f.lo_open else '>='} {f.lo:g} "
                                    f"(got {x!r})")
        if high_bad:
            raise SceneError(where, f"must be at most {f.hi:g} (got {x!r}): beyond any "
                                    "physical scene this runtime is meant for")
    return x


def _vector(f: Field, value, size: int) -> tuple:
    if type(value) is list and len(value) == size and f.hi is not None:
        # the common case at once: floats in range (a NaN fails x <= hi)
        lo, hi, lo_open = f.lo, f.hi, f.lo_open
        for x in value:
            if type(x) is not float or not (x <= hi and (x > lo if lo_open else x >= lo)):
                break
        else:
            return tuple(value)
    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != size:
        raise SceneError(f.where, f"must be a list of {size} numbers")
    return tuple(_num(f, v, f"{f.where}[{k}]") for k, v in enumerate(value))


_NAME = re.compile(r"[A-Za-z0-9 _.,:;=+()\[\]/#@&'\-]{1,80}", re.ASCII)


def _value(f: Field, value):
    k = f.kind
    if k == "number":
        return _num(f, value)
    if k == "integer":
        x = _num(f, value)
        if x != int(x):
            raise SceneError(f.where, f"must be an integer (got {x!r})")
        return int(x)
    if k == "vector":
        return _vector(f, value, f.size)
    if k == "bool":
        if not isinstance(value, bool):
            raise SceneError(f.where, "must be true or false")
        return value
    if k == "string":
        if not isinstance(value, str):
            raise SceneError(f.where, f"must be a string, not {_type_name(value)}")
        if f.key == "name" and not _NAME.fullmatch(value):
            raise SceneError(f.where, "must be 1 to 80 ASCII letters, digits, spaces or "
                                      "- _ . , : ; = + ( ) [ ] / # @ & '")
        if len(value) > 4096:
            raise SceneError(f.where, "is longer than 4096 characters")
        return value
    if k == "choice":
        if not isinstance(value, str):
            raise SceneError(f.where, f"must be a string, not {_type_name(value)}")
        if value not in f.choices:
            shown = value if len(value) <= 30 else value[:27] + "..."
            raise SceneError(f.where, f"must be {f.rule}; got {shown!r}")
        return value
    if k == "choices":
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise SceneError(f.where, f"must be a list of strings, each {f.rule}")
        for v in value:
            if v not in f.choices:
                shown = v if len(v) <= 30 else v[:27] + "..."
                raise SceneError(f.where, f"{shown!r} is not {f.rule}")
        return tuple(dict.fromkeys(value))
    if k == "numbers":
        if not isinstance(value, list) or not value or len(value) > 64:
            raise SceneError(f.where, "must be a list of 1 to 64 numbers")
        return tuple(_num(f, v, f"{f.where}[{i}]") for i, v in enumerate(value))
    if k == "matrix":
        if not isinstance(value, list) or len(value) != 3:
            raise SceneError(f.where, "must be a list of 3 rows of 3 numbers")
        rows = []
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != 3:
                raise SceneError(f"{f.where}[{i}]", "must be a row of 3 numbers")
            rows.append([_num(f, v, f"{f.where}[{i}][{j}]") for j, v in enumerate(row)])
        return np.array(rows)
    if k == "laws":
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            raise SceneError(f.where, "must be a list of three strings: x(t), y(t), z(t)")
        for i, text in enumerate(value):
            if not isinstance(text, str):
                raise SceneError(f"{f.where}[{i}]", f"must be a string, not {_type_name(text)}")
        return tuple(value)
    if k == "samples":
        if not isinstance(value, list) or not 4 <= len(value) <= 100_000:
            raise SceneError(f.where, "must be a list of 4 to 100000 rows [t, x, y, z]")
        rows = []
        cell = Field("point", "samples", "number", None, "")
        isfinite = math.isfinite
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != 4:
                raise SceneError(f"{f.where}[{i}]", "must be a row of 4 numbers [t, x, y, z]")
            if all(type(v) is float and isfinite(v) for v in row):
                rows.append(row)            # the common case, checked without messages
                continue
            rows.append([_num(cell, v, f"{f.where}[{i}][{j}]") for j, v in enumerate(row)])
        return rows
    raise AssertionError(k)


def _table(doc: dict, name: str) -> dict | None:
    if name not in doc:
        return None
    value = doc[name]
    if not isinstance(value, dict):
        raise SceneError(f"[{name}]", "must be a table")
    return value


@lru_cache(maxsize=1)
def _defaults() -> dict:
    """Every field's default, validated once."""
    return {f.where: (f.default if f.default is None or f.default is REQUIRED
                      else _value(f, f.default)) for f in FIELDS}


def _read(doc: dict) -> tuple[dict, set]:
    """Every field of the schema (its value, its default, or REQUIRED when absent) and
    the set of fields the scene gives."""
    if not doc.keys() <= _TOP_KEYS:
        unknown = sorted(str(k) for k in doc if k not in _TOP_KEYS)
        known = ", ".join(sorted(list(TABLES[1:]) + list(_BY_TABLE[""])))
        raise SceneError(unknown[0][:40], f"is not a known key (known: {known})")
    out = dict(_defaults())
    given = set()
    for table in TABLES:
        _read_table(doc, table, out, given)
    out["__plane__"] = "plane" in doc
    return out, given


def _read_table(doc: dict, table: str, out: dict, given: set) -> None:
    """The fields of one table of ``doc`` (``""``: the top level) into ``out`` and
    ``given``."""
    tab = doc if table == "" else _table(doc, table)
    if not tab:
        return
    fields = _BY_TABLE[table]
    scalars = _SCALARS[table]
    for key, value in tab.items():
        f = fields.get(key)
        if f is None:
            if table == "":
                continue                   # the tables themselves
            raise SceneError(f"[{table}].{str(key)[:40]}",
                             f"is not a known key (known: {', '.join(fields)})")
        where = f.where
        bounds = scalars.get(key)
        if bounds is not None and type(value) is float and value <= bounds[1] and \
                (value > bounds[0] if bounds[2] else value >= bounds[0]):
            out[where] = value              # a number in range (NaN fails <=)
        elif f.kind == "vector":
            out[where] = _vector(f, value, f.size)
        else:
            out[where] = _value(f, value)
        given.add(where)


def _require(v: dict, where: str, what: str = "is required"):
    if v[where] is None or v[where] is REQUIRED:
        raise SceneError(where, what)
    return v[where]


# ---- orientation ----------------------------------------------------------------------------
def rotation_from_quaternion(qv) -> np.ndarray:
    w, x, y, z = qv
    r = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w * r, x * r, y * r, z * r
    return np.array((
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))).reshape(3, 3)


def _orientation(v: dict, given: set) -> np.ndarray:
    if "[initial].quaternion" in given and "[initial].matrix" in given:
        raise SceneError("[initial].quaternion", "give either quaternion or matrix, not both")
    if v["[initial].matrix"] is not None:
        A = v["[initial].matrix"]
        err = float(np.max(np.abs(A @ A.T - np.eye(3))))
        if err > 1e-6:
            raise SceneError("[initial].matrix", f"must be orthonormal (A A^T - 1 is {err:.1e})")
        if np.linalg.det(A) < 0:
            raise SceneError("[initial].matrix", "must be a rotation (det = +1), not a reflection")
        u, _, vt = np.linalg.svd(A)
        return u @ vt
    qv = v["[initial].quaternion"]
    w, x, y, z = qv
    if math.sqrt(w * w + x * x + y * y + z * z) < 1e-12:
        raise SceneError("[initial].quaternion", "must not have zero norm")
    return rotation_from_quaternion(qv)


# ---- the law over the run ---------------------------------------------------------------------
@lru_cache(maxsize=1024)
def _analyse_program(program, t0: float, t1: float) -> LawSummary:
    """(cached by the program object, which compile_law caches by the law's text)"""
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


def _point_law(v: dict, base: Path | None):
    sources = [k for k in ("law", "table", "samples") if v[f"[point].{k}"] is not None]
    if len(sources) != 1:
        raise SceneError("[point].law", "give exactly one of law (three formulas), table (a "
                         "CSV file) or samples (rows [t, x, y, z])" +
                         (f"; got {', '.join(sources)}" if sources else ""))
    kind = sources[0]
    if kind == "law":
        texts = v["[point].law"]
        return _compile_law(texts), texts
    from . import table as tablemod
    ends = v["[point].ends"]
    try:
        if kind == "samples":
            return tablemod.build(v["[point].samples"], ends, "samples"), ()
        rel = v["[point].table"]
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
        rows = tablemod.read_rows(text, rel)
        return tablemod.build(rows, ends, rel), ()
    except LawError as exc:
        raise SceneError(f"[point].{kind}", str(exc)) from None


def _check_law(scene_law, t0: float, t1: float, where: str = "[point].table") -> LawSummary:
    """The law's summary over the run; a table's errors name ``where`` (table or
    samples, the field the scene gave)."""
    if getattr(scene_law, "kind", None) == "table":
        try:
            scene_law.check_run(t0, t1)
        except LawError as exc:
            raise SceneError(where, str(exc)) from None
        return scene_law.summary(t0, t1)
    return _analyse_program(scene_law, t0, t1)


def _inertia_ok(J: tuple) -> None:
    for k, c in enumerate("xyz"):
        others = J[(k + 1) % 3] + J[(k + 2) % 3]
        if J[k] > others * (1 + 1e-12):
            raise SceneError(f"[body].inertia[{k}]",
                             f"J_{c} = {J[k]:g} exceeds the sum of the other two "
                             f"({others:g}): no mass distribution has these principal moments")
    if min(J) < 1e-9 * max(J):
        raise SceneError("[body].inertia", "J is near-singular: the smallest moment is below "
                                           "1e-9 of the largest (R1 needs det J != 0)")


def _singular_J(J: tuple, mu: float, summary: LawSummary) -> None:
    """R1: J = diag(J) + mu (|r|^2 1 - r r^T) non-singular along the law; its eigenvalues
    are at least min(J) (the added term is positive semi-definite), so only the ratio
    to the largest can degrade: bounded through max |OP|."""
    largest = max(J) + mu * summary.max_radius ** 2
    if not min(J) > 1e-12 * largest:
        raise SceneError("[body].inertia", "J of E1.5 is near-singular along the law "
                                           "(smallest/largest below 1e-12); R1 needs det J != 0")


@lru_cache(maxsize=256)
def _law_position(law, t: float) -> tuple:
    """OP at one time (a pure function of the program, itself cached by its text)."""
    return tuple(float(c) for c in law.point(t)[:3])


def _start_above_plane(scene: Scene) -> None:
    if not scene.contact_possible:
        return
    n0, n1, n2 = scene.A0[2].tolist()
    a, b, c = (scene.size[0],) * 3 if scene.shape == "sphere" else scene.size
    d0, d1, d2 = a * a * n0, b * b * n1, c * c * n2          # D^2 n
    root = math.sqrt(n0 * d0 + n1 * d1 + n2 * d2)
    c0, c1, c2 = scene.center
    law = scene.law
    r0, r1, r2 = _law_position(law, scene.t0) if law.kind == "program" else \
        law.point(scene.t0)[:3].tolist()      # (tables are not cached: they are large)
    nu = scene.nu
    # the height of the support point S = center - D^2 n / |D n| above the plane
    h = scene.com[2] + n0 * (c0 - d0 / root - nu * r0) + n1 * (c1 - d1 / root - nu * r1) \
        + n2 * (c2 - d2 / root - nu * r2)
    if h < -1e-12 * scene.body_size:
        raise SceneError("[initial].com", f"the lowest point S starts below the plane "
                                          f"(height {h:.6g}); raise Z_C")


# ---- parsing ---------------------------------------------------------------------------------
def parse_scene(source: str | dict, origin: str = "scene", base: Path | None = None) -> Scene:
    """Validate a scene given as TOML text or as an already-parsed dict; ``base`` is the
    folder a ``[point].table`` path is relative to."""
    return _parse(source, origin, base)[0]


def _parse(source: str | dict, origin: str, base: Path | None) -> tuple[Scene, _Static]:
    """parse_scene, and the static part the Scene was made from."""
    if isinstance(source, str):
        if len(source) > 16 * 1024 * 1024:
            raise SceneError(origin, "is larger than 16 MB")
        try:
            doc = tomllib.loads(source)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(origin, f"is not valid TOML ({str(exc)[:200]})") from None
        except RecursionError:
            raise SceneError(origin, "is nested too deeply") from None
        except ValueError as exc:       # e.g. an integer of more than 4300 digits
            raise SceneError(origin, f"is not valid TOML ({str(exc)[:120]})") from None
    elif isinstance(source, dict):
        doc = source
    else:
        raise SceneError(origin, "must be TOML text, a path or a dict")
    key = _static_key(doc, origin, base)
    seen = _SEEN.get(key) if key is not None else None
    if seen is not None:
        v, given = dict(seen[0]), set(seen[1])
        _read_table(doc, _STATE_TABLE, v, given)
        return _state_part(seen[2], v, given, _Snapshot(key, doc, v, given)), seen[2]
    v, given = _read(doc)
    static = _static_part(v, given, origin, base)
    if key is not None and _remember(key, doc, v, given, static):
        kept = _Snapshot(key, doc, v, given)
    else:
        kept = _Copy(doc, owned=isinstance(source, str))
    return _state_part(static, v, given, kept), static


class _Copy:
    """A scene's dict kept as a deep copy (taken now unless the dict is the parser's own:
    a TOML text's); every read gets a copy of it."""
    __slots__ = ("_doc",)

    def __init__(self, doc: dict, owned: bool = False):
        import copy
        self._doc = doc if owned else copy.deepcopy(doc)

    def get(self) -> dict:
        import copy
        return copy.deepcopy(self._doc)


class _Snapshot:
    """A scene's dict kept as the serialised static part that keys it (see _SEEN) and its
    validated field values (the parser's own: nothing copied on the path of a call);
    read back on demand, [initial] from the values."""
    __slots__ = ("_key", "_where", "_v", "_given")

    def __init__(self, key: bytes, doc: dict, v: dict, given: set):
        self._key, self._v, self._given = key, v, given
        self._where = list(doc).index(_STATE_TABLE) if _STATE_TABLE in doc else None

    def get(self) -> dict:
        items = list(marshal.loads(self._key)[2])
        if self._where is not None:
            table = {}
            for f in _STATE_FIELDS:
                if f.where in self._given:
                    x = self._v[f.where]
                    table[f.key] = x.tolist() if isinstance(x, np.ndarray) else \
                        list(x) if isinstance(x, tuple) else x
            items.insert(self._where, (_STATE_TABLE, table))
        return dict(items)


# ---- scenes seen before -------------------------------------------------------------------
# A parameter study calls simulate with scenes that differ only in their initial state:
# the static part of a scene (every field but those of [initial], and [initial].time) is
# kept by its exact content, and such a scene re-validates only its [initial] table.  The
# key is marshal's serialisation of that content (with the origin and the table folder):
# byte for byte the same only for the same types and values, so a hit validates exactly
# what the first scene validated (a scene holding anything but plain dicts, lists,
# strings, numbers and booleans, or a [point].table whose file could change, is not kept).
_SEEN: dict = {}
_SEEN_MAX, _SEEN_MAX_KEY = 64, 1 << 18
_MARSHAL_VERSION = 2        # from 3 on, marshal marks objects by their reference counts
_SEEN_LOCK = threading.Lock()


def _static_key(doc: dict, origin: str, base: Path | None) -> bytes | None:
    init, point = doc.get(_STATE_TABLE), doc.get("point")
    if (init is not None and type(init) is not dict) or \
            (type(point) is dict and "table" in point):
        return None
    rest = [item for item in doc.items() if item[0] != _STATE_TABLE]
    try:
        key = marshal.dumps((origin, None if base is None else str(base), rest,
                             None if init is None else init.get("time")), _MARSHAL_VERSION)
    except ValueError:                      # not plain data
        return None
    return key if len(key) <= _SEEN_MAX_KEY else None


def _remember(key: bytes, doc: dict, v: dict, given: set, static: _Static) -> bool:
    """Keep the static part of a plain scene; False for a scene that is not plain."""
    if not _plain(doc):
        return False                        # e.g. a NumPy float (marshalled as bytes)
    defaults = _defaults()
    state = {f.where for f in _STATE_FIELDS}
    v = {k: (defaults[k] if k in state else x) for k, x in v.items()}
    given = {g for g in given if g not in state}
    with _SEEN_LOCK:
        if len(_SEEN) >= _SEEN_MAX:
            _SEEN.pop(next(iter(_SEEN)))
        _SEEN[key] = (v, given, static)
    return True


def _plain(x) -> bool:
    """Only dicts, lists, strings, floats, ints, booleans and None, exactly."""
    t = type(x)
    if t is dict:
        return all(type(k) is str and _plain(y) for k, y in x.items())
    if t is list:
        return all(_plain(y) for y in x)
    return t in (str, float, int, bool) or x is None


# fields of which a scene gives one: an override of one drops the other from its base
# (the built-in scene's quaternion would otherwise refuse every matrix given on top of it)
EITHER = {"[initial].quaternion": "[initial].matrix", "[initial].matrix": "[initial].quaternion"}


def override_fields(v: dict, given: set, name: str, value) -> str:
    """Validate one override of a variant (``table.key`` or ``table.key[k]``) into the
    field values ``v`` of an already-read scene (see :func:`derive.runtime.batch`);
    returns the field it set (``[table].key``)."""
    path, _, index = name.partition("[")
    table, _, key = path.rpartition(".")
    f = _BY_TABLE.get(table, {}).get(key)
    if f is None:
        raise SceneError(name, "is not a scene field")
    if index:
        current = v[f.where]
        k = index.rstrip("]")
        if f.kind not in ("vector", "laws", "choices") or not k.isdigit() \
                or not isinstance(current, tuple) or not 0 <= int(k) < len(current):
            raise SceneError(name, f"{f.where} has no entry {k}")
        if f.kind == "vector":
            entry = _num(f, value, f"{f.where}[{k}]")
            v[f.where] = current[:int(k)] + (entry,) + current[int(k) + 1:]
        else:                               # one string of a list: the list checked whole
            whole = list(current)
            whole[int(k)] = value
            v[f.where] = _value(f, whole)
    else:
        v[f.where] = _value(f, value)
    given.add(f.where)
    other = EITHER.get(f.where)
    if other is not None and other in given:
        given.discard(other)
        v[other] = _defaults()[other]
    if table == "plane":
        v["__plane__"] = True
    return f.where


def build_scene(v: dict, given: set, doc, origin: str = "scene",
                base: Path | None = None) -> Scene:
    """The cross-field rules over validated field values (from :func:`_read`); ``doc``:
    the scene's dict (copied) or an object whose ``get()`` gives it (:attr:`Scene.doc`)."""
    source = _Copy(doc) if isinstance(doc, dict) else doc
    return _state_part(_static_part(v, given, origin, base), v, given, source)


@dataclass(frozen=True)
class _Static:
    """What a scene's fields give apart from its initial state (``[initial]`` but its
    time): the Scene's fields but those of the state, validated, and what the state's
    rules read."""
    fields: dict
    summary: LawSummary
    step: float | None         # [run].step as given
    # what the driver derives from these fields alone (the run's options, parameters),
    # kept for the scenes made from them by parse_scene (driver.prepare)
    memo: dict = field(default_factory=dict, compare=False)


# the fields the state part reads; a scene seen before re-validates only these
_STATE_TABLE = "initial"
_STATE_FIELDS = tuple(f for f in FIELDS if f.table == _STATE_TABLE)


def _static_part(v: dict, given: set, origin: str, base: Path | None) -> _Static:
    """Every cross-field rule that does not read the initial state."""
    for f in _REQUIRED:
        if v[f.where] is REQUIRED and (f.table != "plane" or v["__plane__"]):
            if f.table in ("body", "point") and not any(g.startswith(f"[{f.table}]")
                                                         for g in given):
                raise SceneError(f"[{f.table}]", "is required")
            raise SceneError(f.where, "is required" + (f" ({f.rule})" if f.choices else ""))

    M, m = v["[body].mass"], v["[point].mass"]
    J = v["[body].inertia"]
    _inertia_ok(J)
    shape = v["[body].shape"]
    if shape == "sphere":
        if v["[body].semi_axes"] is not None:
            raise SceneError("[body].semi_axes", "belongs to an ellipsoid; a sphere has radius")
        size: tuple = (_require(v, "[body].radius", 'is required for shape = "sphere"'),)
    elif shape == "ellipsoid":
        if v["[body].radius"] is not None:
            raise SceneError("[body].radius", "belongs to a sphere; an ellipsoid has semi_axes")
        size = _require(v, "[body].semi_axes", 'is required for shape = "ellipsoid"')
    else:
        for key in ("radius", "semi_axes"):
            if v[f"[body].{key}"] is not None:
                raise SceneError(f"[body].{key}", "a body of shape 'none' has no size")
        size = ()
    center = v["[body].center"]
    if size and math.sqrt(sum(c * c for c in center)) > 100 * max(size):
        raise SceneError("[body].center", "is more than 100 sizes away from O")
    if v["[point].ends"] != "free" and "[point].ends" in given \
            and v["[point].law"] is not None:
        raise SceneError("[point].ends", "applies to a table or samples, not to a law")
    plane = v["__plane__"]
    e = v["[plane].restitution"] if plane else 1.0
    t0, duration = v["[initial].time"], v["[run].duration"]
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
    law, law_text = _point_law(v, base)
    body_size = float(max(size)) if size else math.sqrt(max(J) / M)
    max_distance = v["[point].max_distance"] or 10.0 * body_size
    summary = _check_law(law, t0, t1, "[point].samples" if v["[point].samples"] is not None
                         else "[point].table")
    if summary.max_radius > max_distance:
        if law_text:
            with np.errstate(all="ignore"):
                r = law.jets(np.linspace(t0, t1, lawmod.SAMPLES))[[0, 3, 6]]
                far = np.nan_to_num(np.abs(r), nan=np.inf).max(axis=1)
            where = f"[point].law[{int(np.argmax(far))}]"
        else:
            where = "[point].samples" if v["[point].samples"] is not None else "[point].table"
        raise SceneError(where, f"takes P {summary.max_radius:.3g} from O, beyond "
                                f"max_distance = {max_distance:.3g} (10 body sizes unless "
                                "[point].max_distance says otherwise)")
    if plane and shape != "none" and v["[run].method"] != "rk4" \
            and duration / summary.time_scale > v["[run].max_steps"]:
        # with the plane a step is at most the law's time scale (driver.options): the run
        # could only end at max_steps, after minutes of work
        where = "[point].law" if law_text else (
            "[point].samples" if v["[point].samples"] is not None else "[point].table")
        raise SceneError(where, f"moves P on a time scale of {summary.time_scale:.3g} s "
                                f"(sqrt(amplitude / max |OP''|)); with the plane a step is "
                                f"at most that, so {duration:g} s need at least "
                                f"{duration / summary.time_scale:.3g} steps, beyond [run]."
                                f"max_steps = {v['[run].max_steps']}: shorten "
                                "[run].duration or slow the law")
    st = Stability(v["[stability].period"], v["[stability].impacts_every"],
                   v["[stability].long_periods"], v["[stability].perturbations"])
    _singular_J(J, M * m / (M + m), summary)
    fields = dict(name=v["name"], M=M, J=J, shape=shape, size=size, center=center, m=m,
                  law=law, law_text=law_text, plane=plane, e=e, t0=t0, duration=duration,
                  method=v["[run].method"], rtol=v["[run].rtol"], atol=v["[run].atol"],
                  g=v["[run].g"], outputs=v["[run].outputs"], max_events=v["[run].max_events"],
                  max_steps=v["[run].max_steps"], output_dt=out_dt,
                  keep_orthonormal=v["[run].keep_orthonormal"], model=v["[run].model"],
                  zeno_dt=v["[run].zeno_dt"], source=origin, stability=st,
                  law_summary=summary, max_distance=max_distance)
    return _Static(fields, summary, v["[run].step"])


def _state_part(static: _Static, v: dict, given: set, source) -> Scene:
    """The rules that read the initial state, and the Scene."""
    A0 = _orientation(v, given)
    f = static.fields
    duration, step = f["duration"], static.step
    if step is None:
        # RK4 has no error control: a step that resolves the spin and the point's motion
        spin = max(math.hypot(*v["[initial].omega"]), 1e-300)
        step = min(duration / 2000.0, 0.04 / spin, static.summary.time_scale / 10.0)
    if f["method"] == "rk4" and duration / step > 1e8:
        raise SceneError("[run].step", f"gives {duration / step:.3g} RK4 steps (at most 1e8)")
    scene = Scene.of_fields(f, com=v["[initial].com"], com_velocity=v["[initial].com_velocity"],
                            omega=v["[initial].omega"], A0=A0, step=step, doc_source=source)
    _start_above_plane(scene)
    return scene


def load_scene(scene) -> Scene:
    """A :class:`Scene` from a path, a dict or a Scene."""
    return _load(scene)[0]


def _load(scene) -> tuple[Scene, _Static | None]:
    """load_scene, and the static part the Scene was made from (None for a Scene given)."""
    if isinstance(scene, Scene):
        return scene, None
    if isinstance(scene, dict):
        return _parse(scene, "scene", None)
    if not isinstance(scene, (str, os.PathLike)):
        raise SceneError("scene", f"must be a path, a dict of the schema or a Scene, not "
                                  f"{_type_name(scene)}")
    path = Path(scene)
    if not path.is_file():
        raise SceneError(str(scene)[:200], "no such scene file")
    if path.stat().st_size > 16 * 1024 * 1024:
        raise SceneError(str(scene)[:200], "is larger than 16 MB")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(str(scene)[:200], f"cannot be read ({type(exc).__name__})") from None
    return _parse(text, str(path), path.parent)


# ---- what the schema gives besides validation --------------------------------------------------
def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(x) for x in value) + "]"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def template(shape: str = "sphere") -> str:
    """A commented scene of every field (``derive scene new``)."""
    lines = ["# A scene for `derive simulate` (every key; defaults where not required).",
             "# Schema: README.md, section 'Scene schema'."]
    table = None
    skip = {"sphere": {"semi_axes"}, "ellipsoid": {"radius"}, "none": {"radius", "semi_axes"}}
    for f in FIELDS:
        if f.table == "stability" or f.key in skip.get(shape, set()):
            continue
        if f.table != table:
            table = f.table
            lines.append("")
            if f.table:
                lines.append(f"[{f.table}]")
        value = f.example if f.example is not None else (
            None if f.default is None or f.default is REQUIRED else f.default)
        if f.key == "shape":
            value = shape
        note = f.doc + (f"; {f.rule}" if f.rule else "") + (f" ({f.when})" if f.when else "")
        if value is None or f.key in ("table", "samples", "matrix", "ends"):
            lines.append(f"# {f.key} = ...{' ' * 20}# {note}")
        else:
            lines.append(f"{f.key} = {_toml(value)}  # {note}")
    lines.append("")
    lines.append("# [stability] (optional): period, impacts_every, long_periods, perturbations")
    return "\n".join(lines) + "\n"


def schema_table() -> str:
    """The README's schema table (a test keeps the README equal to it)."""
    rows = ["| field | type | default | rule | meaning |", "|---|---|---|---|---|"]
    for f in FIELDS:
        if f.default is REQUIRED:
            default = "required"
        elif f.default is None:
            default = "—"
        else:
            default = f"`{_toml(f.default)}`"
        kind = f"{f.kind}[{f.size}]" if f.size else f.kind
        doc = f.doc + (f" ({f.when})" if f.when else "")
        rows.append(f"| `{f.where}` | {kind} | {default} | {f.rule} | {doc} |")
    rows.append("")
    rows.append("Rules across fields:")
    rows.append("")
    rows += [f"- {r}" for r in RULES]
    return "\n".join(rows)


def builtin_doc() -> dict:
    """The built-in scene: a ball whose internal point moves, bouncing on the plane."""
    return {
        "name": "bouncing-ball",
        "body": {"mass": 1.0, "inertia": [0.10, 0.12, 0.14], "shape": "sphere", "radius": 0.5,
                 "center": [0.0, 0.0, 0.0]},
        "point": {"mass": 0.2, "law": ["0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"]},
        "plane": {"restitution": 0.9},
        "initial": {"time": 0.0, "com": [0.0, 0.0, 1.5], "com_velocity": [0.3, 0.0, 0.0],
                    "omega": [0.5, -0.3, 1.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
        "run": {"duration": 5.0, "method": "lie", "rtol": 1e-10, "atol": 1e-12, "g": 9.81,
                "outputs": ["pose", "impacts"]},
    }


def _builtin_toml() -> str:
    doc = builtin_doc()
    lines = ["# The built-in scene: a ball whose internal point moves, bouncing on the plane.",
             f"name = {_toml(doc['name'])}"]
    for table in TABLES[1:]:
        if table in doc:
            lines += ["", f"[{table}]"]
            lines += [f"{k} = {_toml(v)}" for k, v in doc[table].items()]
    return "\n".join(lines) + "\n"


DEFAULT_SCENE = _builtin_toml()
