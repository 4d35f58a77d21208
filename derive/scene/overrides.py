"""Overrides of a scene's fields by dotted name: ``body.mass``, ``initial.com[2]`` (one
entry of a vector), ``point.law[0]`` (one formula of the law).  One parser for the
CLI's ``--set`` and ``--sweep``, the variants of ``simulate_many`` and the benchmarks:
a name is checked against the schema (the nearest field suggested when it is not one),
and a value either goes into a scene's dict (:func:`apply_to_doc`, validated later with
the whole scene) or into field values already read (:func:`apply_to_values`, validated
now, for variants that re-validate only what they change).
"""
from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass

from .errors import SceneError
from .schema import SCENE, Field, Schema, check_number, check_value


class OverrideError(SceneError):
    """A bad override: ``where`` names it (or the flag that gave it), ``rule`` says what."""


# fields of which a scene gives one: an override of one drops the other from its base
# (the built-in scene's quaternion would otherwise refuse every matrix given on top of it)
EITHER = {"[initial].quaternion": "[initial].matrix", "[initial].matrix": "[initial].quaternion"}


@dataclass(frozen=True)
class Target:
    """What an override name designates: a field, and an entry of it or None."""
    name: str
    field: Field
    index: int | None
    element: int | None = None     # point[2].law: [[point]] 2 (from 1, as messages count)

    @property
    def where(self) -> str:
        """How messages name it: ``[initial].com[2]``, as for a scene file's fields
        (``[[point]] 2: law[0]`` for an element of an array of tables)."""
        entry = "" if self.index is None else f"[{self.index}]"
        if self.element is not None:
            return f"[[{self.field.table}]] {self.element}: {self.field.key}{entry}"
        return self.field.where + entry


_ELEMENT = re.compile(r"([a-z]+)\[([0-9]{1,3})\]\.(.+)\Z")


def _unknown(name: str, schema: Schema) -> str:
    """Why ``name`` is not a field, with the nearest field or the table's fields."""
    table, dot, key = name.partition(".")
    if dot and table in schema.by_table and table:
        near = difflib.get_close_matches(key, list(schema.by_table[table]), n=1, cutoff=0.6)
        if near:
            return f"{name!r} is not a scene field; did you mean '{table}.{near[0]}'?"
        keys = ", ".join(schema.by_table[table])
        return f"{name!r} is not a scene field ([{table}] has {keys})"
    near = difflib.get_close_matches(name, list(schema.by_path), n=1, cutoff=0.75)
    if near:
        return f"{name!r} is not a scene field; did you mean {near[0]!r}?"
    tables = ", ".join(t for t in schema.tables if t)
    return f"{name!r} is not a scene field (tables: {tables}; e.g. body.mass)"


def target(name: str, where: str | None = None, schema: Schema = SCENE) -> Target:
    """Parse ``table.key`` or ``table.key[k]``; ``where``: how messages name the
    override (a flag such as ``--set``; by default the name itself)."""
    if not isinstance(name, str):
        raise OverrideError(where or "override", f"a field name must be a string, not "
                                                 f"{type(name).__name__}")
    element = None
    m = _ELEMENT.match(name)
    if m and m.group(1) in schema.arrays:     # point[2].law[0]: one of [[point]]
        element = int(m.group(2))
        if element < 1:
            raise OverrideError(where or name, f"{m.group(1)}[{element}]: the elements of "
                                              f"[[{m.group(1)}]] are numbered from 1")
        name = f"{m.group(1)}.{m.group(3)}"
    path, bracket, rest = name.partition("[")
    f = schema.by_path.get(path)
    if f is None:
        raise OverrideError(where or name, _unknown(path if bracket else name, schema))
    index = None
    if bracket:
        text = rest[:-1] if rest.endswith("]") else "?"
        if not (text.isascii() and text.isdigit() and len(text) <= 9):
            raise OverrideError(f"{f.where}[{rest}", f"the index must be a whole number in "
                                                     f"brackets, like {path}[0]")
        if f.kind not in ("vector", "laws", "choices"):
            raise OverrideError(f"{f.where}[{rest}", "has no entries: set it whole")
        index = int(text)
    return Target(name, f, index, element)


