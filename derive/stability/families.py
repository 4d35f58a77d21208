"""Parametric families of stationary rotations, for stability charts.

Each family is a point law with named parameters whose every member has the stationary
rotation omega = (0, 0, omega) about the body axis Oz, the axis fixed in space
(C4.1–C4.3, E4.4–E4.6):

* ``C4.1``: x = y = 0, z = a sin(W t) (any inertia);
* ``C4.2``: x = x0, y = y0, z = a cos(omega t) + b sin(omega t) (4.7);
* ``C4.3``: x = R cos(omega t/2), y = -R sin(omega t/2),
  z = a cos(omega t/2) + b sin(omega t/2) (4.8).

Every member runs on the precompiled variational runtime (numbers and law at run time),
so a whole sweep costs no compilation.  A member is
judged by the multipliers of the (omega, n) block of its monodromy over the law's period:
in free flight the centre of mass decouples (a Jordan block at 1 that says nothing about
the rotation).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import sympy as sp

from .. import notation as nt
from ..scene import SceneError, parse_scene
from .floquet import UNIT_TOL, block_verdict
from .variational import Monodromy

COMMON = {"J_x": 0.10, "J_y": 0.12, "J_z": 0.14, "M": 1.0, "m": 0.2, "omega": 2.0}
LAW_SYMBOLS = {name: sp.Symbol(f"p_{name}", real=True)
               for name in ("a", "b", "W", "omega", "x0", "y0", "R")}


class FamilyError(SceneError):
    """A family's parameter (or a sweep option) that breaks a rule: ``where`` names it,
    ``rule`` says what."""


@dataclass(frozen=True)
class Family:
    name: str
    title: str
    law_names: tuple          # the law's parameters, in the order of LAW_SYMBOLS use
    defaults: dict            # every parameter's default value
    period_factor: float      # period = period_factor * 2 pi / (frequency parameter)
    frequency: str            # the parameter that sets the period

    @property
    def parameters(self) -> tuple:
        return tuple(self.defaults)

    def law(self) -> tuple:
        s = LAW_SYMBOLS
        t = nt.t
        if self.name == "C4.1":
            return (sp.Integer(0), sp.Integer(0), s["a"] * sp.sin(s["W"] * t))
        if self.name == "C4.2":
            w = s["omega"]
            return (s["x0"], s["y0"], s["a"] * sp.cos(w * t) + s["b"] * sp.sin(w * t))
        half = s["omega"] * t / 2
        return (s["R"] * sp.cos(half), -s["R"] * sp.sin(half),
                s["a"] * sp.cos(half) + s["b"] * sp.sin(half))

    def law_text(self, values: dict) -> list:
        """The law with numbers, as a scene's [point].law strings (the same expressions
        as :meth:`law`, numbers printed so that they round-trip)."""
        v = {k: repr(float(values[k])) for k in self.law_names}
        if self.name == "C4.1":
            return ["0", "0", f"{v['a']}*sin({v['W']}*t)"]
        if self.name == "C4.2":
            w = v["omega"]
            return [v["x0"], v["y0"], f"{v['a']}*cos({w}*t) + {v['b']}*sin({w}*t)"]
        half = f"({v['omega']}*t/2)"
        return [f"{v['R']}*cos{half}", f"-{v['R']}*sin{half}",
                f"{v['a']}*cos{half} + {v['b']}*sin{half}"]

    def period(self, values: dict) -> float:
        return self.period_factor * 2 * math.pi / values[self.frequency]

    def values(self, given: dict | None = None) -> dict:
        """Defaults updated with ``given``, checked; FamilyError names a bad one."""
        given = dict(given or {})
        unknown = sorted(set(given) - set(self.defaults))
        if unknown:
            raise FamilyError(unknown[0], f"is not a parameter of family {self.name} "
                                          f"(parameters: {', '.join(self.parameters)})")
        out = {**self.defaults, **{k: float(v) for k, v in given.items()}}
        check(self, out)
        return out

    def scene(self, values: dict, duration: float | None = None) -> dict:
        """A free-flight scene (TOML as a dict) of this member, started in the rotation."""
        return {"name": f"{self.name} stationary rotation",
                "body": {"mass": values["M"], "shape": "none",
                         "inertia": [values["J_x"], values["J_y"], values["J_z"]]},
                "point": {"mass": values["m"], "law": self.law_text(values)},
                "initial": {"time": 0.0, "omega": [0.0, 0.0, values["omega"]]},
                "run": {"duration": duration or self.period(values), "model": "vertical",
                        "method": "lie", "rtol": 1e-12, "atol": 1e-14,
                        "outputs": ["omega"]}}


FAMILIES = {
    "C4.1": Family("C4.1", "x = y = 0, z = a sin(W t)", ("a", "W"),
                   {**COMMON, "a": 0.2, "W": 3.0}, 1.0, "W"),
    "C4.2": Family("C4.2", "x = x0, y = y0, z = a cos(omega t) + b sin(omega t)  (4.7)",
                   ("x0", "y0", "a", "b", "omega"),
                   {**COMMON, "x0": 0.1, "y0": -0.05, "a": 0.15, "b": 0.05}, 1.0, "omega"),
    "C4.3": Family("C4.3", "x = R cos(omega t/2), y = -R sin(omega t/2), "
                           "z = a cos(omega t/2) + b sin(omega t/2)  (4.8)",
                   ("R", "a", "b", "omega"),
                   {**COMMON, "R": 0.15, "a": 0.1, "b": 0.0}, 2.0, "omega"),
}


BOUNCE_DEFAULTS = {"e": 0.5, "a": 0.1, "W": 30.0, "spin": 3.0, "J_x": 0.1, "J_z": 0.15,
                   "M": 1.0, "m": 0.25, "radius": 0.5, "n": 1, "g": 9.81}


@dataclass(frozen=True)
class BounceFamily:
    """The periodic bouncing of reference [5]: the symmetric carrier with z = a sin(W t)
    on its axis, the axis vertical, on the table's symmetric n-orbit.  ``Gamma`` = nu a
    W^2/g may be given instead of ``a`` (then a follows from it)."""
    name: str = "bounce"
    title: str = "periodic bouncing (reference [5]): z = a sin(W t) on the vertical axis"
    defaults: tuple = ()

    @property
    def parameters(self) -> tuple:
        return tuple(BOUNCE_DEFAULTS) + ("Gamma",)

    def axis_rule(self, name: str, lo: float, hi: float) -> str | None:
        """Why a chart axis from lo to hi leaves the parameter's own domain (the rules of
        :meth:`values` on one parameter), or None: such a range is refused, where points
        outside a rule on several parameters are charted as having no body."""
        if name == "e" and not (lo > 0 and hi < 1):
            return f"e must be in (0, 1) over the whole axis (got {lo:g} to {hi:g})"
        if name in ("a", "W", "J_x", "J_z", "M", "m", "radius", "g", "Gamma") \
                and not lo > 0:
            return f"{name} must be > 0 over the whole axis (got {lo:g} to {hi:g})"
        if name == "n":
            return "n is an integer: chart one orbit at a time (set n with --set)"
        return None

    def one_view(self, names, where: str = "") -> None:
        """Gamma and a are two views of one parameter (Gamma = nu a W^2/g): refuse
        ``names`` (the parameters given, swept or set) holding both; ``where``: the
        options that gave them."""
        if "a" in names and "Gamma" in names:
            raise FamilyError(f"{where}: Gamma and a" if where else "Gamma and a",
                              "are two views of one parameter (Gamma = nu a W^2/g, nu = "
                              "m/(m + M)): give one of them")

    def values(self, given: dict | None = None) -> dict:
        given = dict(given or {})
        unknown = sorted(set(given) - set(self.parameters))
        if unknown:
            raise FamilyError(unknown[0], "is not a parameter of bounce (parameters: "
                                          f"{', '.join(self.parameters)})")
        self.one_view(given)
        v = {**BOUNCE_DEFAULTS, **{k: float(x) for k, x in given.items() if k != "Gamma"}}
        for key, value in v.items():
            if not math.isfinite(value):
                raise FamilyError(key, f"must be finite (got {value})")
        for key in ("a", "W", "J_x", "J_z", "M", "m", "radius", "g"):
            if not v[key] > 0:
                raise FamilyError(key, f"must be > 0 (got {v[key]})")
        if v["n"] != int(v["n"]) or v["n"] < 1:
            raise FamilyError("n", f"must be a positive integer (got {v['n']})")
        if not 0 < v["e"] < 1:
            raise FamilyError("e", f"must be in (0, 1) (got {v['e']})")
        if 2 * v["J_x"] < v["J_z"]:
            raise FamilyError("J_z", f"= {v['J_z']} exceeds 2 J_x: no body has these moments")
        nu = v["m"] / (v["m"] + v["M"])
        if "Gamma" in given:
            v["a"] = float(given["Gamma"]) * v["g"] / (nu * v["W"] ** 2)
        v["Gamma"] = nu * v["a"] * v["W"] ** 2 / v["g"]
        from .bouncing import existence_threshold
        threshold = existence_threshold(v["e"], int(v["n"]))
        if v["Gamma"] < threshold:
            raise FamilyError("a", f"gives Gamma = {v['Gamma']:.4g}, below the existence "
                                   f"threshold {threshold:.4g} of the {int(v['n'])}-orbit")
        return v

    def scene(self, v: dict) -> dict:
        from .bouncing import bouncing_scene
        doc = bouncing_scene(e=v["e"], a=v["a"], W=v["W"], spin=v["spin"],
                             inertia=(v["J_x"], v["J_x"], v["J_z"]), M=v["M"], m=v["m"],
                             radius=v["radius"], n=int(v["n"]), g=v["g"])
        doc["stability"] = {"impacts_every": int(v["n"])}
        return doc


class BounceMember:
    """Evaluates bouncing orbits: Newton on the impact-to-impact map and the multipliers,
    on the precompiled vertical and variational runtimes (no compilation per point)."""

    def __init__(self, rtol: float = 1e-12):
        self.family = BounceFamily()

    def point(self, values: dict) -> tuple[float, float, float]:
        """(max |rho| of the whole monodromy, 0.0, Newton's residual)."""
        from .bouncing import analyse
        scene = parse_scene(self.family.scene(values))
        b = analyse(scene, n=int(values["n"]), check=False)
        return float(np.max(np.abs(b.multipliers))), 0.0, float(b.newton_residual)


def family(name: str):
    if name == "bounce":
        return BounceFamily()
    if name not in FAMILIES:
        raise FamilyError("family", f"{name!r} is not one of {', '.join(FAMILIES)}, bounce")
    return FAMILIES[name]


def check(fam: Family, v: dict) -> None:
    for key in ("M", "m", "J_x", "J_y", "J_z"):
        if not v[key] > 0:
            raise FamilyError(key, f"must be > 0 (got {v[key]})")
    J = (v["J_x"], v["J_y"], v["J_z"])
    for k, c in enumerate("xyz"):
        others = J[(k + 1) % 3] + J[(k + 2) % 3]
        if J[k] > others * (1 + 1e-12):
            raise FamilyError(f"J_{c}", f"= {J[k]} exceeds the sum of the other two "
                                        f"({others}): no body has these moments")
    if not v[fam.frequency] > 0:
        raise FamilyError(fam.frequency, f"must be > 0: it sets the period "
                                         f"(got {v[fam.frequency]})")
    if v["omega"] == 0:
        raise FamilyError("omega", "must be nonzero (a rotation)")
    for key, value in v.items():
        if not math.isfinite(value):
            raise FamilyError(key, f"must be finite (got {value})")


def is_valid(fam: Family, v: dict) -> bool:
    try:
        check(fam, v)
    except FamilyError:
        return False
    return True


# ---- evaluating members ---------------------------------------------------------------
class Member:
    """Evaluates members of one family with the precompiled variational runtime: a member
    is a scene (its law a new program, no compilation)."""

    def __init__(self, name: str, rtol: float = 1e-12):
        self.family = family(name)
        self.rtol = rtol

    def monodromy(self, values: dict) -> tuple[np.ndarray, np.ndarray]:
        """(q(T) - q(0), M) for the member ``values`` (checked beforehand)."""
        scene = parse_scene(self.family.scene(values))
        q0 = np.array([0.0, 0.0, 0.0, 0.0, values["omega"], 0.0, 0.0, 1.0])
        qT, M = Monodromy(scene, rtol=self.rtol).flow(0.0, q0, self.family.period(values))
        return qT - q0, M

    def point(self, values: dict) -> tuple[float, float, float]:
        """(max |rho| of the rotation block, 1.0 if it is critical with a Jordan block at
        rho = 1 else 0.0, drift of the base motion over the period)."""
        dq, M = self.monodromy(values)
        block = block_verdict(M[2:, 2:])
        jordan = block["max_modulus"] <= 1 + UNIT_TOL and \
            block["rho_1_geometric"] < block["rho_1_algebraic"]
        return block["max_modulus"], float(jordan), float(np.max(np.abs(dq[2:])))


@lru_cache(maxsize=8)
def member(name: str, rtol: float = 1e-12):
    return BounceMember(rtol) if name == "bounce" else Member(name, rtol)
