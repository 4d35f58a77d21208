"""The derived functions the planner composes: loaded from ``generated/casadi/`` (or,
where a checkout has none, built from the same specifications), never retyped.

``lever`` (CS and d = CS x n of E1.10) is not among the emitted functions; it is built
here from :func:`derive.impact.lever` with the CasADi backend, like the others.
"""
from __future__ import annotations

from functools import lru_cache

import casadi as ca

from .. import models as dm
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
    "lowest_point_sphere": lambda: dm.lowest_point("sphere"),
    "lowest_point_ellipsoid": lambda: dm.lowest_point("ellipsoid"),
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