def _one_of(t: Target, count: int) -> int:
    """The element of ``[[table]]`` (``count`` given) that ``t`` sets, from 1: its own,
    or the only one when the name gives none."""
    table = t.field.table
    if t.element is None:
        if count == 1:
            return 1
        raise OverrideError(t.where, f"the scene gives {count} [[{table}]]: name one, as "
                                     f"{table}[1].{t.name.partition('.')[2]} (numbered from "
                                     f"1, as [[{table}]] 1)")
    if t.element > count:
        raise OverrideError(t.where, f"the scene gives {count} [[{table}]] (numbered from 1)")
    return t.element


def parse_value(text: str):
    """A value as TOML writes it (numbers, [lists], "strings", true/false), or the text
    itself (a bare string such as dop853)."""
    try:
        return tomllib.loads(f"v = {text.strip()}")["v"]
    except ValueError:                    # TOMLDecodeError, or an integer of 5000 digits
        return text.strip()


def parse_assignment(text: str, flag: str = "--set") -> tuple[str, object]:
    """``body.mass=1.3`` -> ("body.mass", 1.3); the name checked against the schema."""
    name, sep, value = text.partition("=")
    name = name.strip()
    if not sep:
        raise OverrideError(flag, f"must be table.key=value, e.g. body.mass=1.3 (got "
                                  f"{text!r})")
    t = target(name, flag)
    parsed = parse_value(value)
    if _is_number(parsed) and (t.field.kind == "formula"
                               or (t.field.kind == "laws" and t.index is not None)):
        parsed = value.strip()           # a number is a formula in t too: as written
    elif t.field.kind == "laws" and t.index is None and isinstance(parsed, list):
        parsed = [repr(v) if _is_number(v) else v for v in parsed]
    return name, parsed


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class Formulas(list):
    """The values of a formula swept by one of its numbers (``point.law[0]=0.05*sin(W*t)
    for W=8:16:9``): the formulas with the number written in, in the order swept, and
    ``symbol`` and ``numbers`` (the values the number takes) for tables and axes."""

    def __init__(self, formulas, symbol: str, numbers):
        super().__init__(formulas)
        self.symbol, self.numbers = symbol, list(numbers)


_SYMBOL = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_RESERVED = {"t", "pi", "e"}


def _sweep_formula(name: str, text: str) -> Formulas:
    """``FORMULA for NAME=lo:hi:n`` (or ``=a,b,c``): the formula once per value of NAME,
    written in as the shortest decimal that reads back as the same float; ``name`` the
    field as typed (``point[2].law[0]``: messages name the element)."""
    from .law.ops import FUNCTIONS
    formula, _, spec = text.rpartition(" for ")
    symbol, sep, values = spec.partition("=")
    symbol = symbol.strip()
    if not sep or not _SYMBOL.match(symbol) or symbol in _RESERVED or symbol in FUNCTIONS:
        raise OverrideError("--sweep", f"{name}: a formula is swept as 'FORMULA for "
                                    f"NAME=lo:hi:n', NAME a name that is not t, pi or a "
                                    f"function (got {spec.strip()!r})")
    word = re.compile(rf"(?<![A-Za-z0-9_.]){re.escape(symbol)}(?![A-Za-z0-9_(])")
    if not word.search(formula):
        raise OverrideError("--sweep", f"{name}: {symbol} does not appear in the formula "
                                    f"{formula.strip()!r}")
    numbers = _numbers(name, values)
    texts = [f"{v:.17g}" if float(f"{v:.15g}") != v else f"{v:.15g}" for v in numbers]
    return Formulas([word.sub(f"({x})", formula.strip()) for x in texts], symbol, numbers)


