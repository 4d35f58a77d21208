"""A study's variants read in bulk: the overrides of many variants of one scene checked
at once with NumPy, by the same :class:`~derive.scene.schema.Field` objects (their
ranges: :func:`~derive.scene.schema.in_range`) and the same rules
(:mod:`derive.scene.rules`: every rule that reads a field of :data:`BULK` has a form over
columns, written with the predicate its check raises on) as one scene is.  What
``derive.simulate_many`` runs without Python per variant.

The fields of :data:`BULK` are the numbers a study varies most (masses, inertia,
restitution, gravity, tolerances, C's position and velocity, omega), given whole or by
entry (``initial.com[2]``).  A group of variants that overrides any other field, or only
one variant, is not read here (:func:`read` returns None): its variants go through the
per-scene validator one by one.  Nor is a variant refused here: one that fails a check
is only marked (``Columns.ok`` False) and goes through the per-scene validator too,
which refuses it with the message one scene gets (a bad value names the variant and
the field) -- or runs it, where the check here is only conservative (a value of a type
other than float or int, a NumPy float32, ...).  tests/test_bulk.py checks over
thousands of random override sets, bad ones among them, that both give the same
verdicts and the same numbers.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import chain

import numpy as np

from .. import shapes
from . import rules
from .parse import scene_fields
from .errors import SceneError
from .overrides import target
from .rules import Draft
from .scene import Scene
from .schema import Field, in_range

# the fields a study may vary in bulk (by Field.where)
BULK = frozenset(("[body].mass", "[point].mass", "[body].inertia", "[plane].restitution",
                  "[run].g", "[run].rtol", "[run].atol", "[initial].com",
                  "[initial].com_velocity", "[initial].omega"))
# read in bulk only where the body has a shape (its size, then max_distance, reads them)
_SIZED = frozenset(("[body].mass", "[body].inertia"))
_EXACT = 2.0 ** 53                      # ints beyond it are refused (check_number)


@dataclass
class Columns:
    """A group of variants read at once: ``v`` the field values (columns where the
    variants differ, vectors as tuples of entries), ``draft`` the rules' draft over them,
    ``ok`` where a variant passed every check, ``scene`` every variant at once (a Scene
    whose numbers are columns and whose state vectors are rows (n, 3): what the options,
    parameters and start of a run read, derive.runtime.batch)."""
    n: int
    v: dict
    draft: Draft
    ok: np.ndarray
    scene: Scene


def _is_number(x) -> bool:
    """A value check_number takes as it is (a float) or converts exactly (an int)."""
    t = type(x)
    return t is float or t is np.float64 or (t is int and -_EXACT <= x <= _EXACT)


def _numbers(col: list, f: Field) -> tuple[np.ndarray, np.ndarray]:
    """The values of one number (or one entry of a vector) for every variant, and where
    they pass the field's checks."""
    if set(map(type, col)) == {float}:                 # the common case
        x = np.array(col, dtype=float)
        return x, in_range(f, x)
    good = np.array([_is_number(c) for c in col], dtype=bool)
    x = np.array([c if g else 0.0 for c, g in zip(col, good)], dtype=float)
    return x, good & in_range(f, x)


def _vectors(col: list, f: Field) -> tuple[tuple, np.ndarray]:
    """A vector given whole by every variant: its entries as columns, and where they pass."""
    size = f.size
    if set(map(type, col)) == {list} and set(map(len, col)) == {size} and \
            set(map(type, chain.from_iterable(col))) == {float}:      # the common case
        rows = np.array(col, dtype=float).reshape(len(col), size)
        good = np.ones(len(col), dtype=bool)
    else:
        good = np.array([isinstance(x, (list, tuple)) and len(x) == size
                         and all(_is_number(c) for c in x) for x in col], dtype=bool)
        rows = np.array([list(x) if g else [0.0] * size for x, g in zip(col, good)],
                        dtype=float).reshape(len(col), size)
    good &= np.all(in_range(f, rows), axis=1)
    return tuple(rows.T), good


def _filled(x: np.ndarray, good: np.ndarray) -> np.ndarray:
    """The column with its failed entries replaced by the first good one (so that the
    rules after read numbers they accept: those variants are marked already)."""
    if not good.all():
        x = x.copy()
        x[~good] = x[good][0]
    return x


def read(base_v: dict, base_given: set, names: tuple, variants: list,
         origin: str = "scene", base=None) -> Columns | None:
    """The variants (dicts with the keys ``names``, in that order) of the scene whose field
    values are ``base_v``, ``base_given`` (``Schema.read``), read in bulk; None when they
    cannot be (a field outside BULK, a single variant, a rule that fails for all of them:
    the per-scene validator then names it)."""
    n = len(variants)
    if n < 2:
        return None
    v, given = dict(base_v), set(base_given)
    ok = np.ones(n, dtype=bool)
    varied = set()
    for name in names:
        t = target(name)
        f = t.field
        if f.where not in BULK:
            return None
        col = [x[name] for x in variants]
        if t.index is not None:
            current = v[f.where]
            if not isinstance(current, tuple) or not 0 <= t.index < len(current):
                return None
            x, good = _numbers(col, f)
            if not good.any():
                return None
            entries = list(current)
            entries[t.index] = _filled(x, good)
            v[f.where] = tuple(entries)
        elif f.kind == "vector":
            entries, good = _vectors(col, f)
            if not good.any():
                return None
            v[f.where] = tuple(_filled(c, good) for c in entries)
        else:
            x, good = _numbers(col, f)
            if not good.any():
                return None
            v[f.where] = _filled(x, good)
        ok &= good
        varied.add(f.where)
        given.add(f.where)                       # as overrides.apply_to_values does
        if f.table and f.table not in v["__tables__"]:
            v["__tables__"] = v["__tables__"] | {f.table}
    if varied & _SIZED and not shapes.SHAPES.get(v["[body].shape"]):
        return None
    d = Draft(v, given, origin, base)
    try:
        with np.errstate(all="ignore"):
            bad = rules.check_bulk(rules.STATIC_RULES + rules.STATE_RULES, d)
    except SceneError:                 # a rule that reads no column: every variant fails it
        return None
    ok &= ~np.broadcast_to(bad, (n,))
    fields = scene_fields(v, d, origin)
    scene = Scene.of_fields(fields, com=_rows(d.extra["com"], n),
                            com_velocity=_rows(d.extra["com_velocity"], n),
                            omega=_rows(v["[initial].omega"], n), A0=d.A0,
                            on_plane=bool(v["[initial].on_plane"]),
                            step=d.extra.get("step", 0.0), doc_source=None)
    return Columns(n, v, d, ok, scene)


def _rows(vector: tuple, n: int) -> np.ndarray:
    """A vector's entries (numbers or columns) as rows (n, len)."""
    out = np.empty((n, len(vector)))
    for k, c in enumerate(vector):
        out[:, k] = c
    return out
