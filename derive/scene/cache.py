"""Scenes seen before, and the dict a Scene was parsed from.

A parameter study calls ``simulate`` with scenes that differ only in their initial
state: the static part of a scene (every field but those of ``[initial]``, and
``[initial].time``: the rules across fields, the law and its proof) is kept by its exact
content, and such a scene re-validates only its ``[initial]`` table.  The key is
marshal's serialisation of that content (with the origin and the table folder): byte
for byte the same only for the same types and values, so a hit validates exactly what
the first scene validated (a scene holding anything but plain dicts, lists, strings,
numbers and booleans, or a ``[point].table`` (a ``[[point]]``'s) whose file could change,
is not kept).
"""
from __future__ import annotations

import copy
import marshal
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .rules import Draft
from .schema import SCENE, SCENE_FIELDS

STATE_TABLE = "initial"
# the fields the state part reads; a scene seen before re-validates only these
STATE_FIELDS = tuple(f for f in SCENE_FIELDS if f.table == STATE_TABLE)
_STATE_WHERE = frozenset(f.where for f in STATE_FIELDS)


@dataclass(frozen=True)
class Static:
    """What a scene's fields give apart from its initial state (``[initial]`` but its
    time): the Scene's attributes but those of the state, and the draft of the rules
    (what the state's rules read: the shape's size, the law, ...)."""
    fields: dict
    draft: Draft
    # what the driver derives from these fields alone (the run's options, parameters),
    # kept for the scenes made from them (driver.prepare)
    memo: dict = field(default_factory=dict, compare=False)


def _state_defaults() -> dict:
    defaults = SCENE.defaults()
    return {where: defaults[where] for where in _STATE_WHERE}


_SEEN: dict = {}
_SEEN_MAX, _SEEN_MAX_KEY = 64, 1 << 18
_MARSHAL_VERSION = 2        # from 3 on, marshal marks objects by their reference counts
_SEEN_LOCK = threading.Lock()


def static_key(doc: dict, origin: str, base: Path | None) -> bytes | None:
    """The key of a scene's static part, or None for a scene that is not kept."""
    init, point = doc.get(STATE_TABLE), doc.get("point")
    if (init is not None and type(init) is not dict) or \
            (type(point) is dict and "table" in point) or \
            (type(point) is list and any(type(p) is not dict or "table" in p for p in point)):
        return None
    rest = [item for item in doc.items() if item[0] != STATE_TABLE]
    try:
        key = marshal.dumps((origin, None if base is None else str(base), rest,
                             None if init is None else init.get("time")), _MARSHAL_VERSION)
    except ValueError:                      # not plain data
        return None
    return key if len(key) <= _SEEN_MAX_KEY else None


def lookup(key: bytes | None):
    """(values, given, static) of a scene seen before, or None."""
    return _SEEN.get(key) if key is not None else None


def remember(key: bytes, doc: dict, v: dict, given: set, static: Static) -> bool:
    """Keep the static part of a plain scene; False for a scene that is not plain."""
    if not _plain(doc):
        return False                        # e.g. a NumPy float (marshalled as bytes)
    v = dict(v)
    v.update(_state_defaults())
    given = given - _STATE_WHERE
    with _SEEN_LOCK:
        if len(_SEEN) >= _SEEN_MAX:
            _SEEN.pop(next(iter(_SEEN)))
        _SEEN[key] = (v, given, static)
    return True


def clear() -> None:
    with _SEEN_LOCK:
        _SEEN.clear()


_ATOMS = frozenset((str, float, int, bool, type(None)))


def _plain(x) -> bool:
    """Only dicts (with string keys), lists, strings, floats, ints, booleans and None,
    exactly (a NumPy number is marshalled as bytes, a tuple read back as a tuple)."""
    stack = [x]
    atoms = _ATOMS
    while stack:
        y = stack.pop()
        t = type(y)
        if t is dict:
            for k in y:
                if type(k) is not str:
                    return False
            stack.extend(y.values())
        elif t is list:
            stack.extend(y)
        elif t not in atoms:
            return False
    return True


# ---- the dict of a Scene (Scene.doc) -----------------------------------------------------
class Copy:
    """A scene's dict kept as a deep copy (taken now unless the dict is the parser's own:
    a TOML text's); every read gets a copy of it."""
    __slots__ = ("_doc",)

    def __init__(self, doc: dict, owned: bool = False):
        self._doc = doc if owned else copy.deepcopy(doc)

    def get(self) -> dict:
        return copy.deepcopy(self._doc)


class Snapshot:
    """A scene's dict kept as the serialised static part that keys it and its validated
    field values (the parser's own: nothing copied on the path of a call); read back on
    demand, ``[initial]`` from the values."""
    __slots__ = ("_key", "_where", "_v", "_given")

    def __init__(self, key: bytes, doc: dict, v: dict, given: set):
        self._key, self._v, self._given = key, v, given
        self._where = list(doc).index(STATE_TABLE) if STATE_TABLE in doc else None

    def get(self) -> dict:
        items = list(marshal.loads(self._key)[2])
        if self._where is not None:
            table = {}
            for f in STATE_FIELDS:
                if f.where in self._given:
                    x = self._v[f.where]
                    table[f.key] = x.tolist() if isinstance(x, np.ndarray) else \
                        list(x) if isinstance(x, tuple) else x
            items.insert(self._where, (STATE_TABLE, table))
        return dict(items)
