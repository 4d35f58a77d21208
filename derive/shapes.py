"""The carrier's surfaces, each written once, as its support map.

A convex surface is given by its *support map*: for a direction ``d`` (body axes, any
length), the point of the surface farthest along ``d``, measured from the shape's centre
``[body].center``.  Its dot product with ``d`` is the support function ``h(d)``.  The lowest
point S on the plane is the support point of ``-n``, ``n`` the vertical in body axes:
``OS = center + support(-n)``.

Each :class:`Shape` writes its support map as a function of the direction's components,
its size numbers and ``ops`` (``sqrt``, ``abs``, ``sign``).  The same function is
evaluated three ways: by SymPy (:mod:`derive.surfaces`, with SymPy's ``ops``: the
derivation of S and of its rate, emitted as ``lowest_point_<shape>`` and
``lowest_point_rate_<shape>`` into the standalone C, the CasADi functions and the
runtime), by NumPy on rows of directions (pictures, the runtime's reasons for a model)
and by ``math`` on one direction (the scene rules: S above the plane at the start).  No
SymPy is imported here: the runtime reads this module.

Adding a shape is one :func:`register` call at the end of this file, then ``derive
emit`` (derive/docs/regenerating.md).  The order of ``SHAPES`` is
the code the runtime reads in ``prm[CRT_P_shape]``: append, never insert.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Callable

import numpy as np

MAX_SIZE_NUMBERS = 3       # the runtime's parameter slots size_a, size_b, size_c


@dataclass(frozen=True)
class Size:
    """A ``[body]`` field that sizes shapes: a positive number (``count = 1``) or a
    vector of ``count`` positive numbers, each at most the schema's MAX_LENGTH.
    ``symbols``: the derivation's names of its numbers, ``labels``: the emitted code's
    (both default to the key, numbered for a vector)."""
    key: str
    doc: str
    count: int = 1
    example: object = None
    symbols: tuple = ()
    labels: tuple = ()

    def names(self, given: tuple) -> tuple:
        if given:
            return given
        return (self.key,) if self.count == 1 else tuple(f"{self.key}_{i}"
                                                          for i in range(self.count))


@dataclass(frozen=True)
class Shape:
    """A convex surface.  ``support(d, size, ops)``: the support point (three
    components) relative to the centre for the direction ``d = (dx, dy, dz)`` (not
    necessarily unit; componentwise NumPy arrays, floats or SymPy expressions), ``size``
    the numbers of ``sizes`` in order; ``reach(size)``: the largest distance of the
    surface from its centre.  ``simplify_rate``: let SymPy simplify S's rate (worth it
    only for short expressions: the sphere's collapses to ``-R n'/|n|``).
    ``strictly_convex``: S moves continuously as the body turns (no flat parts); a shape
    not declared so is watched in contact for S jumping (status ``surface_jump``).
    ``rate_together``: put each entry of dS/dn over one denominator before the chain rule
    (a cylinder's rim ``-R n/rho``: ``1/rho - x^2/rho^3`` would cancel where y is small;
    ``(y^2 + ...)/rho^3`` does not)."""
    name: str
    doc: str
    sizes: tuple[Size, ...]
    support: Callable
    reach: Callable
    simplify_rate: bool = False
    strictly_convex: bool = False
    rate_together: bool = False

    @property
    def code(self) -> int:
        """The number the runtime reads in ``prm[CRT_P_shape]``."""
        return SHAPE_NAMES.index(self.name)

    @property
    def size_count(self) -> int:
        return sum(s.count for s in self.sizes)

    def support_rows(self, d, size) -> np.ndarray:
        """Support points (..., 3) for directions ``d`` (..., 3), NumPy."""
        d = np.asarray(d, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = self.support((d[..., 0], d[..., 1], d[..., 2]), tuple(size), NUMPY)
        return np.stack(np.broadcast_arrays(*out), axis=-1)

    def lowest(self, n, center, size) -> tuple:
        """OS (body axes) for one vertical ``n``, in floats (``math``)."""
        s = self.support((-n[0], -n[1], -n[2]), tuple(size), MATH)
        return (center[0] + s[0], center[1] + s[1], center[2] + s[2])

    def lowest_rows(self, n, center, size) -> np.ndarray:
        """OS (body axes) for verticals ``n`` (..., 3), NumPy."""
        return np.asarray(center, dtype=float) + self.support_rows(-np.asarray(n, dtype=float),
                                                                   size)


def _sign(x):
    return int(x > 0) - int(x < 0)        # (NumPy scalars too: their bools do not subtract)


NUMPY = SimpleNamespace(sqrt=np.sqrt, abs=np.abs, sign=np.sign)
MATH = SimpleNamespace(sqrt=math.sqrt, abs=abs, sign=_sign)

SHAPES: dict[str, Shape] = {}
SHAPE_NAMES: list[str] = []
NONE = "none"              # a body without a surface: no contact


def register(shape: Shape) -> Shape:
    """Add a shape (its code is its place in the order of registration)."""
    if shape.name in SHAPES or shape.name == NONE or not shape.name.isidentifier():
        raise ValueError(f"shape {shape.name!r}: a new identifier, not 'none'")
    if not 1 <= shape.size_count <= MAX_SIZE_NUMBERS:
        raise ValueError(f"shape {shape.name!r}: 1 to {MAX_SIZE_NUMBERS} size numbers "
                         "(the runtime's parameter slots)")
    for s in shape.sizes:
        for other in SHAPES.values():
            for t in other.sizes:
                if t.key == s.key and t != s:
                    raise ValueError(f"shape {shape.name!r}: [body].{s.key} is declared "
                                     f"differently by {other.name!r}: share its Size")
    SHAPES[shape.name] = shape
    SHAPE_NAMES.append(shape.name)
    return shape


def of(name: str) -> Shape:
    return SHAPES[name]


def with_article(name: str) -> str:
    """"a sphere", "an ellipsoid": a shape's name in running text."""
    return ("an " if name[:1] in "aeiou" else "a ") + name