def parse_sweep(text: str) -> tuple[str, list]:
    """``body.mass=0.5:2:7`` (n points from lo to hi) or ``plane.restitution=0.1,0.5,0.9``;
    a formula by one of its numbers, ``point.law[0]=0.05*sin(W*t) for W=8:16:9``
    (:class:`Formulas`)."""
    name, sep, spec = text.partition("=")
    name = name.strip()
    if not sep:
        raise OverrideError("--sweep", f"must be table.key=lo:hi:n or table.key=a,b,c "
                                    f"(got {text!r})")
    t = target(name, "--sweep")
    if (t.field.kind == "laws" and t.index is not None) or t.field.kind == "formula":
        if " for " not in spec:
            raise OverrideError("--sweep", f"{name}: a formula is swept by one of its "
                                        f"numbers: 'FORMULA for NAME=lo:hi:n', e.g. "
                                        f"{name}=0.05*sin(W*t) for W=8:16:9")
        return name, _sweep_formula(name, spec)
    return name, _numbers(name, spec)


def _numbers(name: str, spec: str) -> list:
    """The values of ``lo:hi:n`` or ``a,b,c``."""
    if ":" in spec:
        parts = spec.split(":")
        if len(parts) != 3:
            raise OverrideError("--sweep", f"{name}: a range is lo:hi:n, three parts (got "
                                        f"{spec!r})")
        try:
            lo, hi = float(parts[0]), float(parts[1])
        except ValueError:
            raise OverrideError("--sweep", f"{name}: lo and hi of lo:hi:n must be numbers (got "
                                        f"{spec!r})") from None
        n = parts[2].strip()
        if not (n.isascii() and n.isdigit() and len(n) <= 6) or not 1 <= int(n) <= 100_000:
            raise OverrideError("--sweep", f"{name}: n of lo:hi:n, the number of values, must "
                                        f"be a whole number in [1, 100000] (got {n!r})")
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise OverrideError("--sweep", f"{name}: values must be finite numbers")
        values = decimal_grid(parts[0], parts[1], int(n))
    else:
        try:
            values = [float(v) for v in spec.split(",")]
        except ValueError:
            raise OverrideError("--sweep", f"{name}: values must be numbers separated by commas "
                                        f"(got {spec!r})") from None
    if not values or not all(math.isfinite(v) for v in values):
        raise OverrideError("--sweep", f"{name}: values must be finite numbers")
    return values


def decimal_grid(lo, hi, n: int) -> list[float]:
    """``n`` values from ``lo`` to ``hi`` evenly spaced in decimal, as a user types them:
    ``lo + k (hi - lo)/(n - 1)`` computed from the numbers as written (strings, or floats
    by their shortest repr) to 60 digits, each rounded once to the nearest float.  So
    0.1:0.9:17 gives 0.3, where ``np.linspace`` gives 0.30000000000000004 (its steps add
    the rounding of (hi - lo)/(n - 1)).  ``derive simulate --sweep`` and ``derive chart
    stability --x/--y`` both use it."""
    from decimal import Decimal, InvalidOperation, localcontext

    def exact(v) -> Decimal:
        if isinstance(v, str):
            try:
                return Decimal(v.strip())
            except InvalidOperation:
                v = float(v)                      # what float() reads and Decimal not
        return Decimal(repr(float(v)))
    with localcontext() as ctx:
        ctx.prec = 60
        a, b = exact(lo), exact(hi)
        if n == 1:
            return [float(a)]
        return [float(a + (b - a) * k / (n - 1)) for k in range(n)]


