"""The law as allocation-free C: ``law.h`` and ``law.c`` rendered from
``templates/plan/`` with numbers only (each printed by ``repr`` of a float checked
finite); every identifier is fixed by the templates, nothing of the task's text enters."""
from __future__ import annotations

import math

from ..emit.render import environment, versions
from .law import Law


def _num(x) -> str:
    x = float(x)
    if not math.isfinite(x):
        raise ValueError("a non-finite number cannot be written into the C law")
    text = repr(x)
    return text if any(c in text for c in ".en") else text + ".0"


def render(law: Law) -> dict[str, str]:
    """{"law.h": ..., "law.c": ...}"""
    knots = law.knots
    P = law.polynomials_in_t()                   # (n, dim, 4) in powers of t - t_i
    ctx = {"versions": versions(), "pieces": int(law.spline.n),
           "periodic": law.repeats, "rest": law.rest and not law.repeats,
           "circle": law.kind == "circle",
           "dim": int(P.shape[1]), "knots": [_num(k) for k in knots],
           "coeffs": [[[_num(c) for c in row] for row in piece] for piece in P]}
    if law.kind == "circle":
        cx, cy, R = law.circle
        ctx.update(center_x=_num(cx), center_y=_num(cy), radius=_num(R))
    env = environment()
    return {name: env.get_template(f"plan/{name}.jinja").render(**ctx)
            for name in ("law.h", "law.c")}
