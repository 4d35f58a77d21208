"""The opcodes of the law programs, one :class:`Op` each: how its arguments are read, its
value and two derivatives (written once for NumPy arrays and for floats), its enclosure
over an interval of values, its text, its SymPy form and where it may be singular.  The C
interpreter (``crt_law.h``) implements the same list, numbered by
:data:`derive.abi.OPCODES` (``tests/test_law.py`` keeps the two lists equal)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

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

class Floats:
    """The functions of a jet on floats: a value that does not exist raises (ValueError,
    OverflowError, ZeroDivisionError), which :meth:`Program.point` turns into NaN."""
    sin, cos, tan, exp, log, sqrt = math.sin, math.cos, math.tan, math.exp, math.log, math.sqrt
    sinh, cosh, tanh = math.sinh, math.cosh, math.tanh
    arcsin, arccos, arctan = math.asin, math.acos, math.atan
    power = staticmethod(math.pow)


class Arrays:
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
HALF_PI = 0.5 * math.pi


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


def iv_sine(shift):
    def enclose(x, y, r):
        x0, x1 = x[0] + shift, x[1] + shift
        wide = ~np.isfinite(x0) | ~np.isfinite(x1) | (x1 - x0 >= 2 * math.pi)
        x0s, x1s = np.where(wide, 0.0, x0), np.where(wide, 0.0, x1)
        s0, s1 = np.sin(x0s), np.sin(x1s)
        # maxima at pi/2 + 2k pi, minima at -pi/2 + 2k pi
        kmax = np.ceil((x0s - HALF_PI) / (2 * math.pi))
        has_max = HALF_PI + 2 * math.pi * kmax <= x1s
        kmin = np.ceil((x0s + HALF_PI) / (2 * math.pi))
        has_min = -HALF_PI + 2 * math.pi * kmin <= x1s
        rlo = np.where(has_min | wide, -1.0, np.minimum(s0, s1))
        rhi = np.where(has_max | wide, 1.0, np.maximum(s0, s1))
        return rlo, rhi, _none(x[0].shape[0])
    return enclose


def _iv_tan(x, y, r):
    alo, ahi = x
    wide = ~np.isfinite(alo) | ~np.isfinite(ahi) | (ahi - alo >= math.pi)
    lo_s, hi_s = np.where(wide, 0.0, alo), np.where(wide, 0.0, ahi)
    k = np.ceil((lo_s - HALF_PI) / math.pi)
    flag = wide | (HALF_PI + math.pi * k <= hi_s)
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
    _fn("sin", _sin, iv_sine(0.0), "sin"),
    _fn("cos", _cos, iv_sine(HALF_PI), "cos"),
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
MATH = {name: getattr(Floats, {"asin": "arcsin", "acos": "arccos", "atan": "arctan"}
                       .get(name, name)) for name in FUNCTIONS}