def apply_to_doc(doc: dict, name: str, value) -> None:
    """Set a dotted field in a scene's dict (``initial.com[2]`` sets one entry of the
    list the dict holds); the value is checked when the scene is."""
    t = target(name)
    f = t.field
    table, key = f.table, f.key
    holder = doc.setdefault(table, {}) if table else doc
    if isinstance(holder, list) and holder:   # [[point]]: one of its elements
        holder = holder[_one_of(t, len(holder)) - 1]
    elif t.element is not None:
        raise OverrideError(t.where, f"the scene gives no [[{table}]] (a single [{table}] "
                                     f"is set as {table}.{key})")
    if not isinstance(holder, dict):
        raise OverrideError(f"[{table}]", "is not a table in the base scene")
    if t.index is not None:
        vec = holder.get(key)
        if not isinstance(vec, list) or not 0 <= t.index < len(vec):
            have = f" (it has {len(vec)})" if isinstance(vec, list) else ""
            raise OverrideError(t.where, f"the base scene has no entry {t.index}{have}")
        vec[t.index] = value
    else:
        holder[key] = value
    other = EITHER.get(f.where)
    if other is not None:                   # one of two fields a scene gives one of
        holder.pop(other.rpartition(".")[2], None)


def apply_to_values(v: dict, given: set, name: str, value, schema: Schema = SCENE) -> str:
    """Validate one override into the field values ``v`` of a scene already read
    (``Schema.read``); returns the field it set (``[table].key``)."""
    t = target(name, schema=schema)
    f = t.field
    elements = v.get(f"[[{f.table}]]") if f.table else None
    if elements:                            # [[point]]: one of its elements
        return _element_value(v, t, elements, value)
    if t.element is not None:
        raise OverrideError(t.where, f"the scene gives no [[{f.table}]] (a single "
                                     f"[{f.table}] is set as {f.table}.{f.key})")
    if t.index is not None:
        current = v[f.where]
        k = t.index
        if not isinstance(current, tuple) or not 0 <= k < len(current):
            have = f" (it has {len(current)})" if isinstance(current, tuple) else ""
            raise OverrideError(t.where, f"has no entry {k}{have}")
        if f.kind == "vector":
            entry = check_number(f, value, f"{f.where}[{k}]")
            v[f.where] = current[:k] + (entry,) + current[k + 1:]
        else:                               # one string of a list: the list checked whole
            whole = list(current)
            whole[k] = value
            v[f.where] = check_value(f, whole)
    else:
        v[f.where] = check_value(f, value)
    given.add(f.where)
    other = EITHER.get(f.where)
    if other is not None and other in given:
        given.discard(other)
        v[other] = schema.defaults()[other]
    if f.table and f.table not in v["__tables__"]:
        v["__tables__"] = v["__tables__"] | {f.table}
    return f.where


def _element_value(v: dict, t: Target, elements: tuple, value) -> str:
    """apply_to_values for a field of one element of ``[[table]]``."""
    from dataclasses import replace
    f = t.field
    k = _one_of(t, len(elements))
    el = elements[k - 1]
    current = el.values.get(f.key)
    if t.index is not None:
        if not isinstance(current, tuple) or not 0 <= t.index < len(current):
            have = f" (it has {len(current)})" if isinstance(current, tuple) else ""
            raise OverrideError(el.where(f"{f.key}[{t.index}]"), f"has no entry "
                                                                 f"{t.index}{have}")
        whole = list(current)
        whole[t.index] = value
        value = whole
    values = {**el.values, f.key: check_value(f, value, el.where(f.key))}
    new = replace(el, values=values, given=el.given | {f.key})
    v[f"[[{f.table}]]"] = elements[:k - 1] + (new,) + elements[k:]
    return f"[[{f.table}]]"


# ---- raw paths (the fuzzers' hostile documents) ------------------------------------------
def set_path(doc: dict, keys: tuple, value) -> dict:
    """``doc[k0][k1]... = value``, making tables on the way (any keys: for documents that
    need not follow the schema)."""
    d = doc
    for k in keys[:-1]:
        d = d.setdefault(k, {})
    d[keys[-1]] = value
    return doc


def delete_path(doc: dict, keys: tuple) -> dict:
    d = doc
    for k in keys[:-1]:
        d = d[k]
    d.pop(keys[-1], None)
    return doc
