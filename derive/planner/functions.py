"""The derived functions the planner composes: loaded from ``generated/casadi/`` (or,
where a checkout has none, built from the same specifications), never retyped.

``lever`` (CS and d = CS x n of E1.10) is not among the emitted functions; it is built
here from :func:`derive.impact.lever` with the CasADi backend, like the others.
"""
from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np

from .. import models as dm
from .. import shapes
from ..emit.casadi_backend import build_function
from ..emit.render import GENERATED

SPECS = {
    "general_flight_rhs": lambda: dm.flight_rhs("general"),
    "vertical_flight_rhs": lambda: dm.flight_rhs("vertical"),
    "vertical_flight_jacobian": lambda: dm.flight_jacobian("vertical"),
    "general_impact": lambda: dm.impact("general"),
    "vertical_impact": lambda: dm.impact("vertical"),
    "general_gap": lambda: dm.gap("general"),
    "vertical_gap": lambda: dm.gap("vertical"),
    "general_kinetic_moment": lambda: dm.kinetic_moment("general"),
    **{f"lowest_point_{name}": (lambda name=name: dm.lowest_point(name))
       for name in shapes.SHAPE_NAMES},
}


@lru_cache(maxsize=None)
def load(name: str) -> ca.Function:
    """A derived CasADi function by its generated name."""
    if name == "lever":
        return _lever()
    path = GENERATED / "casadi" / f"{name}.casadi"
    if path.is_file():
        return ca.Function.load(str(path))
    return build_function(SPECS[name]())


def _lever() -> ca.Function:
    """``lever(q, u, s, p) -> (CS, d)``, body axes, general layout (E1.10)."""
    from ..impact import lever
    CS, d = lever()
    spec = dm.FunctionSpec(
        name="lever", doc="CS and d = CS x n (E1.10), body axes",
        inputs=(dm.Vector("q", dm.STATES["general"], dm.STATE_LABELS["general"]),
                dm.Vector("u", dm.U, dm.U_LABELS), dm.Vector("s", dm.S, dm.S_LABELS),
                dm.Vector("p", dm.P, dm.P_LABELS)),
        outputs=(dm.Vector("CS", tuple(CS), ("CS_x", "CS_y", "CS_z")),
                 dm.Vector("d", tuple(d), ("d_x", "d_y", "d_z"))),
        definitions=dm.MASS_DEFINITIONS)
    return build_function(spec)


def lowest_point(shape: str, n, center, size):
    """OS for the vertical n (CasADi or numbers)."""
    f = load(f"lowest_point_{shape}")
    return f(n, ca.DM(list(center)), ca.DM(list(size)))


class Fast:
    """Numeric evaluation of a CasADi function through preallocated buffers (a few
    microseconds a call, against about a hundred through the usual conversions): for the
    SciPy integrations, which call the right-hand side many thousands of times."""

    def __init__(self, f: ca.Function):
        self.f = f
        self.args = [np.zeros(f.nnz_in(i)) for i in range(f.n_in())]
        self.res = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
        self.buf, self.trigger = f.buffer()
        for i, a in enumerate(self.args):
            self.buf.set_arg(i, memoryview(a))
        for i, r in enumerate(self.res):
            self.buf.set_res(i, memoryview(r))

    def __call__(self, *args):
        for dst, src in zip(self.args, args):
            dst[:] = src
        self.trigger()
        return [r.copy() for r in self.res]
