"""Point laws ``x(t), y(t), z(t)`` given as formulas: parsed by a whitelist, checked over
the whole run, and compiled into a program the C runtime interprets.

A law string never reaches generated source, ``eval`` or SymPy: the parser turns it into
a :class:`Program` (nodes of a few opcodes over a table of float constants), which is
data for the C interpreter (``crt_law.h`` of the runtime: value, first and second
derivative in one pass, forward mode), for NumPy (:meth:`Program.jets`) and, when a
symbolic tool asks, for SymPy (:meth:`Program.sympy`).

Grammar (precedence climbing; ``**`` and ``^`` are right-associative and bind tighter
than unary minus, as in Python)::

    expr   := term (("+" | "-") term)*
    term   := unary (("*" | "/") unary)*
    unary  := ("+" | "-") unary | power
    power  := atom (("**" | "^") unary)?
    atom   := NUMBER | "t" | "pi" | NAME "(" expr ")" | "(" expr ")"

Limits: ASCII only, spaces and tabs as the only white space, at most
:data:`MAX_LENGTH` characters, nesting at most :data:`MAX_DEPTH`, at most
:data:`MAX_NODES` distinct operations per law, integer exponents at most
:data:`MAX_POWER` in size.  Constant subexpressions are evaluated in floats when parsed
and must be finite and real.

Over a run ``[t0, t1]`` (:func:`analyse`) the law must have no singular point: interval
arithmetic over boxes of t, bisected where a box cannot be cleared, proves that no
denominator vanishes, that ``log``, ``sqrt`` and non-integer powers see positive
arguments, ``asin``/``acos`` arguments inside (-1, 1) and ``tan`` no pole.  These are
exactly the conditions under which x, x' and x'' exist and are continuous, so a law
that passes is C^2 on the whole run, not only on a grid of samples.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from .. import layout


MAX_LENGTH = 2000
MAX_DEPTH = 60
MAX_NODES = 300
MAX_POWER = 64

_TOKEN = re.compile(r"""
    (?P<ws>[ \t]+)
  | (?P<number>(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<op>\*\*|[-+*/^()])
""", re.VERBOSE | re.ASCII)


class LawError(ValueError):
    """A law that is malformed, unsafe, or not twice differentiable on the run."""


# ---- the opcodes: one object each --------------------------------------------------------
# What every part of this module knows about an operation is in its Op: how its
# arguments are read (``shape``), its value and two derivatives (``jet``, written once
# for NumPy arrays and for floats through a namespace of functions), its enclosure over
# an interval of values (``interval``), its text, its SymPy form, and where it may be
# singular.  The C interpreter (crt_law.h) implements the same list, numbered by
# derive.abi.OPCODES (a test keeps the two lists equal).
#
# shape: "const" (a = index into consts), "t", "harmonic" (a = first of A, w, p in
# consts), "unary" (a = node), "binary" (a, b = nodes), "power" (a = node, b = index of
# the exponent in consts).

class _Floats:
    """The functions of a jet on floats: a value that does not exist raises (ValueError,
    OverflowError, ZeroDivisionError), which :meth:`Program.point` turns into NaN."""
    sin, cos, tan, exp, log, sqrt = math.sin, math.cos, math.tan, math.exp, math.log, math.sqrt
    sinh, cosh, tanh = math.sinh, math.cosh, math.tanh
    arcsin, arccos, arctan = math.asin, math.acos, math.atan
    power = staticmethod(math.pow)


class _Arrays:
    """The same functions on NumPy arrays (NaN or inf where a value does not exist)."""
    sin, cos, tan, exp, log, sqrt = np.sin, np.cos, np.tan, np.exp, np.log, np.sqrt
    sinh, cosh, tanh = np.sinh, np.cosh, np.tanh
    arcsin, arccos, arctan = np.arcsin, np.arccos, np.arctan
    power = staticmethod(np.power)


def _chain(f0, f1, f2, x):
    """The jet of f(x) from f, f', f'' at x's value and x's jet."""
    _, dx, ddx = x
    return f0, f1 * dx, f2 * dx * dx + f1 * ddx


def _jet_unary(fn):
    """The jet rule of a function from its value and two derivatives, f(xp, x) ->
    (f, f', f'')."""
    def jet(xp, x, y, r):
        return _chain(*fn(xp, x[0]), x)
    return jet


def _sin(xp, v):
    s, c = xp.sin(v), xp.cos(v)
    return s, c, -s


def _cos(xp, v):
    s, c = xp.sin(v), xp.cos(v)
    return c, -s, -c


def _tan(xp, v):
    tn = xp.tan(v)
    sec2 = 1.0 + tn * tn
    return tn, sec2, 2.0 * tn * sec2


def _exp(xp, v):
    e = xp.exp(v)
    return e, e, e


def _log(xp, v):
    r = 1.0 / v
    return xp.log(v), r, -r * r


def _sqrt(xp, v):
    s = xp.sqrt(v)
    return s, 0.5 / s, -0.25 / (s * v)


def _sinh(xp, v):
    s, c = xp.sinh(v), xp.cosh(v)
    return s, c, s


def _cosh(xp, v):
    s, c = xp.sinh(v), xp.cosh(v)
    return c, s, c


def _tanh(xp, v):
    th = xp.tanh(v)
    d = 1.0 - th * th
    return th, d, -2.0 * th * d


def _asin(xp, v):
    w = 1.0 - v * v
    r = 1.0 / xp.sqrt(w)
    return xp.arcsin(v), r, v * r / w


def _acos(xp, v):
    w = 1.0 - v * v
    r = 1.0 / xp.sqrt(w)
    return xp.arccos(v), -r, -v * r / w


def _atan(xp, v):
    w = 1.0 / (1.0 + v * v)
    return xp.arctan(v), w, -2.0 * v * w * w


def _jet_add(xp, x, y, r):
    return x[0] + y[0], x[1] + y[1], x[2] + y[2]


def _jet_sub(xp, x, y, r):
    return x[0] - y[0], x[1] - y[1], x[2] - y[2]


def _jet_neg(xp, x, y, r):
    return -x[0], -x[1], -x[2]


def _jet_mul(xp, x, y, r):
    return (x[0] * y[0], x[1] * y[0] + x[0] * y[1],
            x[2] * y[0] + 2.0 * x[1] * y[1] + x[0] * y[2])


def _jet_div(xp, x, y, r):
    q = x[0] / y[0]
    dq = (x[1] - q * y[1]) / y[0]
    return q, dq, (x[2] - 2.0 * dq * y[1] - q * y[2]) / y[0]


def _jet_powr(xp, x, y, r):
    """x ** r for a constant exponent r (an integer for powi)."""
    p2 = xp.power(x[0], r - 2.0)
    p1 = p2 * x[0]
    return _chain(p1 * x[0], r * p1, r * (r - 1.0) * p2, x)


def _jet_pow(xp, x, y, r):
    """x ** y = exp(y log x), x > 0."""
    lx = xp.log(x[0])
    e = xp.exp(y[0] * lx)
    # d(y ln x) = dy ln x + y dx/x; second derivative of the exponent
    u1 = y[1] * lx + y[0] * x[1] / x[0]
    u2 = y[2] * lx + 2.0 * y[1] * x[1] / x[0] + y[0] * (x[2] / x[0] - x[1] * x[1] / (x[0] * x[0]))
    return e, e * u1, e * (u2 + u1 * u1)


def harmonic_jet(op, A, w, p, sin, cos, t):
    """A sin(w t + p) (hsin) or A cos(w t + p) (hcos) and its two derivatives."""
    th = w * t + p
    sv, cv = sin(th), cos(th)
    if op == "hsin":
        return A * sv, (A * w) * cv, -(A * w * w) * sv
    return A * cv, -(A * w) * sv, -(A * w * w) * cv


# ---- enclosures over intervals of values (NumPy arrays of boxes) -------------------------
_HALF_PI = 0.5 * math.pi


def _none(n):
    return np.zeros(n, dtype=bool)


def _iv_add(x, y, r):
    return x[0] + y[0], x[1] + y[1], _none(x[0].shape[0])


def _iv_sub(x, y, r):
    return x[0] - y[1], x[1] - y[0], _none(x[0].shape[0])


def _iv_neg(x, y, r):
    return -x[1], -x[0], _none(x[0].shape[0])


def _iv_mul(x, y, r):
    c = np.stack([x[0] * y[0], x[0] * y[1], x[1] * y[0], x[1] * y[1]])
    c = np.where(np.isnan(c), 0.0, c)            # 0 * inf
    return c.min(0), c.max(0), _none(x[0].shape[0])


def _iv_div(x, y, r):
    flag = (y[0] <= 0.0) & (y[1] >= 0.0)
    rlo = np.where(flag, 1.0, 1.0 / np.where(flag, 1.0, y[1]))
    rhi = np.where(flag, 1.0, 1.0 / np.where(flag, 1.0, y[0]))
    c = np.stack([x[0] * rlo, x[0] * rhi, x[1] * rlo, x[1] * rhi])
    c = np.where(np.isnan(c), 0.0, c)
    return np.where(flag, -np.inf, c.min(0)), np.where(flag, np.inf, c.max(0)), flag


def _iv_powi(x, y, r):
    alo, ahi = x
    nexp = int(r)
    flag = (alo <= 0.0) & (ahi >= 0.0) if nexp < 0 else _none(alo.shape[0])
    p_lo, p_hi = alo ** float(nexp), ahi ** float(nexp)
    if nexp % 2 == 0:
        straddle = (alo < 0.0) & (ahi > 0.0)
        rlo = np.where(straddle, 0.0 if nexp > 0 else -np.inf, np.minimum(p_lo, p_hi))
        rhi = np.where(straddle, np.maximum(p_lo, p_hi) if nexp > 0 else np.inf,
                       np.maximum(p_lo, p_hi))
        if nexp < 0:
            rlo = np.where(flag, 0.0, rlo)
            rhi = np.where(flag, np.inf, rhi)
        return rlo, rhi, flag
    if nexp < 0:
        return (np.where(flag, -np.inf, np.minimum(p_lo, p_hi)),
                np.where(flag, np.inf, np.maximum(p_lo, p_hi)), flag)
    return p_lo, p_hi, flag


def _positive(x):
    """The box clipped to positive values and the flag where it reaches 0 or below."""
    flag = x[0] <= 0.0
    safe_lo = np.where(flag, 1e-300, x[0])
    return safe_lo, np.maximum(x[1], safe_lo), flag


def _iv_log(x, y, r):
    lo, hi, flag = _positive(x)
    return np.log(lo), np.log(hi), flag


def _iv_sqrt(x, y, r):
    lo, hi, flag = _positive(x)
    return np.sqrt(lo), np.sqrt(hi), flag


def _iv_powr(x, y, r):
    lo, hi, flag = _positive(x)
    c = np.stack([lo ** r, hi ** r])
    return c.min(0), c.max(0), flag


def _iv_pow(x, y, r):
    lo, hi, flag = _positive(x)
    llo, lhi = np.log(lo), np.log(hi)
    c = np.stack([llo * y[0], llo * y[1], lhi * y[0], lhi * y[1]])
    c = np.where(np.isnan(c), 0.0, c)
    return np.exp(c.min(0)), np.exp(c.max(0)), flag


def _iv_sine(shift):
    def enclose(x, y, r):
        x0, x1 = x[0] + shift, x[1] + shift
        wide = ~np.isfinite(x0) | ~np.isfinite(x1) | (x1 - x0 >= 2 * math.pi)
        x0s, x1s = np.where(wide, 0.0, x0), np.where(wide, 0.0, x1)
        s0, s1 = np.sin(x0s), np.sin(x1s)
        # maxima at pi/2 + 2k pi, minima at -pi/2 + 2k pi
        kmax = np.ceil((x0s - _HALF_PI) / (2 * math.pi))
        has_max = _HALF_PI + 2 * math.pi * kmax <= x1s
        kmin = np.ceil((x0s + _HALF_PI) / (2 * math.pi))
        has_min = -_HALF_PI + 2 * math.pi * kmin <= x1s
        rlo = np.where(has_min | wide, -1.0, np.minimum(s0, s1))
        rhi = np.where(has_max | wide, 1.0, np.maximum(s0, s1))
        return rlo, rhi, _none(x[0].shape[0])
    return enclose


def _iv_tan(x, y, r):
    alo, ahi = x
    wide = ~np.isfinite(alo) | ~np.isfinite(ahi) | (ahi - alo >= math.pi)
    lo_s, hi_s = np.where(wide, 0.0, alo), np.where(wide, 0.0, ahi)
    k = np.ceil((lo_s - _HALF_PI) / math.pi)
    flag = wide | (_HALF_PI + math.pi * k <= hi_s)
    return (np.where(flag, -np.inf, np.tan(lo_s)), np.where(flag, np.inf, np.tan(hi_s)), flag)


def _iv_asin(x, y, r):
    flag = (x[0] <= -1.0) | (x[1] >= 1.0)
    return np.arcsin(np.clip(x[0], -1.0, 1.0)), np.arcsin(np.clip(x[1], -1.0, 1.0)), flag


def _iv_acos(x, y, r):
    flag = (x[0] <= -1.0) | (x[1] >= 1.0)
    return np.arccos(np.clip(x[1], -1.0, 1.0)), np.arccos(np.clip(x[0], -1.0, 1.0)), flag


def _iv_cosh(x, y, r):
    straddle = (x[0] < 0.0) & (x[1] > 0.0)
    c0, c1 = np.cosh(x[0]), np.cosh(x[1])
    return np.where(straddle, 1.0, np.minimum(c0, c1)), np.maximum(c0, c1), \
        _none(x[0].shape[0])


def _iv_increasing(fn):
    def enclose(x, y, r):
        return fn(x[0]), fn(x[1]), _none(x[0].shape[0])
    return enclose


@dataclass(frozen=True)
class Op:
    name: str
    shape: str                 # const | t | harmonic | unary | binary | power
    jet: Any = None            # (xp, x, y, r) -> (value, d/dt, d2/dt2); x, y jets, r a const
    interval: Any = None       # (x, y, r) -> (lo, hi, may-be-singular flag)
    sympy: Any = None          # (sp, x, y) -> expression (unary, binary)
    infix: str = ""            # binary: the operator's text
    singular: str = ""         # where it may be singular: the message
    entire: bool = True        # no singular point whatever its argument (powi: if r > 0)

    @property
    def reads_b(self) -> bool:
        return self.shape == "binary"

    @property
    def leaf(self) -> bool:
        return self.shape in ("const", "t", "harmonic")


def _fn(name, jet_fn, interval, sympy_name, singular=""):
    return Op(name, "unary", _jet_unary(jet_fn), interval,
              lambda sp, x, y: getattr(sp, sympy_name)(x), singular=singular,
              entire=not singular)


OPS = {op.name: op for op in (
    Op("const", "const"),
    Op("t", "t"),
    Op("add", "binary", _jet_add, _iv_add, lambda sp, x, y: x + y, infix=" + "),
    Op("sub", "binary", _jet_sub, _iv_sub, lambda sp, x, y: x - y, infix=" - "),
    Op("mul", "binary", _jet_mul, _iv_mul, lambda sp, x, y: x * y, infix="*"),
    Op("div", "binary", _jet_div, _iv_div, lambda sp, x, y: x / y, infix="/",
       singular="a division by zero", entire=False),
    Op("neg", "unary", _jet_neg, _iv_neg, lambda sp, x, y: -x),
    Op("powi", "power", _jet_powr, _iv_powi, singular="a division by zero", entire=False),
    Op("powr", "power", _jet_powr, _iv_powr, singular="a power of a non-positive number",
       entire=False),
    Op("pow", "binary", _jet_pow, _iv_pow, lambda sp, x, y: x ** y,
       singular="a power of a non-positive number", entire=False),
    _fn("sin", _sin, _iv_sine(0.0), "sin"),
    _fn("cos", _cos, _iv_sine(_HALF_PI), "cos"),
    _fn("tan", _tan, _iv_tan, "tan", "a pole of tan"),
    _fn("exp", _exp, _iv_increasing(np.exp), "exp"),
    _fn("log", _log, _iv_log, "log", "log of a non-positive number"),
    _fn("sqrt", _sqrt, _iv_sqrt, "sqrt", "sqrt of a non-positive number (not twice "
        "differentiable where it reaches 0)"),
    _fn("sinh", _sinh, _iv_increasing(np.sinh), "sinh"),
    _fn("cosh", _cosh, _iv_cosh, "cosh"),
    _fn("tanh", _tanh, _iv_increasing(np.tanh), "tanh"),
    _fn("asin", _asin, _iv_asin, "asin", "asin outside (-1, 1)"),
    _fn("acos", _acos, _iv_acos, "acos", "acos outside (-1, 1)"),
    _fn("atan", _atan, _iv_increasing(np.arctan), "atan"),
    Op("hsin", "harmonic"),
    Op("hcos", "harmonic"),
)}
FUNCTIONS = tuple(name for name, op in OPS.items() if op.shape == "unary" and name != "neg")
_MATH = {name: getattr(_Floats, {"asin": "arcsin", "acos": "arccos", "atan": "arctan"}
                       .get(name, name)) for name in FUNCTIONS}


# ---- the program -------------------------------------------------------------------------
@dataclass(eq=False)
class Program:
    """Nodes in topological order: ``ops[k]`` with arguments ``a[k]``, ``b[k]`` (node
    indices, or for ``const``/``powi``/``powr`` an index into ``consts``); the nodes
    ``outputs`` are x, y, z.  Constant nodes come first, then ``t``, then the rest."""
    kind = "program"
    ops: tuple
    a: tuple
    b: tuple
    consts: tuple
    outputs: tuple
    text: tuple = ()                       # the three source strings
    _sympy: tuple | None = field(default=None, repr=False, compare=False)

    def is_zero(self, k: int) -> bool:
        node = self.outputs[k]
        return self.ops[node] == "const" and self.consts[self.a[node]] == 0.0

    def is_constant(self, k: int) -> bool:
        return self.ops[self.outputs[k]] == "const"

    def constant(self, k: int) -> float:
        node = self.outputs[k]
        return self.consts[self.a[node]] if self.ops[node] == "const" else math.nan

    def _jets(self, xp, t, one, zero) -> list:
        """Every node's jet: (value, d/dt, d2/dt2) in the arithmetic of ``xp``."""
        val: list = [None] * len(self.ops)
        consts = self.consts
        for k, name in enumerate(self.ops):
            a, b = self.a[k], self.b[k]
            op = OPS[name]
            if op.shape == "const":
                val[k] = (consts[a] * one, zero, zero)
            elif op.shape == "t":
                val[k] = (t, one, zero)
            elif op.shape == "harmonic":
                val[k] = harmonic_jet(name, *consts[a:a + 3], xp.sin, xp.cos, t)
            elif op.shape == "power":
                val[k] = op.jet(xp, val[a], None, consts[b])
            else:
                val[k] = op.jet(xp, val[a], val[b] if op.reads_b else None, 0.0)
        return val

    def jets(self, ts) -> np.ndarray:
        """(9, N): x, x', x'', y, y', y'', z, z', z'' at the times ``ts``."""
        ts = np.asarray(ts, dtype=float).reshape(-1)
        n = ts.size
        with np.errstate(all="ignore"):
            val = self._jets(_Arrays, ts, np.ones(n), np.zeros(n))
        out = []
        for node in self.outputs:
            out.extend(np.broadcast_to(v, (n,)) for v in val[node])
        return np.array(out)

    def point(self, t: float) -> np.ndarray:
        """u = (x, y, z, x', y', z', x'', y'', z'') at one time (float arithmetic: for a
        single point this is faster than :meth:`jets`; NaN where a value does not
        exist)."""
        out = np.empty(9)
        try:
            val = self._jets(_Floats, float(t), 1.0, 0.0)
        except (ValueError, OverflowError, ZeroDivisionError):
            out[:] = math.nan
            return out
        for c, node in enumerate(self.outputs):
            out[c], out[3 + c], out[6 + c] = val[node]
        return out

    # -- for the C interpreter -----------------------------------------------------------
    def arrays(self) -> dict:
        """int32 ``code`` rows (op, a, b) and float64 ``consts`` for the runtime."""
        from .. import abi
        code = np.array([[abi.OP[op], a, b] for op, a, b in zip(self.ops, self.a, self.b)],
                        dtype=np.int32).reshape(-1, 3)
        n_const = sum(1 for op in self.ops if op == "const")
        return {"code": np.ascontiguousarray(code),
                "consts": np.ascontiguousarray(self.consts or (0.0,), dtype=float),
                "outputs": np.array(self.outputs, dtype=np.int32), "n_const": n_const}

    # -- text and SymPy ----------------------------------------------------------------------
    def node_text(self, k: int, depth: int = 0) -> str:
        name, a, b = self.ops[k], self.a[k], self.b[k]
        op = OPS[name]
        if depth > 12:
            return "..."
        if op.shape == "const":
            return f"{self.consts[a]:.15g}"
        if op.shape == "t":
            return "t"
        if op.shape == "harmonic":
            A, w, ph = self.consts[a:a + 3]
            return f"{A:.15g}*{name[1:]}({w:.15g}*t + {ph:.15g})"
        x = self.node_text(a, depth + 1)
        if op.shape == "power":
            return f"{x}**{self.consts[b]:.15g}"
        if name == "pow":
            return f"{x}**{self.node_text(b, depth + 1)}"
        if op.infix:
            return f"({x}{op.infix}{self.node_text(b, depth + 1)})"
        if name == "neg":
            return f"-{x}"
        return f"{name}({x})"

    def sympy(self) -> tuple:
        """The three coordinates as SymPy expressions in ``derive.notation.t`` (for the
        symbolic tools; the runtime never needs this)."""
        if self._sympy is None:
            self._sympy = _to_sympy(self)
        return self._sympy

    def arguments(self, k: int) -> tuple:
        """The nodes node ``k`` reads."""
        op = OPS[self.ops[k]]
        if op.leaf:
            return ()
        return (self.a[k], self.b[k]) if op.reads_b else (self.a[k],)

    def coordinate_of(self, node: int) -> int:
        """The first coordinate whose expression uses ``node``."""
        for k, out in enumerate(self.outputs):
            if node in _reachable(self, out):
                return k
        return 0


def _reachable(p: Program, root: int) -> set:
    seen, stack = set(), [root]
    while stack:
        k = stack.pop()
        if k not in seen:
            seen.add(k)
            stack.extend(p.arguments(k))
    return seen


def _to_sympy(p: Program) -> tuple:
    import sympy as sp
    from .. import notation as nt

    def number(c: float):
        if c == math.pi:
            return sp.pi
        return sp.Integer(int(c)) if c == int(c) and abs(c) < 2 ** 53 else sp.Float(repr(c), 17)
    val: list = []
    for name, a, b in zip(p.ops, p.a, p.b):
        op = OPS[name]
        if op.shape == "const":
            v = number(p.consts[a])
        elif op.shape == "t":
            v = nt.t
        elif op.shape == "harmonic":
            A, w, ph = (sp.Float(repr(c), 17) for c in p.consts[a:a + 3])
            v = A * (sp.sin if name == "hsin" else sp.cos)(w * nt.t + ph)
        elif op.shape == "power":
            r = p.consts[b]
            v = val[a] ** (sp.Integer(int(r)) if name == "powi" else sp.Float(repr(r), 17))
        else:
            v = op.sympy(sp, val[a], val[b] if op.reads_b else None)
        val.append(v)
    return tuple(val[k] for k in p.outputs)


# ---- building: hash-consing, constant folding --------------------------------------------
class _Builder:
    def __init__(self):
        self.nodes: list = []          # (op, a, b)
        self.value: list = []          # float for constant nodes, else None
        self.consts: list = []
        self.index: dict = {}
        self.const_index: dict = {}
        self.affine: dict = {}         # node -> (w, p): the node is w t + p
        self.harmonic: dict = {}       # node -> (op, A, w, p): A sin|cos(w t + p)

    def _node(self, op, a, b, value=None) -> int:
        key = (op, a, b)
        k = self.index.get(key)
        if k is None:
            k = len(self.nodes)
            if k >= MAX_NODES:
                raise LawError(f"has more than {MAX_NODES} distinct operations")
            self.nodes.append(key)
            self.value.append(value)
            self.index[key] = k
        return k

    def _cidx(self, v: float) -> int:
        key = float(v).hex()
        if key not in self.const_index:
            self.const_index[key] = len(self.consts)
            self.consts.append(float(v))
        return self.const_index[key]

    def const(self, v: float, what: str = "a constant subexpression") -> int:
        if isinstance(v, complex) or not math.isfinite(v):
            raise LawError(f"{what} is not a finite real number")
        v = float(v) + 0.0                    # -0.0 -> 0.0
        return self._node("const", self._cidx(v), 0, v)

    def t(self) -> int:
        k = self._node("t", 0, 0)
        self.affine[k] = (1.0, 0.0)
        return k

    def _harmonic(self, op: str, A: float, w: float, p: float) -> int:
        """A harmonic as one node (the interpreter's superinstruction): A sin(w t + p) and
        its two derivatives from one sine and cosine, instead of four nodes."""
        if A == 0.0:
            return self.const(0.0)
        k = self._node(op, float(A).hex(), (float(w).hex(), float(p).hex()))
        self.harmonic[k] = (op, float(A), float(w), float(p))
        return k

    def _fused(self, op: str, a: int, b: int) -> int | None:
        """Harmonics and affine arguments recognised while building: c*(w t + p),
        (w t + p) + c, c*A sin(...), -A sin(...)."""
        va, vb = self.value[a], self.value[b]
        if op == "mul":
            c, x = (va, b) if va is not None else (vb, a) if vb is not None else (None, None)
            if c is None:
                return None
            if x in self.harmonic:
                h, A, w, p = self.harmonic[x]
                return self._harmonic(h, c * A, w, p)
            if x in self.affine:
                w, p = self.affine[x]
                k = self._node("mul", *sorted((a, b)))
                self.affine[k] = (c * w, c * p)
                return k
        elif op == "div" and vb is not None and a in self.affine:
            w, p = self.affine[a]
            k = self._node("div", a, b)
            self.affine[k] = (w / vb, p / vb)
            return k
        elif op in ("add", "sub"):
            if a in self.affine and vb is not None:
                w, p = self.affine[a]
                k = self._node(op, a, b)
                self.affine[k] = (w, p + vb if op == "add" else p - vb)
                return k
            if b in self.affine and va is not None:
                w, p = self.affine[b]
                k = self._node(op, *((a, b) if op == "sub" else sorted((a, b))))
                self.affine[k] = (w, va + p) if op == "add" else (-w, va - p)
                return k
        return None

    def is_const(self, k: int, v: float | None = None) -> bool:
        x = self.value[k]
        return x is not None and (v is None or x == v)

    def binary(self, op: str, a: int, b: int, text) -> int:
        va, vb = self.value[a], self.value[b]
        if va is not None and vb is not None:
            try:
                r = {"add": va + vb, "sub": va - vb, "mul": va * vb}[op] if op != "div" \
                    else va / vb
            except ZeroDivisionError:
                raise LawError(f"divides by zero in {text()}") from None
            return self.const(r, f"{text()}")
        if op == "add":
            if self.is_const(a, 0.0):
                return b
            if self.is_const(b, 0.0):
                return a
        elif op == "sub":
            if a == b:
                return self.const(0.0)
            if self.is_const(b, 0.0):
                return a
            if self.is_const(a, 0.0):
                return self._node("neg", b, 0)
        elif op == "mul":
            if self.is_const(a, 1.0):
                return b
            if self.is_const(b, 1.0):
                return a
            if self.is_const(a, -1.0):
                return self.neg(b)
            if self.is_const(b, -1.0):
                return self.neg(a)
        elif op == "div":
            if self.is_const(b, 0.0):
                raise LawError(f"divides by zero in {text()}")
            if self.is_const(b, 1.0):
                return a
        fused = self._fused(op, a, b)
        if fused is not None:
            return fused
        if op in ("add", "mul") and b < a:
            a, b = b, a                       # commutative: one canonical order
        return self._node(op, a, b)

    def neg(self, a: int) -> int:
        if self.value[a] is not None:
            return self.const(-self.value[a])
        op, x, _ = self.nodes[a]
        if op == "neg":
            return x
        if a in self.harmonic:
            h, A, w, p = self.harmonic[a]
            return self._harmonic(h, -A, w, p)
        return self._node("neg", a, 0)

    def call(self, name: str, a: int, text) -> int:
        va = self.value[a]
        if va is not None:
            try:
                r = _MATH[name](va)
            except (ValueError, OverflowError):
                raise LawError(f"{text()} is not a finite real number") from None
            return self.const(r, text())
        if name in ("sin", "cos") and a in self.affine:
            w, p = self.affine[a]
            return self._harmonic("hsin" if name == "sin" else "hcos", 1.0, w, p)
        return self._node(name, a, 0)

    def power(self, a: int, b: int, text) -> int:
        va, vb = self.value[a], self.value[b]
        if vb is not None and abs(vb) > MAX_POWER:
            raise LawError(f"exponent {vb:g} in {text()} is larger than {MAX_POWER} in size")
        if va is not None and vb is not None:
            try:
                r = math.pow(va, vb)
            except (ValueError, OverflowError, ZeroDivisionError):
                raise LawError(f"{text()} is not a finite real number") from None
            return self.const(r, text())
        if vb is not None:
            if vb == 1.0:
                return a
            if vb == 0.0:
                return self.const(1.0)
            if vb == int(vb):
                return self._node("powi", a, self._cidx(vb))
            return self._node("powr", a, self._cidx(vb))
        return self._node("pow", a, b)

    def program(self, outputs: tuple, text: tuple) -> Program:
        """Prune to what the outputs use and renumber: constants, t, then the rest."""
        used = set()
        stack = list(outputs)
        while stack:
            k = stack.pop()
            if k in used:
                continue
            used.add(k)
            op, a, b = self.nodes[k]
            shape = OPS[op].shape
            if shape in ("unary", "binary", "power"):
                stack.append(a)
            if shape == "binary":
                stack.append(b)
        order = sorted(used, key=lambda k: (self.nodes[k][0] != "const",
                                            self.nodes[k][0] != "t", k))
        new = {k: i for i, k in enumerate(order)}
        consts, cnew = [], {}

        def cref(c):
            if c not in cnew:
                cnew[c] = len(consts)
                consts.append(self.consts[c])
            return cnew[c]
        ops, aa, bb = [], [], []
        for k in order:
            op, a, b = self.nodes[k]
            ops.append(op)
            shape = OPS[op].shape
            if shape == "const":
                ref = (cref(a), 0)
            elif shape == "t":
                ref = (0, 0)
            elif shape == "power":
                ref = (new[a], cref(b))
            elif shape == "harmonic":
                ref = (len(consts), 0)
                consts.extend(self.harmonic[k][1:])          # A, w, p consecutive
            elif shape == "binary":
                ref = (new[a], new[b])
            else:
                ref = (new[a], 0)
            aa.append(ref[0])
            bb.append(ref[1])
        return Program(tuple(ops), tuple(aa), tuple(bb), tuple(consts),
                       tuple(new[k] for k in outputs), text)


# ---- parsing -----------------------------------------------------------------------------
def _tokens(text: str) -> list:
    out, pos = [], 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m:
            ch = text[pos]
            shown = repr(ch) if ch.isprintable() and ch.isascii() else f"U+{ord(ch):04X}"
            raise LawError(f"unexpected character {shown} at position {pos + 1} (laws are "
                           "ASCII: digits 0-9, t, pi, + - * / ** ^ ( ) and "
                           f"{', '.join(FUNCTIONS)})")
        kind = m.lastgroup
        if kind != "ws":
            out.append((kind, m.group(), pos + 1, m.end()))
        pos = m.end()
    return out


class _Parser:
    def __init__(self, text: str, builder: _Builder):
        self.src = text
        self.tokens = _tokens(text)
        self.i = 0
        self.depth = 0
        self.b = builder

    def peek(self):
        return self.tokens[self.i] if self.i < len(self.tokens) else ("end", "", -1, -1)

    def take(self, value=None):
        tok = self.peek()
        if value is not None and tok[1] != value:
            where = f"position {tok[2]}" if tok[2] > 0 else "the end"
            raise LawError(f"expected {value!r} at {where}")
        self.i += 1
        return tok

    def deeper(self):
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise LawError(f"is nested deeper than {MAX_DEPTH} levels")

    def span(self, start: int):
        """A callable giving the source text from token ``start`` to the current one
        (only built when a message needs it)."""
        end = self.i
        def text():
            lo = self.tokens[start][2] - 1
            hi = self.tokens[end - 1][3] if end > start else lo
            s = self.src[lo:hi].strip()
            return repr(s if len(s) <= 60 else s[:57] + "...")
        return text

    def expr(self) -> int:
        self.deeper()
        start = self.i
        left = self.term()
        while self.peek()[1] in ("+", "-"):
            op = self.take()[1]
            right = self.term()
            left = self.b.binary("add" if op == "+" else "sub", left, right, self.span(start))
        self.depth -= 1
        return left

    def term(self) -> int:
        start = self.i
        left = self.unary()
        while self.peek()[1] in ("*", "/"):
            op = self.take()[1]
            right = self.unary()
            left = self.b.binary("mul" if op == "*" else "div", left, right, self.span(start))
        return left

    def unary(self) -> int:
        if self.peek()[1] in ("+", "-"):
            op = self.take()[1]
            self.deeper()
            value = self.unary()
            self.depth -= 1
            return value if op == "+" else self.b.neg(value)
        return self.power()

    def power(self) -> int:
        start = self.i
        base = self.atom()
        if self.peek()[1] in ("**", "^"):
            self.take()
            self.deeper()
            exponent = self.unary()
            self.depth -= 1
            return self.b.power(base, exponent, self.span(start))
        return base

    def atom(self) -> int:
        kind, value, pos, _ = self.peek()
        start = self.i
        if kind == "number":
            self.take()
            number = float(value)
            if not math.isfinite(number):
                raise LawError(f"number {value!r} at position {pos} is not finite")
            if number == 0.0 and re.search(r"[1-9]", value.split("e")[0].split("E")[0]):
                raise LawError(f"number {value!r} at position {pos} underflows to zero")
            if 0.0 < abs(number) < 2.2250738585072014e-308:
                raise LawError(f"number {value!r} at position {pos} is subnormal")
            return self.b.const(number)
        if kind == "name":
            self.take()
            if value == "t":
                return self.b.t()
            if value == "pi":
                return self.b.const(math.pi)
            if value in FUNCTIONS:
                self.take("(")
                self.deeper()
                arg = self.expr()
                self.depth -= 1
                self.take(")")
                return self.b.call(value, arg, self.span(start))
            allowed = ", ".join(["t", "pi", *FUNCTIONS])
            shown = value if len(value) <= 20 else value[:17] + "..."
            raise LawError(f"unknown name {shown!r} at position {pos} (allowed: {allowed})")
        if value == "(":
            self.take()
            inner = self.expr()
            self.take(")")
            return inner
        where = f"position {pos}" if pos > 0 else "the end"
        raise LawError(f"expected a number, t, a function or '(' at {where}")


def parse_one(text: str, builder: _Builder) -> int:
    if not isinstance(text, str):
        raise LawError("must be a string")
    if len(text) > MAX_LENGTH:
        raise LawError(f"is longer than {MAX_LENGTH} characters ({len(text)})")
    if not text.strip():
        raise LawError("is empty")
    parser = _Parser(text, builder)
    node = parser.expr()
    if parser.i != len(parser.tokens):
        _, tok, pos, _ = parser.peek()
        raise LawError(f"unexpected {tok!r} at position {pos}")
    return node


class CoordinateError(LawError):
    """A :class:`LawError` in coordinate ``k`` of the law."""

    def __init__(self, k: int, message: str):
        super().__init__(message)
        self.k = k


@lru_cache(maxsize=512)
def compile_law(texts: tuple) -> Program:
    """The program of a law given as three strings (cached by the text)."""
    if len(texts) != 3:
        raise LawError("must be three strings: x(t), y(t), z(t)")
    b = _Builder()
    outs = []
    for k, text in enumerate(texts):
        try:
            outs.append(parse_one(text, b))
        except CoordinateError:
            raise
        except LawError as exc:
            raise CoordinateError(k, str(exc)) from None
    return b.program(tuple(outs), tuple(texts))


def parse_law(text: str) -> Program:
    """One coordinate as a program (x = the law, y = z = 0): for tests and tools."""
    return compile_law((text, "0", "0"))


# ---- the whole run: interval arithmetic --------------------------------------------------
MAX_BOXES = 512
# a harmonic node's enclosure over a box of t: the sine's of its argument's box
_SINE = {"hsin": _iv_sine(0.0), "hcos": _iv_sine(_HALF_PI)}


@dataclass(frozen=True)
class Singularity:
    coordinate: int
    t: float
    what: str


def shortest_in(lo: float, hi: float) -> float:
    """The number of fewest significant digits in [lo, hi] (0 when the box holds it): a
    singular point is reported as 0 or 1.5, not as the middle of the last box,
    4.54747351e-12 or 1.50000000000023."""
    lo, hi = float(lo), float(hi)
    if lo <= 0.0 <= hi:
        return 0.0
    mid = 0.5 * (lo + hi)
    for digits in range(1, 18):
        x = float(f"{mid:.{digits}g}")
        if lo <= x <= hi:
            return x
    return mid


def _entire(p: Program) -> bool:
    """Every node is an entire function of t (nothing to prove)."""
    return all(OPS[name].entire or (name == "powi" and p.consts[p.b[k]] > 0)
               for k, name in enumerate(p.ops))


def find_singularity(p: Program, t0: float, t1: float) -> Singularity | None:
    """The earliest point of [t0, t1] near which the law may not be twice continuously
    differentiable, or None when interval arithmetic proves it is everywhere.  A box is
    bisected while some node may be singular in it; a box narrower than 1e-12 of the run
    (or 1e-300) that still may be singular is reported."""
    if _entire(p):
        return None
    ops = p.ops
    width_min = max(1e-12 * (t1 - t0), 1e-12 * max(abs(t0), abs(t1)), 1e-300)
    edges = np.linspace(t0, t1, 65)
    lo_t, hi_t = edges[:-1], edges[1:]
    with np.errstate(all="ignore"):
        for _ in range(200):
            n = lo_t.size
            box: list = [None] * len(ops)
            bad = np.zeros(n, dtype=bool)
            first_bad = np.full(n, -1)
            for k, name in enumerate(ops):
                op = OPS[name]
                a, b = p.a[k], p.b[k]
                if op.shape == "const":
                    box[k] = (np.full(n, p.consts[a]),) * 2
                    continue
                if op.shape == "t":
                    box[k] = (lo_t, hi_t)
                    continue
                if op.shape == "harmonic":      # A sin(w t + p) (cos: p + pi/2) on the box
                    A, w, ph = p.consts[a:a + 3]
                    arg = (w * lo_t + ph, w * hi_t + ph) if w >= 0 else \
                        (w * hi_t + ph, w * lo_t + ph)
                    s_lo, s_hi, _ = _SINE[name](arg, None, 0.0)
                    box[k] = (A * s_lo, A * s_hi) if A >= 0 else (A * s_hi, A * s_lo)
                    continue
                lo, hi, flag = op.interval(box[a], box[b] if op.reads_b else None,
                                           p.consts[b] if op.shape == "power" else 0.0)
                box[k] = (lo, hi)
                new = flag & ~bad
                first_bad[new] = k
                bad |= flag
            if not bad.any():
                return None
            idx = np.flatnonzero(bad)
            narrow = idx[(hi_t[idx] - lo_t[idx]) <= width_min]
            if narrow.size:
                j = narrow[0]
                node = int(first_bad[j])
                return Singularity(p.coordinate_of(node), shortest_in(lo_t[j], hi_t[j]),
                                   OPS[ops[node]].singular or "a singular point")
            idx = idx[:MAX_BOXES]
            mid = 0.5 * (lo_t[idx] + hi_t[idx])
            lo_t = np.concatenate([lo_t[idx], mid])
            hi_t = np.concatenate([mid, hi_t[idx]])
            order = np.argsort(lo_t, kind="stable")
            lo_t, hi_t = lo_t[order], hi_t[order]
    return Singularity(0, float(lo_t[0]), "a point that could not be cleared")


# ---- what a run needs to know about its law ----------------------------------------------
@dataclass(frozen=True)
class LawSummary:
    """Facts about a law over a run, from its samples and the interval proof."""
    max_radius: float           # max |OP|
    max_speed: float            # max |OP'|
    max_acceleration: float     # max |OP''|
    amplitude: float            # max |OP - mean OP|
    time_scale: float           # sqrt(amplitude / max |OP''|) (inf for a still point)


SAMPLES = 4097


def summarise(jets: np.ndarray) -> LawSummary:
    r, v, a = (jets[list(rows)] for rows in (layout.JET_R, layout.JET_V, layout.JET_A))
    with np.errstate(over="ignore", invalid="ignore"):     # huge laws: inf, then refused
        rn = np.sqrt((r * r).sum(0))
        amp = float(np.sqrt(((r - r.mean(axis=1, keepdims=True)) ** 2).sum(0)).max())
        acc = float(np.sqrt((a * a).sum(0)).max())
        speed = float(np.sqrt((v * v).sum(0)).max())
    scale = math.sqrt(amp / acc) if acc > 0 and amp > 0 and math.isfinite(acc) else math.inf
    return LawSummary(float(rn.max()), speed, acc, amp, scale)
