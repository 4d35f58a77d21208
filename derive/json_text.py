"""The one JSON writer of the outputs (summary.json, plan.json, control.json, sweep.json,
...): strict JSON that any parser reads.  NaN and infinities become null (JSON has no
such numbers; Python's ``json`` would write the non-standard ``NaN``), NumPy arrays and
scalars become lists and numbers, and the text ends with a newline."""
from __future__ import annotations

import json
import math

import numpy as np


def _plain(o):
    if isinstance(o, np.ndarray):
        return _finite(o.tolist())
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return _finite(o.item())
    raise TypeError(f"{type(o).__name__} is not JSON data")


def _finite(o):
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    return o


def dumps(data, indent: int | None = 2) -> str:
    """``data`` as strict JSON text (see the module's docstring)."""
    return json.dumps(_finite(data), indent=indent, default=_plain, allow_nan=False) + "\n"
