"""Equality of a derived and a printed expression, established two ways.

1. Symbolically: the difference, expanded (and cancelled when it is rational), is zero.
2. Numerically and exactly: both sides evaluated at random rational points agree exactly
   (rational arithmetic, no floating point), so a weak simplification cannot hide a
   mismatch and a strong one cannot invent an agreement.

Some relations involve an auxiliary unknown, such as ``w = J^-1 d``; pass its definition
as ``given=LinearDefinition(w, J, d)``.  The symbolic stage treats ``w`` as free (the
identity then holds for every ``w``, which is stronger, and no inverse is ever formed);
the numeric stage solves ``J w = d`` exactly at each rational point.
"""
from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Iterable

import sympy as sp
from sympy.core.function import AppliedUndef

from .registry import CheckFailed

POINTS = 4


@dataclass(frozen=True)
class LinearDefinition:
    unknown: sp.Matrix      # w
    matrix: sp.Matrix       # J
    rhs: sp.Matrix          # d

    def numeric(self, point: dict) -> dict:
        J = self.matrix.xreplace(point)
        d = self.rhs.xreplace(point)
        w = J.LUsolve(d)
        return {self.unknown[i]: sp.nsimplify(w[i]) for i in range(len(self.unknown))}

    def symbols(self) -> set:
        return self.matrix.free_symbols | self.rhs.free_symbols


def _zero(expr: sp.Expr) -> bool:
    expr = sp.expand(expr)
    if expr == 0:
        return True
    # a rational expression is zero iff the numerator over a common denominator is
    return sp.expand(sp.numer(sp.together(expr))) == 0


def random_point(symbols: Iterable[sp.Symbol], rng: random.Random) -> dict:
    point = {}
    for s in sorted(set(symbols), key=sp.default_sort_key):
        den = rng.randint(1, 9)
        if s.is_positive or s.is_nonnegative:
            num = rng.randint(1, 30)
        else:
            num = rng.choice([k for k in range(-30, 31) if k != 0])
        point[s] = sp.Rational(num, den)
    return point


def as_matrix(expr) -> sp.Matrix:
    return expr if isinstance(expr, sp.MatrixBase) else sp.Matrix([expr])


def _atomize(exprs: list) -> list:
    """Replace derivatives and undefined functions of t by fresh symbols (same map for
    all the expressions), so that the numeric stage can assign them values."""
    atoms = set()
    for ex in exprs:
        atoms |= ex.atoms(sp.Derivative)
    for ex in exprs:
        atoms |= {f for f in ex.atoms(AppliedUndef)}
    ordered = sorted(atoms, key=lambda a: (-sp.count_ops(a), sp.default_sort_key(a)))
    table = {a: sp.Dummy(f"q{k}", real=True) for k, a in enumerate(ordered)}
    return [ex.xreplace(table) for ex in exprs]


def assert_same(label: str, derived, printed, *, seed: int = 0,
                given: LinearDefinition | None = None) -> None:
    """Fail with a readable message unless ``derived`` equals ``printed``, symbolically
    and at exact rational points."""
    assert_symbolic(label, derived, printed)
    assert_numeric(label, derived, printed, seed=seed, given=given)


def assert_symbolic(label: str, derived, printed) -> None:
    D, P = as_matrix(derived), as_matrix(printed)
    if D.shape != P.shape:
        raise CheckFailed(f"{label}: derived shape {D.shape} != printed {P.shape}")
    for i, (dv, pv) in enumerate(zip(D, P)):
        if not _zero(dv - pv):
            raise CheckFailed(f"{label}[{i}]: derived - printed = "
                              f"{sp.sstr(sp.expand(dv - pv))[:400]}")


def assert_numeric(label: str, derived, printed, *, seed: int = 0,
                   given: LinearDefinition | None = None) -> None:
    D, P = as_matrix(derived), as_matrix(printed)
    if D.shape != P.shape:
        raise CheckFailed(f"{label}: derived shape {D.shape} != printed {P.shape}")
    flat = _atomize(list(D) + list(P))
    D2, P2 = flat[:len(D)], flat[len(D):]
    syms = set().union(*(ex.free_symbols for ex in flat))
    if given is not None:
        syms = (syms - set(given.unknown)) | given.symbols()
    rng = random.Random(f"{label}:{seed}")
    for _ in range(POINTS):
        point = random_point(syms, rng)
        if given is not None:
            point.update(given.numeric(point))
        for i, (dv, pv) in enumerate(zip(D2, P2)):
            a, b = dv.xreplace(point), pv.xreplace(point)
            if a.free_symbols or b.free_symbols:
                raise CheckFailed(f"{label}[{i}]: symbols left unassigned "
                                  f"{sorted(map(str, a.free_symbols | b.free_symbols))}")
            if a.is_Rational and b.is_Rational:
                same = a == b
            else:
                same = sp.nsimplify(sp.radsimp(a - b)) == 0
            if not same:
                raise CheckFailed(f"{label}[{i}] differs at a rational point: {a} != {b}")


def is_same(derived, printed) -> bool:
    D, P = as_matrix(derived), as_matrix(printed)
    return D.shape == P.shape and all(_zero(dv - pv) for dv, pv in zip(D, P))


def assert_zero(label: str, expr) -> None:
    for i, v in enumerate(as_matrix(expr)):
        if not _zero(v):
            raise CheckFailed(f"{label}[{i}] is not identically zero: "
                              f"{sp.sstr(sp.expand(v))[:400]}")
