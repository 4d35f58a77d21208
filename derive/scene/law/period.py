"""The common period of laws given as formulas: every sin/cos argument ``k t + c`` with
frequencies commensurate (ratios of small integers), and t nowhere else.  Read by the
stability analysis (its Floquet period, :func:`common_period` of SymPy expressions) and by
a base run's mean velocity per period (:func:`program_period`, from the compiled law's
nodes: a run's summary never imports SymPy)."""
from __future__ import annotations

import math
from fractions import Fraction

from .ops import MATH, OPS


class NotPeriodic(ValueError):
    """``constant``: the laws have no frequency at all; else why they are not periodic."""

    def __init__(self, why: str, constant: bool = False):
        super().__init__(why)
        self.constant = constant


def common_period(exprs) -> float:
    """The least common period of SymPy expressions in ``derive.notation.t``, or
    :class:`NotPeriodic`."""
    import sympy as sp

    from ... import notation as nt
    freqs = set()
    for expr in exprs:
        expr = sp.sympify(expr)
        for atom in expr.atoms(sp.sin, sp.cos):
            arg = sp.expand(atom.args[0])
            k = arg.coeff(nt.t)
            if not k.is_number or (arg - k * nt.t).has(nt.t):
                raise NotPeriodic(f"is not periodic in t ({atom})")
            if k != 0:
                freqs.add(abs(float(k)))
        u = sp.Dummy("u")                    # (not 0: t sin t would lose its t)
        if expr.xreplace({a: u for a in expr.atoms(sp.sin, sp.cos)}).has(nt.t):
            raise NotPeriodic(f"is not periodic in t ({expr})")
    return _period(freqs)


def program_period(programs) -> float:
    """The least common period of the outputs of compiled laws
    (:class:`~.program.Program`), or :class:`NotPeriodic`: :func:`common_period`'s answer
    for their SymPy forms, read from the nodes without SymPy.  Each node is a constant,
    ``k t + c`` (k != 0), periodic (t only inside sin/cos of ``k t + c``; its frequencies)
    or neither; an output that is ``k t + c`` or neither is not periodic.  (One law this
    reads more widely: sin(sin(t)) is periodic here, not to :func:`common_period`.)"""
    freqs: set = set()
    for p in programs:
        forms = _forms(p)
        for node in p.outputs:
            kind, val = forms[node]
            if kind in ("affine", "neither"):
                raise NotPeriodic(f"is not periodic in t ({p.node_text(node)})")
            if kind == "periodic":
                freqs |= val
    return _period(freqs)


def _period(freqs: set) -> float:
    if not freqs:
        raise NotPeriodic("a constant law has no period", constant=True)
    base = min(freqs)
    ratios = [Fraction(f / base).limit_denominator(64) for f in freqs]
    for f, r in zip(freqs, ratios):
        if abs(f / base - float(r)) > 1e-12:
            raise NotPeriodic("has incommensurate frequencies")
    den = math.lcm(*[r.denominator for r in ratios])
    return 2 * math.pi / (base / den)


_NEITHER = ("neither", None)


def _forms(p) -> list:
    """Every node's form: ("const", value), ("affine", (k, c)) for k t + c, ("periodic",
    frequencies) or ("neither", None)."""
    forms: list = []
    for name, a, b in zip(p.ops, p.a, p.b):
        shape = OPS[name].shape
        if shape == "const":
            form = ("const", p.consts[a])
        elif shape == "t":
            form = ("affine", (1.0, 0.0))
        elif shape == "harmonic":
            A, w, ph = p.consts[a:a + 3]
            form = (("periodic", {abs(w)}) if w != 0.0 and A != 0.0 else
                    ("const", A * (math.sin if name == "hsin" else math.cos)(ph)))
        elif shape == "power":
            form = _power(forms[a], p.consts[b])
        elif shape == "binary":
            form = _binary(name, forms[a], forms[b])
        else:
            form = _unary(name, forms[a])
        forms.append(form)
    return forms


def _value(fn, *args) -> float:
    try:
        return float(fn(*args))
    except (ValueError, OverflowError, ZeroDivisionError, TypeError):
        return math.nan


def _affine(k: float, c: float) -> tuple:
    return ("affine", (k, c)) if k != 0.0 else ("const", c)


def _unary(name: str, x: tuple) -> tuple:
    kind, v = x
    if kind == "const":
        return ("const", -v if name == "neg" else _value(MATH[name], v))
    if kind == "affine":
        if name == "neg":
            return ("affine", (-v[0], -v[1]))
        return ("periodic", {abs(v[0])}) if name in ("sin", "cos") else _NEITHER
    return x                                 # periodic or neither, and so f of it


def _power(x: tuple, r: float) -> tuple:
    kind, v = x
    if kind == "const":
        return ("const", _value(pow, v, r))
    if kind == "affine":
        return x if r == 1.0 else ("const", 1.0) if r == 0.0 else _NEITHER
    return x


def _binary(name: str, x: tuple, y: tuple) -> tuple:
    (kx, vx), (ky, vy) = x, y
    if "neither" in (kx, ky):
        return _NEITHER
    if kx == ky == "const":
        fn = {"add": lambda p, q: p + q, "sub": lambda p, q: p - q,
              "mul": lambda p, q: p * q, "div": lambda p, q: p / q, "pow": pow}[name]
        return ("const", _value(fn, vx, vy))
    zero_x, zero_y = (kx == "const" and vx == 0.0), (ky == "const" and vy == 0.0)
    if name in ("add", "sub"):
        s = 1.0 if name == "add" else -1.0
        if kx == "periodic" or ky == "periodic":
            if "affine" in (kx, ky):
                return _NEITHER
            return ("periodic", (vx if kx == "periodic" else set())
                    | (vy if ky == "periodic" else set()))
        (a, c), (b, d) = (vx if kx == "affine" else (0.0, vx)), \
            (vy if ky == "affine" else (0.0, vy))
        return _affine(a + s * b, c + s * d)
    if name == "mul" and (zero_x or zero_y):
        return ("const", 0.0)
    if name == "div" and zero_x and not zero_y:
        return ("const", 0.0)
    if "affine" in (kx, ky):
        if name == "mul" and "const" in (kx, ky):
            k = vx if kx == "const" else vy
            (a, c) = vy if kx == "const" else vx
            return _affine(a * k, c * k)
        if name == "div" and kx == "affine" and ky == "const" and not zero_y:
            return _affine(vx[0] / vy, vx[1] / vy)
        return _NEITHER
    return ("periodic", (vx if kx == "periodic" else set())
            | (vy if ky == "periodic" else set()))