def size_fields() -> list[tuple[Size, tuple[str, ...]]]:
    """Every size field once, with the shapes that read it (the scene schema's rows)."""
    out: dict[str, tuple[Size, list]] = {}
    for shape in SHAPES.values():
        for s in shape.sizes:
            out.setdefault(s.key, (s, []))[1].append(shape.name)
    return [(s, tuple(names)) for s, names in out.values()]


def size_of(shape: Shape, values: dict) -> tuple:
    """The shape's size numbers from its fields' values (``{key: value}``)."""
    out: list = []
    for s in shape.sizes:
        v = values[s.key]
        out += list(v) if s.count > 1 else [v]
    return tuple(float(x) for x in out)


def fields_of(shape: Shape, size) -> dict:
    """The shape's fields (``{key: value}``) from its size numbers (size_of's inverse)."""
    out, k = {}, 0
    for s in shape.sizes:
        part = [float(x) for x in size[k:k + s.count]]
        out[s.key] = part if s.count > 1 else part[0]
        k += s.count
    return out


# ---- the shapes ------------------------------------------------------------------------
RADIUS = Size("radius", "radius", example=0.5, symbols=("R",), labels=("R",))
SEMI_AXES = Size("semi_axes", "semi-axes along the body axes", 3, example=[0.5, 0.4, 0.3],
                 symbols=("s_a", "s_b", "s_c"), labels=("a", "b", "c"))
HALF_EXTENTS = Size("half_extents", "half-extents along the body axes", 3,
                    example=[0.2, 0.1, 0.05], symbols=("h_a", "h_b", "h_c"),
                    labels=("a", "b", "c"))
HALF_LENGTH = Size("half_length", "half-length along the body z axis", example=0.3,
                   symbols=("L",), labels=("L",))


def _sphere(d, size, ops):
    (R,) = size
    x, y, z = d
    k = R / ops.sqrt(x * x + y * y + z * z)
    return (k * x, k * y, k * z)


def _ellipsoid(d, size, ops):
    """The point D^2 d / |D d| of the surface {D u : |u| = 1}, D = diag(a, b, c)."""
    a, b, c = size
    x, y, z = d
    ax, by, cz = a * a * x, b * b * y, c * c * z
    k = ops.sqrt(x * ax + y * by + z * cz)
    return (ax / k, by / k, cz / k)


register(Shape("sphere", "a sphere of the given radius", (RADIUS,), _sphere,
               reach=lambda size: size[0], simplify_rate=True, strictly_convex=True))
register(Shape("ellipsoid", "an ellipsoid with its semi-axes along the body axes",
               (SEMI_AXES,), _ellipsoid, reach=lambda size: max(size), strictly_convex=True))


def _box(d, size, ops):
    """The corner of the box [-a, a] x [-b, b] x [-c, c] that d points to.  Where a
    component of d is 0 (a face or an edge square to d), its sign 0 gives the middle of
    that face or edge: a support point too, the one a flat contact is centred on."""
    a, b, c = size
    x, y, z = d
    return (a * ops.sign(x), b * ops.sign(y), c * ops.sign(z))


def _cylinder(d, size, ops):
    """The point of the rim (radius R, along the horizontal part of d) on the end face that
    d points to (z = +-L).  Where d is along the axis (x = y = 0) every point of that end
    face is a support point: ``sign(1 - sign(x^2 + y^2))`` (1 there, 0 elsewhere) under
    the root keeps the quotient and its derivatives finite and gives the face's centre, as
    the box's sign 0 does.  It is ``1 - sign(rr)`` inside a sign of its own so that
    SymPy keeps it apart (an Add would flatten it, and the C computed ``(rr - 1) + 1``):
    added as a whole it is exact, where ``(rr - 1) + 1`` is 0 for rr below 1e-16 (a
    cylinder 1e-8 rad off its end face, or a direction that near the axis) and R/0
    times 0 was NaN, and lost bits of every rr below 1."""
    R, L = size
    x, y, z = d
    rr = x * x + y * y
    k = R / ops.sqrt(rr + ops.sign(1 - ops.sign(rr)))
    return (k * x, k * y, L * ops.sign(z))


# Box and cylinder are convex but not strictly convex: in flight their corner and rim
# impacts are single-point impacts at S, exact; in contact S can jump (to another corner,
# across an edge or a face), which the runtime watches (surface_jump).  A body resting on a
# face is the base model's (derive/base.py), not the one-point contact's.
register(Shape("box", "a box with its half-extents a, b, c along the body axes",
               (HALF_EXTENTS,), _box,
               reach=lambda size: math.sqrt(sum(v * v for v in size))))
register(Shape("cylinder", "a circular cylinder of radius R and half-length L, its axis "
               "along the body z axis", (RADIUS, HALF_LENGTH), _cylinder,
               reach=lambda size: math.hypot(size[0], size[1]), rate_together=True))
