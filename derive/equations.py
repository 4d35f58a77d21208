"""The derived equations, indexed by the catalogue's IDs (``../shared/paper/CLAIMS.md``).

Each entry is computed by ``momentum``, ``kinematics``, ``impact``, ``surfaces`` (and,
for persistent contact, ``contact``); this module only collects and prints them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import sympy as sp

from . import notation as nt
from . import shapes


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
                   + tuple((sp.Derivative(sp.Function(f"K_{c}")(nt.t), nt.t), 0)
                           for c in "XYZ"),
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
        from .surfaces import lowest_point
        lp = lowest_point(kind)
        return Derived(f"S.{kind}", f"lowest point S of a {kind} (not in the catalogue)",
                       _vec_rel(list(nt.OS), lp.point)
                       + _vec_rel(list(nt.OS_rate), lp.rate))
    return build


BUILDERS: dict[str, Callable[[], Derived]] = {
    "E1.1": _e1_1, "E1.2": _e1_2, "E1.3": _e1_3, "E1.4": _e1_4, "E1.5": _e1_5,
    "E1.6": _e1_6, "E1.7": _e1_7, "E1.8": _e1_8, "E1.8a": _e1_8a, "E1.9": _e1_9,
    "E1.10": _e1_10, "E1.11": _e1_11, "E1.12": _e1_12, "E1.13": _e1_13,
    "E1.14": _e1_14, "E1.15": _e1_15, "E1.16": _e1_16,
    **{f"S.{name}": _surface(name) for name in shapes.SHAPE_NAMES},
}


def derived(eq_id: str) -> Derived:
    try:
        return BUILDERS[eq_id]()
    except KeyError:
        raise KeyError(f"no derived equation with ID {eq_id!r}; known: "
                       + ", ".join(BUILDERS)) from None


# ---- what every printed symbol means ------------------------------------------------
GLOSSARY = {
    "t": "time", "const": "a constant of the motion",
    "M": "mass of the carrier", "m": "mass of the point P",
    "mu": "reduced mass m M/(m+M)", "nu": "mass fraction m/(m+M): OC = nu OP",
    "J_x": "principal central moment of inertia of the carrier about Ox (J_y, J_z alike)",
    "g": "acceleration of gravity", "e": "restitution coefficient",
    "x": "OP = (x, y, z): position of P in body axes (a prescribed law of t)",
    "x'": "V_r = (x', y', z'): velocity of P relative to the body",
    "x''": "(x'', y'', z''): acceleration of P relative to the body",
    "omega_x": "omega = (omega_x, omega_y, omega_z): angular velocity, body axes",
    "omega_x'": "(omega_x', omega_y', omega_z'): its rate",
    "a11": "a_ij = cos(fixed axis i, body axis j); (a31, a32, a33) = n, the upward "
           "vertical in body axes",
    "a11'": "a_ij': rate of a_ij",
    "X_C": "(X_C, Y_C, Z_C): centre of mass C of the system, fixed axes (Z up)",
    "X_C'": "(X_C', Y_C', Z_C'): velocity of C; a trailing + or - marks after or before "
            "an impact",
    "X_C''": "acceleration of C",
    "X_O": "(X_O, Y_O, Z_O): the carrier's centre of mass O, fixed axes",
    "Q_X": "Q = (Q_X, Q_Y, Q_Z): momentum of the system, fixed axes",
    "Q_X'": "rate of Q_X",
    "K_X": "(K_X, K_Y, K_Z): angular momentum about C, fixed axes",
    "K_X'": "rate of K_X",
    "K_x": "K = (K_x, K_y, K_z): angular momentum about C, body axes",
    "K_x'": "rate of the body component K_x (the relative derivative)",
    "J_11": "J_ij: entries of J = dK/d omega (E1.5), the inertia at O of the carrier plus "
            "a mass mu at P",
    "J_11'": "J_ij': rate of J_ij along the law",
    "(K - J omega)_x": "components of K - J omega, the part carried by the motion of P",
    "d_x": "d = CS x n (E1.10): the lever of the impulse",
    "CS_x": "CS = OS - nu OP: from C to the lowest point S, body axes",
    "x_*": "OS = (x_*, y_*, z_*): the lowest point S of the surface, body axes",
    "x_*'": "rate of OS",
    "I": "the impulse of the plane's reaction, along n",
    "v_n": "normal velocity of the body point S (the rate of its height); v_n- before, "
           "v_n+ after the impact",
    "k": "the coefficient of E1.16: v_n+ - v_n- = I k",
    "w_x": "w = J^-1 d, found by solving J w = d (never by inversion)",
    "J w": "the product of J (E1.5) and w", "d": "the vector d of E1.10",
    "omega_x+": "omega just after the impact (omega on the right: just before)",
    "c_x": "(c_x, c_y, c_z): centre of the surface in body axes",
    "|n|": "sqrt(a31^2 + a32^2 + a33^2) (= 1; kept so that S tolerates round-off)",
    "D": "sqrt(s_a^2 a31^2 + s_b^2 a32^2 + s_c^2 a33^2)",
}

# the surfaces' size symbols, from derive/shapes.py (a shape added there is named too)
for _size, _shapes in shapes.size_fields():
    _names = _size.names(_size.symbols)
    GLOSSARY[_names[0]] = (f"({', '.join(_names)}): " if len(_names) > 1 else "") + \
        f"{_size.doc} ({', '.join(_shapes)}: [body].{_size.key})"

_ALIASES = {}
for _size, _shapes in shapes.size_fields():
    for _name in _size.names(_size.symbols)[1:]:
        _ALIASES[_name] = _size.names(_size.symbols)[0]
for _group in (("x", "y", "z"), ("x'", "y'", "z'"), ("x''", "y''", "z''"),
               ("omega_x", "omega_y", "omega_z"), ("omega_x'", "omega_y'", "omega_z'"),
               ("X_C", "Y_C", "Z_C"), ("X_O", "Y_O", "Z_O"), ("Q_X", "Q_Y", "Q_Z"),
               ("Q_X'", "Q_Y'", "Q_Z'"), ("K_X", "K_Y", "K_Z"), ("K_X'", "K_Y'", "K_Z'"),
               ("K_x", "K_y", "K_z"), ("K_x'", "K_y'", "K_z'"), ("d_x", "d_y", "d_z"),
               ("CS_x", "CS_y", "CS_z"), ("x_*", "y_*", "z_*"), ("x_*'", "y_*'", "z_*'"),
               ("w_x", "w_y", "w_z"), ("omega_x+", "omega_y+", "omega_z+"),
               ("c_x", "c_y", "c_z"), ("J_x", "J_y", "J_z"),
               ("(K - J omega)_x", "(K - J omega)_y", "(K - J omega)_z")):
    for _name in _group:
        _ALIASES[_name] = _group[0]
for _c in "XYZ":
    for _sfx in ("'", "''", "'+", "'-"):
        _ALIASES[f"{_c}_C{_sfx}"] = "X_C''" if _sfx == "''" else "X_C'"
for _i in range(1, 4):
    for _j in range(1, 4):
        _ALIASES[f"a{_i}{_j}"], _ALIASES[f"a{_i}{_j}'"] = "a11", "a11'"
        _ALIASES[f"J_{_i}{_j}"], _ALIASES[f"J_{_i}{_j}'"] = "J_11", "J_11'"
for _name in ("v_n", "v_n-", "v_n+"):
    _ALIASES[_name] = "v_n"


def _printed_names(entry: Derived) -> list[str]:
    """The names of the symbols and functions an entry prints, in order of appearance."""
    names = []
    for lhs, rhs in (*entry.relations, *entry.where):
        for expr in (lhs, rhs):
            expr = sp.sympify(expr)
            found = [str(a) for a in expr.atoms(sp.Symbol)]
            found += [f.func.__name__ for f in expr.atoms(sp.core.function.AppliedUndef)]
            found += [f"{d.expr.func.__name__}'" for d in expr.atoms(sp.Derivative)
                      if isinstance(d.expr, sp.core.function.AppliedUndef)]
            for name in sorted(found, key=lambda n: (len(n), n)):
                if name not in names:
                    names.append(name)
    return names


def undefined_symbols(entry: Derived) -> list[str]:
    """Printed names with no entry in :data:`GLOSSARY` (the tests want none)."""
    out = []
    for name in _printed_names(entry):
        key = _ALIASES.get(name, name)
        if key not in GLOSSARY and not name.startswith("K_x^2"):
            out.append(name)
    return out


def symbols_block(entry: Derived) -> list[str]:
    """``symbols:`` lines for an entry, each meaning once."""
    seen, lines = set(), []
    for name in _printed_names(entry):
        key = _ALIASES.get(name, name)
        if key in GLOSSARY and key not in seen:
            seen.add(key)
            lines.append(f"      {key:<16} {GLOSSARY[key]}")
    return lines


class _Printer(sp.printing.str.StrPrinter):
    """SymPy's str printer with ``f(t)`` printed as ``f`` and ``df/dt`` as ``f'``."""

    def _print_Derivative(self, expr):
        if isinstance(expr.expr, sp.core.function.AppliedUndef) and \
                len(expr.variables) == 1:
            return f"{expr.expr.func.__name__}'"
        return super()._print_Derivative(expr)

    def _print_Function(self, expr):
        if isinstance(expr, sp.core.function.AppliedUndef) and expr.args == (nt.t,):
            return expr.func.__name__
        return super()._print_Function(expr)


def _str(expr) -> str:
    return _Printer().doprint(expr)


# ---- the compact (factored) form -------------------------------------------------------
def _named() -> dict:
    """Named quantities (symbol -> its definition in the derivation's terms)."""
    from .impact import lever
    from .momentum import angular_momentum
    from .surfaces import radius, semi_axes
    J = angular_momentum().J
    CS, d = lever()
    names = {}
    for i in range(3):
        for j in range(3):
            names[sp.Symbol(f"J_{i + 1}{j + 1}")] = J[i, j]
    for k, c in enumerate("xyz"):
        names[sp.Symbol(f"d_{c}")] = d[k]
        names[sp.Symbol(f"CS_{c}")] = CS[k]
    n = nt.n
    names[sp.Symbol("|n|")] = sp.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2)
    names[sp.Symbol("D")] = sp.sqrt(sum(semi_axes[k] ** 2 * n[k] ** 2 for k in range(3)))
    del radius
    return names


