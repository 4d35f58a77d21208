"""Local coordinates on the rotation group for the attitude: the exponential map and the
inverse of its differential, as power series derived from their definitions.

A Lie-group integrator (Runge–Kutta–Munthe-Kaas; Hairer, Lubich & Wanner, *Geometric
Numerical Integration*, IV.8) writes the attitude over one step as

    A(t) = A_n exp(skew(W(t))),   W(t_n) = 0,

with ``W`` in R^3 (the Lie algebra so(3) through the hat map ``W -> skew(W)``), and
integrates an ordinary differential equation for ``W`` with a Runge–Kutta method:
whatever ``W`` the method produces, ``A`` is a rotation, to rounding.  A uniform rotation
(omega constant in body axes) is ``W = (t - t_n) omega``, integrated exactly.

Everything is a power series in ``s = |W|^2`` (no square root, no trigonometric call):

* ``exp(skew(W)) = sum skew(W)^k / k!`` with ``skew(W)^3 = -s skew(W)`` is
  ``1 + a(s) skew(W) + b(s) skew(W)^2`` (Rodrigues' formula, ``a = sin(theta)/theta``,
  ``b = (1 - cos(theta))/theta^2``);
* Poisson's equations (E1.8), ``A' = A skew(omega)``, become ``omega = D(W) W'`` with
  ``skew(D(W) W') = exp(-skew(W)) d/dt exp(skew(W))``, ``D = sum_k (-1)^k ad_W^k/(k+1)!``
  (``ad_W = skew(W)`` on R^3); its inverse is solved here as
  ``dexpinv(W, omega) = omega + alpha(s) W x omega + c(s) W x (W x omega)``, two series
  found from ``D dexpinv = 1`` (alpha = 1/2, c = 1/12 + s/720 + ...: Bernoulli numbers);
* the unit quaternion of ``exp(skew(W))`` is ``(cos(theta/2), sin(theta/2)/theta W)``.

Each series is cut where its remaining terms are below 2^-56 of its value for every
``|W| <= THETA_MAX``; the runtime refuses a step whose ``|W|`` goes beyond.  The checks
(:func:`check`) compare with the closed forms.  Nothing here is specific to the carrier;
:mod:`derive.momentum` supplies omega.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache

import sympy as sp

from .notation import skew

W = sp.Matrix(sp.symbols("W_x W_y W_z", real=True))          # exponential coordinates
S_W = sp.Symbol("s_W", nonnegative=True)                      # |W|^2
OMEGA = sp.Matrix(sp.symbols("Omega_x Omega_y Omega_z", real=True))
THETA_MAX = Fraction(5, 4)            # |W| of a step is at most this (radians)
EXACT_TERMS = 40                       # series arithmetic is exact to this many terms


def _series_terms(coeffs: list, s_max: Fraction, rel: float = 2.0 ** -56) -> int:
    """How many terms of ``sum coeffs[j] s^j`` keep the tail below ``rel`` of the
    constant term for ``0 <= s <= s_max`` (the coefficients decay fast: the tail is
    bounded by twice its first term once the ratio of successive terms is below 1/2)."""
    lead = abs(Fraction(coeffs[0]))
    for n in range(1, len(coeffs) - 1):
        term = abs(Fraction(coeffs[n])) * s_max ** n
        nxt = abs(Fraction(coeffs[n + 1])) * s_max ** (n + 1)
        if nxt <= term / 2 and 2 * term <= Fraction(rel) * lead:
            return n
    raise ValueError("series too short for the range")


def _mul(p: list, q: list) -> list:
    out = [sp.Integer(0)] * EXACT_TERMS
    for i, a in enumerate(p):
        if a == 0:
            continue
        for j, b in enumerate(q[:EXACT_TERMS - i]):
            out[i + j] += a * b
    return out


def _inverse(p: list) -> list:
    """1/p as a power series (p[0] != 0)."""
    out = [sp.Integer(0)] * EXACT_TERMS
    out[0] = 1 / p[0]
    for n in range(1, EXACT_TERMS):
        out[n] = -sum((p[k] * out[n - k] for k in range(1, n + 1)), sp.Integer(0)) / p[0]
    return out


def _shift(p: list) -> list:
    """s p(s)."""
    return [sp.Integer(0)] + list(p[:EXACT_TERMS - 1])


def _add(*ps) -> list:
    return [sum(vals, sp.Integer(0)) for vals in zip(*ps)]


def _neg(p: list) -> list:
    return [-v for v in p]


def horner(coeffs: list, x: sp.Symbol) -> sp.Expr:
    """``sum coeffs[j] x^j`` nested for evaluation (``c0 + x (c1 + x (c2 + ...)))``)."""
    expr = sp.Integer(0)
    for c in reversed(coeffs):
        expr = sp.Add(sp.Float(float(c), 17) if c.q != 1 else c,
                      sp.Mul(x, expr, evaluate=False), evaluate=False) \
            if expr != 0 else (sp.Float(float(c), 17) if c.q != 1 else c)
    return expr


@dataclass(frozen=True)
class ExponentialChart:
    a: list                  # exp(W^) = 1 + a(s) W^ + b(s) W^2: series coefficients in s
    b: list
    alpha: list              # dexpinv = omega + alpha(s) W x omega + c(s) W x (W x omega)
    c: list
    quat_w: list             # the unit quaternion of exp(W^): (qw(s), qv(s) W)
    quat_v: list

    def series(self, name: str, x=S_W) -> sp.Expr:
        """The truncated series ``name`` in ``x`` (Horner form, one expression)."""
        return horner(getattr(self, name), x)

    def exp_matrix(self, w=W, values=None) -> sp.Matrix:
        a, b = (values or self.values())[:2]
        Wh = skew(w)
        return sp.eye(3) + a * Wh + b * Wh * Wh

    def body_view(self, k: sp.Matrix, w=W, values=None) -> sp.Matrix:
        """``exp(-W^) k = exp(W^)^T k``: a vector fixed in space seen from the rotated
        body, ``k - a W x k + b W x (W x k)``."""
        a, b = (values or self.values())[:2]
        Wk = skew(w) * k
        return k - a * Wk + b * (skew(w) * Wk)

    def dexpinv(self, omega: sp.Matrix, w=W, values=None) -> sp.Matrix:
        alpha, c = (values or self.values())[2:4]
        Wo = skew(w) * omega
        return omega + alpha * Wo + c * (skew(w) * Wo)

    def values(self, x=S_W) -> tuple:
        """(a, b, alpha, c, quat_w, quat_v) as expressions in ``x`` (Horner)."""
        return tuple(self.series(n, x) for n in SERIES)

    def definitions(self, w=W) -> tuple:
        """``(symbol, expr)`` computing ``s = |W|^2``, its powers and every series by
        Estrin's scheme (pairs c_2i + c_2i+1 s, then s^2, s^4, ...: the chain of dependent
        operations grows with the logarithm of the number of terms, not with it as in
        Horner's), each level a named quantity so that the printed C keeps the order.
        Returns the definitions and the symbols of (a, b, alpha, c, quat_w, quat_v)."""
        defs = [(S_W, (w.T * w)[0])]
        longest = max(len(getattr(self, n)) for n in SERIES)
        powers = [S_W]
        while 2 ** len(powers) < longest:
            p = sp.Symbol(f"s_W{2 ** len(powers)}", nonnegative=True)
            defs.append((p, powers[-1] * powers[-1]))
            powers.append(p)
        out = []
        for name in SERIES:
            coeffs = [_number(c) for c in getattr(self, name)]
            sym = SERIES_SYMBOLS[name]
            if len(coeffs) == 1:
                out.append(coeffs[0])
                continue
            level = [coeffs[i] + (coeffs[i + 1] * S_W if i + 1 < len(coeffs) else 0)
                     for i in range(0, len(coeffs), 2)]
            depth = 1
            while len(level) > 1:
                nxt = []
                for i in range(0, len(level), 2):
                    if i + 1 < len(level):
                        nxt.append(level[i] + powers[depth] * level[i + 1])
                    else:
                        nxt.append(level[i])
                named = []
                for k, expr in enumerate(nxt):
                    if len(nxt) == 1:
                        named.append(expr)
                        break
                    t = sp.Symbol(f"{sym.name}_{depth}_{k}", real=True)
                    defs.append((t, expr))
                    named.append(t)
                level, depth = named, depth + 1
            defs.append((sym, level[0]))
            out.append(sym)
        return tuple(defs), tuple(out)


SERIES = ("a", "b", "alpha", "c", "quat_w", "quat_v")
SERIES_SYMBOLS = {n: sp.Symbol(f"{n}_W", real=True) for n in SERIES}


def _number(c):
    c = sp.Rational(c)
    return c if c.q == 1 else sp.Float(float(c), 17)


@lru_cache(maxsize=None)
def exponential_chart() -> ExponentialChart:
    fac = sp.factorial
    neg = [(-1) ** j for j in range(EXACT_TERMS)]
    # exp(W^) = sum_k W^k / k!, W^(2j+1) = (-s)^j W^, W^(2j+2) = (-s)^j W^2
    a = [sp.Rational(neg[j], fac(2 * j + 1)) for j in range(EXACT_TERMS)]
    b = [sp.Rational(neg[j], fac(2 * j + 2)) for j in range(EXACT_TERMS)]
    # D = sum_k (-1)^k W^k/(k+1)! = 1 + d1 W^ + d2 W^2
    d1 = [sp.Rational(-neg[j], fac(2 * j + 2)) for j in range(EXACT_TERMS)]
    d2 = [sp.Rational(neg[j], fac(2 * j + 3)) for j in range(EXACT_TERMS)]
    # (1 + d1 W^ + d2 W^2)(1 + alpha W^ + c W^2) = 1, with W^3 = -s W^, W^4 = -s W^2:
    #   W^ :  d1 + alpha - s (d1 c + d2 alpha) = 0
    #   W^2:  d2 + c + d1 alpha - s d2 c = 0
    # linear in (alpha, c): solve by Cramer's rule in series arithmetic
    m11 = _add([sp.Integer(1)] + [sp.Integer(0)] * (EXACT_TERMS - 1), _neg(_shift(d2)))
    m12 = _neg(_shift(d1))
    m21 = d1
    m22 = m11
    det = _add(_mul(m11, m22), _neg(_mul(m12, m21)))
    inv = _inverse(det)
    r1, r2 = _neg(d1), _neg(d2)
    alpha = _mul(_add(_mul(r1, m22), _neg(_mul(m12, r2))), inv)
    c = _mul(_add(_mul(m11, r2), _neg(_mul(m21, r1))), inv)
    # the quaternion (cos(theta/2), sin(theta/2)/theta W), theta^2 = s
    quat_w = [sp.Rational(neg[j], 4 ** j * fac(2 * j)) for j in range(EXACT_TERMS)]
    quat_v = [sp.Rational(neg[j], 2 * 4 ** j * fac(2 * j + 1)) for j in range(EXACT_TERMS)]
    s_max = THETA_MAX ** 2
    cut = {}
    for name, coeffs in (("a", a), ("b", b), ("alpha", alpha), ("c", c),
                         ("quat_w", quat_w), ("quat_v", quat_v)):
        nz = [v for v in coeffs if v != 0]
        if len(nz) <= 1:
            cut[name] = [coeffs[0]]
            continue
        n = _series_terms([Fraction(int(v.p), int(v.q)) for v in coeffs], s_max)
        cut[name] = list(coeffs[:n + 1])
    return ExponentialChart(**cut)


def check() -> None:
    """The series against the closed forms (Rodrigues, the Bernoulli-number inverse of
    the differential, the half-angle quaternion) at several |W| up to THETA_MAX; and D
    times dexpinv equals 1 as series.  Raises AssertionError."""
    ch = exponential_chart()
    th = sp.Symbol("theta", positive=True)
    closed = {"a": sp.sin(th) / th, "b": (1 - sp.cos(th)) / th ** 2,
              "alpha": sp.Rational(1, 2),
              "c": (1 - th / 2 * sp.cot(th / 2)) / th ** 2,
              "quat_w": sp.cos(th / 2), "quat_v": sp.sin(th / 2) / th}
    for name, f in closed.items():
        for theta in (sp.Rational(1, 10), sp.Rational(1, 2), sp.Integer(1),
                      sp.Rational(THETA_MAX.numerator, THETA_MAX.denominator)):
            series = sum((v * theta ** (2 * j) for j, v in enumerate(getattr(ch, name))),
                         sp.Integer(0))
            exact = f if not hasattr(f, "xreplace") else f.xreplace({th: theta})
            err = abs(sp.N(series - exact, 40))
            if err > 2.0 ** -53 * max(abs(sp.N(exact, 40)), 1e-300):
                raise AssertionError(f"the series {name} is off by {err} at theta = {theta}")
