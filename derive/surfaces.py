"""The lowest point S of the carrier's surface as a function of the vertical ``n``.

The surface is an ellipsoid ``s = c + D u``, ``|u| = 1``, with ``D = diag(a, b, c)``
(semi-axes along the body axes) and centre ``c`` anywhere in the body; a sphere is the
case ``a = b = c = radius``.  S minimises the height ``(n, s)`` over the surface; the
stationary points of the Lagrangian ``(n, c + D u) - lambda (|u|^2 - 1)`` are found here
and the lower one is kept.  Its rate ``ds/dt = (ds/dn) dn/dt`` is what persistent contact
needs.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp

from .notation import n as n_body
from .kinematics import poisson_equations

center = sp.Matrix(sp.symbols("c_x c_y c_z", real=True))
semi_axes = sp.Matrix(sp.symbols("s_a s_b s_c", positive=True))
radius = sp.Symbol("R", positive=True)


@dataclass(frozen=True)
class LowestPoint:
    point: sp.Matrix    # OS in body axes, in terms of n = (a31, a32, a33)
    rate: sp.Matrix     # d(OS)/dt along Poisson's equations (in terms of n and omega)


def _lowest_point(n: sp.Matrix, c: sp.Matrix, axes: sp.Matrix) -> sp.Matrix:
    u = sp.Matrix(sp.symbols("u_1:4", real=True))
    lam = sp.Symbol("lambda", real=True)
    D = sp.diag(*axes)
    lagrangian = (n.T * (c + D * u))[0] - lam * ((u.T * u)[0] - 1)
    equations = [sp.diff(lagrangian, v) for v in (*u, lam)]
    candidates = sp.solve(equations, [*u, lam], dict=True)
    if len(candidates) != 2:
        raise AssertionError(f"expected two stationary points, found {len(candidates)}")
    points = [c + D * sp.Matrix([sol[v] for v in u]) for sol in candidates]
    # the lower of the two, decided at a sample direction (the sign does not depend on n)
    sample = {n[0]: sp.Rational(1, 3), n[1]: sp.Rational(-2, 3), n[2]: sp.Rational(2, 3),
              **{v: 1 for v in axes}, **{v: 0 for v in c}}
    heights = [sp.nsimplify((n.T * p)[0].xreplace(sample)) for p in points]
    lower = points[0] if heights[0] < heights[1] else points[1]
    return lower.applyfunc(sp.simplify)


def _with_rate(point: sp.Matrix, simplify: bool = False) -> LowestPoint:
    ndot = poisson_equations()[2, :].T
    rate = point.jacobian(n_body) * ndot
    # for a sphere, (n, n') = 0 collapses the rate to -R n'/|n| (simplify finds it)
    rate = rate.applyfunc(sp.simplify if simplify else sp.factor_terms)
    return LowestPoint(point=point, rate=rate)


@lru_cache(maxsize=None)
def ellipsoid() -> LowestPoint:
    return _with_rate(_lowest_point(n_body, center, semi_axes))


@lru_cache(maxsize=None)
def sphere() -> LowestPoint:
    """The ellipsoid with equal semi-axes: ``c - R n/|n|`` (``|n| = 1`` exactly, but
    keeping the norm makes S insensitive to round-off drift of the direction cosines)."""
    point = ellipsoid().point.xreplace({v: radius for v in semi_axes})
    # sqrt(R^2 (n, n)) = R |n| for R > 0: factor the radicand so SymPy sees it
    point = point.replace(lambda e: e.is_Pow and e.exp.is_Rational and e.exp.q == 2,
                          lambda e: sp.Pow(sp.factor(e.base), e.exp))
    return _with_rate(point, simplify=True)


SHAPES = {"sphere": sphere, "ellipsoid": ellipsoid}