def _same(a, b) -> bool:
    a, b = nt.from_paper_notation(sp.sympify(a)), nt.from_paper_notation(sp.sympify(b))
    return sp.simplify(sp.expand(a - b)) == 0


def compact_expression(expr, names: dict, variables: list):
    """``expr`` with the radicals of ``names`` and, after collecting by ``variables``,
    every coefficient equal (or opposite) to a named quantity replaced by its name; the
    rest grouped (``factor_terms``)."""
    expr = sp.sympify(expr)
    for name, value in names.items():
        if isinstance(value, sp.Pow):
            expr = expr.xreplace({value: name, 1 / value: 1 / name,
                                  value ** 3: name ** 3, 1 / value ** 3: 1 / name ** 3})
            expr = expr.xreplace({value.base: name ** 2, 1 / value.base: name ** -2})
    if variables:
        expanded = sp.expand(expr)
        coeffs = sp.collect(expanded, variables, evaluate=False)
        out = sp.Integer(0)
        for key, c in coeffs.items():
            c = sp.factor_terms(c)
            for name, value in names.items():
                if isinstance(value, sp.Pow):
                    continue
                if sp.expand(c - value) == 0:
                    c = name
                    break
                if sp.expand(c + value) == 0:
                    c = -name
                    break
            out += c * key
        expr = out
    return sp.factor_terms(expr)


