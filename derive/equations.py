"""The derived equations, indexed by the catalogue's IDs (``../shared/paper/CLAIMS.md``).

Each entry is computed by ``momentum``, ``kinematics``, ``impact``, ``surfaces`` (and,
for persistent contact, ``contact``); this module only collects and prints them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import sympy as sp

from . import notation as nt


@dataclass(frozen=True)
class Derived:
    id: str
    title: str
    relations: tuple          # tuple of (lhs, rhs) pairs, each read "lhs = rhs"
    where: tuple = field(default=())   # auxiliary definitions, same form
    note: str = ""


def _vec_rel(lhs: list, rhs: sp.Matrix) -> tuple:
    return tuple((lh, r) for lh, r in zip(lhs, rhs))


def _e1_1() -> Derived:
    from .momentum import centre_of_mass_motion
    Q, _, lemma = centre_of_mass_motion()
    if lemma != sp.zeros(3, 1):
        raise AssertionError("Q is not (m+M) V_C")
    Qs = sp.symbols("Q_X Q_Y Q_Z")
    return Derived("E1.1", "momentum theorems in flight (starting point)",
                   _vec_rel([sp.Derivative(sp.Function(q)(nt.t), nt.t) for q in Qs],
                            -(nt.m + nt.M) * nt.g * nt.E_Z)
                   + tuple((sp.Symbol(f"dK_{c}/dt"), 0) for c in "xyz"),
                   where=_vec_rel(list(Qs), (nt.m + nt.M) * nt.V_C),
                   note="Q = M V_O + m V_P reduces to (m+M) V_C (checked while deriving)")


def _e1_2() -> Derived:
    from .momentum import centre_of_mass_motion
    _, acc, _ = centre_of_mass_motion()
    return Derived("E1.2", "motion of the centre of mass C",
                   _vec_rel([nt.X_Cdd, nt.Y_Cdd, nt.Z_Cdd], acc))


def _e1_3() -> Derived:
    from .momentum import relative_rate_equation
    _, lhs = relative_rate_equation()
    return Derived("E1.3", "angular-momentum theorem through the relative derivative",
                   tuple((c, 0) for c in lhs))


def _e1_4() -> Derived:
    from .momentum import angular_momentum
    am = angular_momentum()
    own = [sp.Symbol(f"(K - J omega)_{c}") for c in "xyz"]
    return Derived("E1.4", "K = J omega + (angular momentum of the relative motion of P)",
                   _vec_rel(own, am.own.applyfunc(sp.factor)),
                   where=((nt.mu, nt.MU_DEFINITION),))


def _e1_5() -> Derived:
    from .momentum import angular_momentum
    J = angular_momentum().J
    names = [sp.Symbol(f"J_{i + 1}{j + 1}") for i in range(3) for j in range(3)]
    return Derived("E1.5", "the matrix J = dK/d omega", tuple(zip(names, J)))


def _e1_6() -> Derived:
    from .momentum import angular_momentum
    K = angular_momentum().K
    return Derived("E1.6", "components of K about C in body axes",
                   _vec_rel(sp.symbols("K_x K_y K_z"), K))


def _e1_7() -> Derived:
    from .momentum import flight_dynamics
    r = flight_dynamics().residual
    return Derived("E1.7", "dynamic equations of the carrier in flight",
                   tuple((sp.collect(c, [nt.mu, *nt.omega_dot]), 0) for c in r))


def _e1_8() -> Derived:
    from .kinematics import poisson_equations
    rates = poisson_equations()
    return Derived("E1.8", "Poisson's kinematic equations",
                   tuple((nt.ad[i, j], rates[i, j]) for i in range(3) for j in range(3)))


def _e1_8a() -> Derived:
    from .kinematics import carrier_centre_position
    r_O, expr = carrier_centre_position()
    return Derived("E1.8a", "position of the carrier's centre O", _vec_rel(list(r_O), expr))


def _e1_9() -> Derived:
    from .momentum import integral_of_kinetic_moment
    return Derived("E1.9", "integral of the dynamic equations",
                   ((sp.Symbol("K_x^2 + K_y^2 + K_z^2"), integral_of_kinetic_moment()),),
                   note="constant along E1.7: its derivative is 2 (K, residual of E1.7)")


def _e1_10() -> Derived:
    from .impact import lever
    CS, d = lever()
    return Derived("E1.10", "impact: Q+ - Q- = I n, K+ - K- = I d, d = CS x n",
                   _vec_rel(sp.symbols("d_x d_y d_z"), d.applyfunc(sp.factor_terms)),
                   where=_vec_rel([sp.Symbol(f"CS_{c}") for c in "xyz"], CS))


def _e1_11() -> Derived:
    from .impact import impact_map
    jump = impact_map().velocity_jump
    plus = sp.symbols("X_C'+ Y_C'+ Z_C'+")
    minus = sp.symbols("X_C'- Y_C'- Z_C'-")
    return Derived("E1.11", "jump of the velocity of C",
                   _vec_rel(list(plus), sp.Matrix(minus) + jump))


def _e1_12() -> Derived:
    from .impact import impact_map
    im = impact_map()
    plus = sp.symbols("omega_x+ omega_y+ omega_z+")
    return Derived("E1.12", "jump of the angular velocity",
                   _vec_rel(list(plus), im.omega_plus),
                   where=((sp.Symbol("J w"), sp.Symbol("d")),),
                   note="omega on the right is omega-; w = J^-1 d is solved numerically")


def _e1_13() -> Derived:
    from .impact import V_N_MINUS
    return Derived("E1.13", "Newton's law of restitution (starting point)",
                   ((sp.Symbol("v_n+"), -nt.e * V_N_MINUS),))


def _e1_14() -> Derived:
    from .impact import impact_map
    return Derived("E1.14", "normal velocity of the body point S",
                   ((sp.Symbol("v_n"), impact_map().normal_velocity),))


def _e1_15() -> Derived:
    from .impact import impact_map
    return Derived("E1.15", "the impulse", ((nt.I, impact_map().impulse),),
                   note="v_n- is E1.14 at the state before the impact")


def _e1_16() -> Derived:
    from .impact import impact_map, K_SYMBOL
    return Derived("E1.16", "the coefficient k", ((K_SYMBOL, impact_map().k),),
                   where=((sp.Symbol("J w"), sp.Symbol("d")),))


def _surface(kind: str) -> Callable[[], Derived]:
    def build() -> Derived:
        from .surfaces import SHAPES
        lp = SHAPES[kind]()
        return Derived(f"S.{kind}", f"lowest point S of a {kind} (not in the catalogue)",
                       _vec_rel(list(nt.OS), lp.point)
                       + _vec_rel(list(nt.OS_rate), lp.rate))
    return build


BUILDERS: dict[str, Callable[[], Derived]] = {
    "E1.1": _e1_1, "E1.2": _e1_2, "E1.3": _e1_3, "E1.4": _e1_4, "E1.5": _e1_5,
    "E1.6": _e1_6, "E1.7": _e1_7, "E1.8": _e1_8, "E1.8a": _e1_8a, "E1.9": _e1_9,
    "E1.10": _e1_10, "E1.11": _e1_11, "E1.12": _e1_12, "E1.13": _e1_13,
    "E1.14": _e1_14, "E1.15": _e1_15, "E1.16": _e1_16,
    "S.sphere": _surface("sphere"), "S.ellipsoid": _surface("ellipsoid"),
}


def derived(eq_id: str) -> Derived:
    try:
        return BUILDERS[eq_id]()
    except KeyError:
        raise KeyError(f"no derived equation with ID {eq_id!r}; known: "
                       + ", ".join(BUILDERS)) from None


def render_text(entry: Derived) -> str:
    lines = [f"{entry.id}  {entry.title}"]
    for lhs, rhs in entry.relations:
        lines.append(f"    {sp.sstr(lhs)} = {sp.sstr(rhs)}")
    for lhs, rhs in entry.where:
        lines.append(f"  where {sp.sstr(lhs)} = {sp.sstr(rhs)}")
    if entry.note:
        lines.append(f"  ({entry.note})")
    return "\n".join(lines)


def render_latex(entry: Derived) -> str:
    def tex(expr) -> str:
        return sp.latex(expr, symbol_names=nt.LATEX_NAMES)
    lines = [f"% {entry.id}: {entry.title}", r"\begin{align}"]
    rows = [f"  {tex(lhs)} &= {tex(rhs)}" for lhs, rhs in entry.relations]
    lines.append(" \\\\\n".join(rows))
    lines.append(r"\end{align}")
    for lhs, rhs in entry.where:
        lines.append(f"% where ${tex(lhs)} = {tex(rhs)}$")
    return "\n".join(lines)
