"""The one TOML writer of the project: scenes written by ``derive scene new`` and by the
planner (``scene.toml`` of a plan), the built-in scene, and the fuzzers' hostile files
(arrays of tables, ``[[point]]`` and ``[[rotor]]``, as such).

Python's ``tomllib`` only reads; what this writes reads back with it to the same
values (floats by their shortest repr, bit for bit; NaN and infinities as TOML's
``nan``/``inf``; every string escaped so that no character of it can end it).
"""
from __future__ import annotations

import math
import re

import numpy as np

_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f",
            "\r": "\\r"}
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def string(s: str) -> str:
    """A basic string: quotes, backslashes and control characters escaped (a lone
    surrogate, which TOML cannot hold, as U+FFFD)."""
    out = []
    for ch in s:
        code = ord(ch)
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif code < 0x20 or code == 0x7F:
            out.append(f"\\u{code:04x}")
        elif 0xD800 <= code <= 0xDFFF:
            out.append("\\ufffd")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def key(k) -> str:
    k = str(k)
    return k if _BARE_KEY.fullmatch(k) else string(k)


def value(v) -> str:
    """One value: booleans, integers, floats (NumPy's too), strings, lists (tuples and
    arrays) and inline tables."""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if math.isnan(x):
            return "nan"
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)
    if isinstance(v, str):
        return string(v)
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{key(k)} = {value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def _tables(v) -> bool:
    """A non-empty list of dicts: an array of tables (``[[point]]``)."""
    return isinstance(v, (list, tuple)) and bool(v) and all(isinstance(x, dict) for x in v)


def dumps(doc: dict, comments: tuple = ()) -> str:
    """A document: ``comments`` first (each line prefixed ``# ``), the top-level keys,
    then one ``[table]`` per dict value and one ``[[table]]`` per element of a list of
    dicts (``[[point]]``, ``[[rotor]]``), in the document's order (dicts inside tables
    inline)."""
    lines = [f"# {c}" for c in comments]
    for k, v in doc.items():
        if not isinstance(v, dict) and not _tables(v):
            lines.append(f"{key(k)} = {value(v)}")
    for k, v in doc.items():
        for header, table in ((f"[{key(k)}]", v),) if isinstance(v, dict) else \
                ((f"[[{key(k)}]]", x) for x in v) if _tables(v) else ():
            lines += ["", header]
            lines += [f"{key(kk)} = {value(vv)}" for kk, vv in table.items()]
    return "\n".join(lines) + "\n"