def compact(entry: Derived) -> Derived:
    """The entry with named quantities (J_ij, d, CS, |n|, D) in place of their expansions,
    each relation checked equal to the expanded one before it is returned."""
    names = _named()
    variables = [*nt.omega_dot, *nt.omega, *nt.W, nt.a[2, 0], nt.a[2, 1], nt.a[2, 2]]
    if entry.id == "E1.7":
        relations = _e1_7_compact()
    elif entry.id == "E1.9":
        relations = ((entry.relations[0][0], sp.Symbol("const")),)
    elif entry.id in ("E1.4", "E1.5", "E1.8", "E1.8a"):
        return entry
    else:
        relations = tuple((lhs, compact_expression(rhs, names, variables))
                          for lhs, rhs in entry.relations)
    used = set().union(*(sp.sympify(side).free_symbols for rel in relations for side in rel))
    lhs_names = {lhs for lhs, _ in relations}
    no_d = {k: v for k, v in names.items() if not k.name.startswith("d_")}
    n_vars = [nt.a[2, 0], nt.a[2, 1], nt.a[2, 2]]
    where = [(k, compact_expression(v, no_d, n_vars) if k.name.startswith("d_")
              else sp.factor_terms(v)) for k, v in names.items()
             if k in used and k not in lhs_names and not isinstance(v, sp.Pow)]
    where += [(k, v) for k, v in names.items() if k in used and isinstance(v, sp.Pow)]
    if entry.id == "E1.7":
        where += [(k, v) for k, v in _e1_7_where() if k in used]
        where += list(_vec_rel(sp.symbols("K_x K_y K_z"), _k_compact()))
    if entry.id == "E1.9":
        where = list(_vec_rel(sp.symbols("K_x K_y K_z"), _k_compact()))
    # each name used by a where-line's right-hand side, defined too
    more = set().union(*(sp.sympify(v).free_symbols for _, v in where)) if where else set()
    where += [(k, sp.factor_terms(v)) for k, v in names.items()
              if k in more and k not in used and not isinstance(v, sp.Pow)]
    known = {lhs for lhs, _ in entry.where}
    where = [(k, v) for k, v in where if k not in known]
    if entry.id not in ("E1.9",):
        full = dict(names)
        if entry.id == "E1.7":
            full.update(dict(_e1_7_where()))
            full[sp.Symbol("K_x")], full[sp.Symbol("K_y")], full[sp.Symbol("K_z")] = \
                _k_compact().xreplace(names)
        for (lhs, r_full), (_, r_comp) in zip(entry.relations, relations):
            back = sp.sympify(r_comp)
            for _ in range(3):
                back = back.xreplace(full)
            if not _same(back, r_full):
                raise AssertionError(f"{entry.id}: the compact form of {lhs} differs")
    return Derived(entry.id, entry.title + " (compact)", relations,
                   where=tuple((*entry.where, *where)), note=entry.note)


