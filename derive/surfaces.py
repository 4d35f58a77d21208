"""The lowest point S of the carrier's surface as a function of the vertical ``n``.

Every surface is the convex shape of :mod:`derive.shapes`, written there once as its
support map; here SymPy evaluates it: ``OS = c + support(-n)`` (the point of the surface
farthest along ``-n``, ``c`` the shape's centre in body axes), and its rate
``d(OS)/dt = (d OS/d n) dn/dt`` along Poisson's equations, which persistent contact
needs.  A kink of the support map (a capsule's ``sign``) is differentiated away from it
(:class:`sign`: no DiracDelta), where S lies on one face.

The ellipsoid's S is checked in the tests against the stationary points of the
Lagrangian ``(n, c + D u) - lambda (|u|^2 - 1)`` (the form this module derived before
shapes were written as support maps).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from types import SimpleNamespace

import sympy as sp

from . import shapes
from .kinematics import poisson_equations
from .notation import n as n_body

class sign(sp.sign):  # noqa: N801 (named as SymPy's, so that every printer prints it so)
    """SymPy's ``sign`` with derivative zero: a support map's kink (a capsule's jump from
    one end to the other) is differentiated away from it, where S lies on one face, and
    no DiracDelta reaches the emitted code.  Every printer finds it by its name, and the
    CasADi translation by its base."""

    def _eval_derivative(self, x):
        return sp.S.Zero


class Abs(sp.Abs):
    """SymPy's ``Abs`` whose derivative is the :class:`sign` above (no DiracDelta in a
    derivative of any order)."""

    def _eval_derivative(self, x):
        arg = self.args[0]
        return sign(arg) * sp.diff(arg, x)


SYMPY = SimpleNamespace(sqrt=sp.sqrt, abs=Abs, sign=sign)

center = sp.Matrix(sp.symbols("c_x c_y c_z", real=True))


def size_symbols(size: shapes.Size) -> tuple:
    """The derivation's symbols of one size field (positive numbers)."""
    return tuple(sp.Symbol(name, positive=True) for name in size.names(size.symbols))


def shape_symbols(shape: shapes.Shape) -> tuple:
    return tuple(s for size in shape.sizes for s in size_symbols(size))


# the sizes the paper's shapes read (derive.equations names them)
radius = size_symbols(shapes.RADIUS)[0]
semi_axes = sp.Matrix(size_symbols(shapes.SEMI_AXES))


@dataclass(frozen=True)
class LowestPoint:
    point: sp.Matrix    # OS in body axes, in terms of n = (a31, a32, a33)
    rate: sp.Matrix     # d(OS)/dt along Poisson's equations (in terms of n and omega)


@lru_cache(maxsize=None)
def lowest_point(name: str) -> LowestPoint:
    """S of the registered shape ``name`` and its rate."""
    shape = shapes.of(name)
    d = tuple(-v for v in n_body)
    point = center + sp.Matrix(shape.support(d, shape_symbols(shape), SYMPY))
    ndot = poisson_equations()[2, :].T
    jac = point.jacobian(n_body)
    rate = (jac.applyfunc(sp.together) if shape.rate_together else jac) * ndot
    # for a sphere, (n, n') = 0 collapses the rate to -R n'/|n| (simplify finds it)
    rate = rate.applyfunc(sp.simplify if shape.simplify_rate else sp.factor_terms)
    return LowestPoint(point=point, rate=rate)


def sphere() -> LowestPoint:
    return lowest_point("sphere")


def ellipsoid() -> LowestPoint:
    return lowest_point("ellipsoid")
