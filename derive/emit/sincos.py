"""The constants of the runtime's sine and cosine (``crt_sincos`` in
``templates/runtime/crt_law.h``), computed here from their definitions and rendered into
``generated/runtime/crt_constants.h`` (``CRT_SINCOS_*``).

The point law's harmonics take a sine and a cosine of one argument at every evaluation;
in a run of the built-in scene they were 28% of the C time through the C library.  The
runtime's own kernel is the textbook one, written here:

* reduction by Cody and Waite: ``k = round(x 2/pi)``, ``r = x - k pi/2`` with pi/2 split
  into three parts, the first two of 33 bits so that ``k`` times them is exact for
  ``|k| < 2^20`` (the kernel hands larger arguments to the C library), ``r`` kept as a
  sum ``hi + lo`` of two doubles;
* Taylor polynomials of sin and cos on ``|r| <= pi/4``, to the degree whose first
  omitted term is below 1e-19 of the result (sin to r^17, cos to r^18), evaluated by
  Estrin's scheme;
* the quadrant ``k mod 4`` picks the signs and which polynomial gives which.

Everything is exact rational arithmetic (SymPy) until the final rounding of each
constant to the nearest double, printed as a C99 hexadecimal literal.
"""
from __future__ import annotations

from functools import lru_cache

import sympy as sp

SPLIT_BITS = 33          # bits of the first two parts of pi/2
MAX_QUADRANT = 2 ** 20   # |k| below this: k times a 33-bit part is exact
SIN_DEGREE = 17          # sin r = r + r^3 (s3 + s5 z + ... + s17 z^7), z = r^2
COS_DEGREE = 18          # cos r = 1 - z/2 + z^2 (c4 + c6 z + ... + c18 z^7)


def _nearest_double(x) -> float:
    """The double nearest the exact (or 100-digit) value ``x``."""
    return float(sp.Float(sp.N(x, 100), 100))


def _leading_bits(x, bits: int):
    """The rational ``x`` cut (toward zero) to its leading ``bits`` significant bits."""
    e = sp.floor(sp.log(abs(x), 2))
    scale = sp.Integer(2) ** (bits - 1 - e)
    return sp.floor(x * scale) / scale


@lru_cache(maxsize=1)
def constants() -> dict:
    """The kernel's constants as doubles: ``two_over_pi``, ``pio2`` (three parts), the
    sine and cosine coefficients."""
    half_pi = sp.pi / 2
    p1 = _leading_bits(sp.Rational(sp.N(half_pi, 120)), SPLIT_BITS)
    p2 = _leading_bits(sp.Rational(sp.N(half_pi - p1, 120)), SPLIT_BITS)
    p3 = _nearest_double(half_pi - p1 - p2)
    return {
        "two_over_pi": _nearest_double(2 / sp.pi),
        "pio2": (float(p1), float(p2), p3),
        "max_argument": float(MAX_QUADRANT) * 1.5,     # |x| below: |k| < 2^20
        "sin": tuple(_nearest_double(sp.Integer(-1) ** j / sp.factorial(2 * j + 1))
                     for j in range(1, (SIN_DEGREE - 1) // 2 + 1)),
        "cos": tuple(_nearest_double(sp.Integer(-1) ** j / sp.factorial(2 * j))
                     for j in range(2, COS_DEGREE // 2 + 1)),
    }


def estrin(coefficients: tuple, powers: tuple) -> str:
    """``c0 + c1 z + ... + c7 z^7`` by Estrin's scheme, as C99 with hexadecimal literals:
    pairs ``c_2k + c_2k+1 z``, then pairs of those with ``z^2``, then with ``z^4``: a
    chain of three multiply-adds after the powers, where Horner's is seven (the kernel's
    latency is on the path of every evaluation of the law).  ``powers``: the names of
    z, z^2, z^4, ..."""
    terms = [c.hex() for c in coefficients]
    for power in powers:
        terms = [f"({a} + {power} * {b})" if b is not None else a
                 for a, b in zip(terms[0::2], terms[1::2] + [None] * (len(terms) % 2))]
        if len(terms) == 1:
            break
    assert len(terms) == 1, "more coefficients than the powers reach"
    return terms[0]


def template_context() -> dict:
    c = constants()
    p1, p2, p3 = c["pio2"]
    return {"sincos_two_over_pi": c["two_over_pi"].hex(), "sincos_p1": p1.hex(),
            "sincos_p2": p2.hex(), "sincos_p3": p3.hex(),
            "sincos_max": repr(c["max_argument"]),
            "sincos_sin_poly": estrin(c["sin"], ("z", "z2", "z4")),
            "sincos_cos_poly": estrin(c["cos"], ("z", "z2", "z4"))}