def _k_compact() -> sp.Matrix:
    from .momentum import angular_momentum
    am = angular_momentum()
    Js = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"J_{i + 1}{j + 1}"))
    return Js * nt.omega + am.own.applyfunc(sp.factor)


def _e1_7_where() -> list:
    """J_ij' (the rates of J along the law) in terms of the law."""
    from .momentum import angular_momentum
    J = angular_momentum().J
    out = []
    for i in range(3):
        for j in range(3):
            rate = nt.freeze(sp.diff(nt.thaw(J[i, j]), nt.t))
            out.append((sp.Symbol(f"J_{i + 1}{j + 1}'"), sp.factor(rate)))
    return out


def _e1_7_compact() -> tuple:
    """E1.3 applied to K = J omega + (K - J omega) with J and K kept by name:
    ``J omega' + J' omega + d/dt (K - J omega) + omega x K = 0``."""
    from .momentum import angular_momentum
    am = angular_momentum()
    Js = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"J_{i + 1}{j + 1}"))
    Jd = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"J_{i + 1}{j + 1}'"))
    own_rate = nt.freeze(sp.diff(nt.thaw(am.own), nt.t)).applyfunc(sp.factor)
    Ks = sp.Matrix(sp.symbols("K_x K_y K_z"))
    residual = Js * nt.omega_dot + Jd * nt.omega + own_rate + nt.cross(nt.omega, Ks)
    return tuple((r, 0) for r in residual)


def render_text(entry: Derived, symbols: bool = True) -> str:
    lines = [f"{entry.id}  {entry.title}"]
    for lhs, rhs in entry.relations:
        lines.append(f"    {_str(lhs)} = {_str(rhs)}")
    for lhs, rhs in entry.where:
        lines.append(f"  where {_str(lhs)} = {_str(rhs)}")
    if entry.note:
        lines.append(f"  ({entry.note})")
    if symbols:
        block = symbols_block(entry)
        if block:
            lines.append("  symbols:")
            lines += block
    return "\n".join(lines)


def _dotted(expr):
    """d/dt of a function of t named like Q_X as the symbol \\dot{Q}_{X} (E1.7's style,
    not \\frac{d}{dt} Q_X(t))."""
    swap = {}
    for d in sp.sympify(expr).atoms(sp.Derivative):
        f = d.expr
        if isinstance(f, sp.core.function.AppliedUndef) and d.variables == (nt.t,):
            base, _, sub = f.func.__name__.partition("_")
            swap[d] = sp.Symbol(rf"\dot{{{base}}}" + (f"_{{{sub}}}" if sub else ""))
    return sp.sympify(expr).xreplace(swap) if swap else expr


def render_latex(entry: Derived) -> str:
    def tex(expr) -> str:
        return sp.latex(_dotted(expr), symbol_names=nt.LATEX_NAMES)
    lines = [f"% {entry.id}: {entry.title}", r"\begin{align}"]
    rows = [f"  {tex(lhs)} &= {tex(rhs)}" for lhs, rhs in entry.relations]
    lines.append(" \\\\\n".join(rows))
    lines.append(r"\end{align}")
    for lhs, rhs in entry.where:
        lines.append(f"% where ${tex(lhs)} = {tex(rhs)}$")
    for line in symbols_block(entry):
        lines.append("% " + line.strip())
    return "\n".join(lines)
