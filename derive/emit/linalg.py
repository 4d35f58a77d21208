"""Closed-form LDL^T solve of a symmetric positive definite 3x3 system.

One algorithm for every backend: it runs on SymPy symbols (producing the straight-line
steps of the generated C), on CasADi SX (the CasADi functions) and on floats (tests).
``assign(name, value)`` records an intermediate and returns what later steps use: a new
symbol for the C program, the value itself elsewhere.

    A = L D L^T,  L unit lower triangular,  D = diag(d0, d1, d2) > 0
    forward  L y = b;  scale  z = D^-1 y;  back  L^T x = z

Unrolled for 3x3: three reciprocals (one per pivot), 17 multiplications and 12
additions for the factors and one right-hand side; every further right-hand side shares
the factors.  (Computing the pivots from the leading principal minors instead makes the
three reciprocals independent, but costs ten more multiplications; measured on this
project's benchmark it was slower in both throughput and latency.)  No pivoting: A is
positive definite (R1 in paper_checks), so every pivot is positive.
"""
from __future__ import annotations

from typing import Callable, Sequence


def _identity(_name: str, value):
    return value


def ldlt3_factor(A: Sequence, assign: Callable[[str, object], object] = _identity) -> tuple:
    """The factors of ``A`` (lower triangle ``(a00, a10, a11, a20, a21, a22)``):
    ``(inv_d0, l10, l20, inv_d1, l21, inv_d2)``."""
    a00, a10, a11, a20, a21, a22 = A
    inv_d0 = assign("inv_d0", 1 / a00)
    l10 = assign("l10", a10 * inv_d0)
    l20 = assign("l20", a20 * inv_d0)
    d1 = assign("d1", a11 - l10 * a10)
    inv_d1 = assign("inv_d1", 1 / d1)
    c21 = assign("c21", a21 - l20 * a10)          # d1 * l21
    l21 = assign("l21", c21 * inv_d1)
    d2 = assign("d2", a22 - l20 * a20 - l21 * c21)
    inv_d2 = assign("inv_d2", 1 / d2)
    return inv_d0, l10, l20, inv_d1, l21, inv_d2


def ldlt3_apply(factors: Sequence, rhs: Sequence[Sequence],
                assign: Callable[[str, object], object] = _identity) -> list[list]:
    """Forward, scale and back substitution with the factors of :func:`ldlt3_factor`:
    one solution vector per right-hand side."""
    inv_d0, l10, l20, inv_d1, l21, inv_d2 = factors
    solutions = []
    for k, b in enumerate(rhs):
        y0 = b[0]
        y1 = assign(f"y1_{k}", b[1] - l10 * y0)
        y2 = assign(f"y2_{k}", b[2] - l20 * y0 - l21 * y1)
        x2 = assign(f"x2_{k}", y2 * inv_d2)
        x1 = assign(f"x1_{k}", y1 * inv_d1 - l21 * x2)
        x0 = assign(f"x0_{k}", y0 * inv_d0 - l10 * x1 - l20 * x2)
        solutions.append([x0, x1, x2])
    return solutions


def ldlt3_solve(A: Sequence, rhs: Sequence[Sequence],
                assign: Callable[[str, object], object] = _identity) -> list[list]:
    """``A``: lower triangle as ``(a00, a10, a11, a20, a21, a22)``; ``rhs``: vectors.

    Returns one solution vector per right-hand side.
    """
    return ldlt3_apply(ldlt3_factor(A, assign), rhs, assign)


def lower_triangle(matrix) -> tuple:
    """``(a00, a10, a11, a20, a21, a22)`` of a 3x3 matrix-like object."""
    return (matrix[0, 0], matrix[1, 0], matrix[1, 1], matrix[2, 0], matrix[2, 1],
            matrix[2, 2])
