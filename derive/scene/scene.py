"""A validated scene: :class:`Scene`, what :func:`derive.scene.parse_scene` returns and
the runtime runs."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import shapes
from .law import LawSummary


def body_size(shape: str, size: tuple, J, M: float) -> float:
    """The length a scene's tolerances and rules scale by: the shape's reach, or
    sqrt(J_max/M) for a body with no shape."""
    if size:
        return float(shapes.of(shape).reach(size))
    return math.sqrt(max(J) / M)


@dataclass(frozen=True)
class Stability:
    """``[stability]``: what ``derive stability`` analyses (derive/docs/stability.md)."""
    period: float | None = None
    impacts_every: int = 1
    long_periods: int = 0
    perturbations: tuple = (1e-6, 1e-4, 1e-2)


@dataclass(frozen=True)
class Control:
    """``[control]``: the loop closed around the run (derive/docs/control.md)."""
    mode: str
    period: float | None = None
    gain: str = "lqr"
    state_weight: float = 1.0
    input_weight: float = 1.0
    apex_height: float | None = None
    intervals: int = 30
    iterations: int = 1
    solver: str = "sqp"
    duration: float | None = None


@dataclass(frozen=True)
class Disturbance:
    """``[disturbance]``: how the plant differs from the model; ``noise`` (omega,
    attitude, com, com_velocity) standard deviations of what the controller reads;
    ``pushes`` rows (time, P_X, P_Y, P_Z, at_x, at_y, at_z)."""
    seed: int = 0
    mass_factor: float = 1.0
    point_mass_factor: float = 1.0
    inertia_factor: tuple = (1.0, 1.0, 1.0)
    restitution: float | None = None
    noise: tuple = (0.0, 0.0, 0.0, 0.0)
    pushes: tuple = ()

    @property
    def changes_plant(self) -> bool:
        return (self.mass_factor != 1.0 or self.point_mass_factor != 1.0
                or tuple(self.inertia_factor) != (1.0, 1.0, 1.0)
                or self.restitution is not None)


@dataclass(frozen=True)
class Scene:
    name: str
    M: float
    J: tuple                   # J_x, J_y, J_z
    shape: str                 # a name of derive/shapes.py, or none
    size: tuple                # the shape's size numbers (derive/shapes.py)
    center: tuple
    m: float                   # the point's mass (several points: their total)
    law: Any                   # law.Program or table.TableLaw; None for a scene read
    law_text: tuple            # the three strings, or () for a table   without a law
                               # (or with internal bodies other than one point)
    plane: bool
    e: float
    t0: float
    com: tuple
    com_velocity: tuple
    omega: tuple
    A0: np.ndarray = field(compare=False)   # a_ij = cos(fixed i, body j)
    duration: float = 5.0
    method: str = "lie"
    rtol: float = 1e-10
    atol: float = 1e-12
    g: float = 9.81
    outputs: tuple = ("pose", "impacts")
    step: float = 0.0          # RK4 step
    max_events: int = 100000
    max_steps: int = 10_000_000
    output_dt: float = 0.0
    keep_orthonormal: bool = False
    model: str = "auto"
    zeno_dt: float = 1e-9
    source: str = ""
    stability: Stability = Stability()
    law_summary: LawSummary | None = field(default=None, compare=False)
    max_distance: float = 0.0
    control: Control | None = None
    disturbance: Disturbance | None = None
    doc_source: Any = field(default=None, compare=False, repr=False)   # see Scene.doc
    friction: float = 0.0      # mu_f at S ([plane].friction)
    restitution_model: str = "energetic"
    spin_friction: float = 0.0       # mu_s, a length ([plane].spin_friction)
    rolling_resistance: float = 0.0  # mu_r, a length ([plane].rolling_resistance)
    static_friction: float | None = None   # the base model's mu_s (None: not given)
    pressure: str | None = None      # the base model's pressure over the face (None: not given)
    on_plane: bool = False           # [initial].on_plane: S on the plane at the start
    # the fields the scene gave outside [initial] ("[run].method", ...): a model that
    # does not read a key refuses it by name only when it was given (choice.py)
    given: tuple = ()                # (sorted: a Scene compares and prints the same)
    # the internal bodies other than one point (derive/scene/bodies.py): None for one
    # point (the paper's carrier, its law in ``law``), else (points, rotors), the proved
    # Point and Rotor objects, with ``law`` None, ``m`` the points' total mass and
    # ``bodies_law`` the law of them all
    internal: tuple | None = None
    bodies_law: Any = field(default=None, compare=False)

    @classmethod
    def of_fields(cls, base: dict | None = None, **values) -> "Scene":
        """The constructor of the parser: every field given (in ``base`` and ``values``),
        set at once (the frozen dataclass's ``__init__`` sets them one by one through
        ``object.__setattr__``, a tenth of a validation's time)."""
        obj = object.__new__(cls)
        d = obj.__dict__
        if base:
            d.update(base)
        d.update(values)
        if len(d) != len(SCENE_ATTRIBUTES) or not d.keys() <= SCENE_ATTRIBUTES:
            raise TypeError(f"Scene.of_fields needs every field: {sorted(SCENE_ATTRIBUTES)}")
        return obj

    @property
    def doc(self) -> dict:
        """The scene as a dict of the schema, as it was when parsed (a fresh copy on
        every read, so that a caller who edits the dict it gave changes no Scene; {} for a
        Scene made otherwise).  A Scene changed with ``dataclasses.replace`` keeps the
        dict it was parsed from."""
        return self.doc_source.get() if self.doc_source is not None else {}

    @property
    def one_point(self) -> bool:
        """The internal bodies are one point (the paper's carrier; a task's, too)."""
        return self.internal is None

    @property
    def points(self) -> tuple:
        """The points (:class:`derive.scene.bodies.Point`); one point's made from
        ``m`` and ``law`` when asked (so that a Scene given another law by
        ``dataclasses.replace`` says so)."""
        if self.internal is not None:
            return self.internal[0]
        from .bodies import Point
        return (Point("[point]", self.m, self.law, self.law_text, self.law_summary,
                      self.max_distance),)

    @property
    def rotors(self) -> tuple:
        return self.internal[1] if self.internal is not None else ()

    @property
    def runtime_law(self):
        """The law the runtime runs: the one point's (``law``), or that of every body
        (``bodies_law``, a :class:`~derive.scene.law.bodies.BodiesLaw`: the moments
        models)."""
        return self.law if self.internal is None else self.bodies_law

    @property
    def contact_possible(self) -> bool:
        return self.plane and self.shape != "none"

    @property
    def rough(self) -> bool:
        """Contact is possible and the plane has friction (the rough model)."""
        return self.contact_possible and self.friction > 0.0

    @property
    def restitution_given(self) -> bool:
        """[plane].restitution was given (a base scene may leave it out: then ``e`` is
        NaN, and nothing but a flight after a lift-off would read it)."""
        return "[plane].restitution" in self.given

    @property
    def mu_static(self) -> float:
        """The static coefficient over a face (the base model): [plane].static_friction, or
        friction's when it is not given."""
        return self.friction if self.static_friction is None else self.static_friction

    @property
    def reduced_mass(self) -> float:
        """mM/(m+M), the paper's mu (the friction coefficient is :attr:`friction`, mu_f)."""
        return self.M * self.m / (self.M + self.m)

    @property
    def nu(self) -> float:
        return self.m / (self.M + self.m)

    @property
    def p(self) -> tuple:
        return (self.M, self.m, *self.J, self.g)

    @property
    def body_size(self) -> float:
        """The shape's reach (its farthest point from its centre: a sphere's radius, an
        ellipsoid's largest semi-axis), or sqrt(J_max/M) for a body with no shape."""
        return body_size(self.shape, self.size, self.J, self.M)

    def jets(self, ts) -> np.ndarray:
        """The point law at ``ts``: (9, N) x, x', x'', y, y', y'', z, z', z''."""
        return self.law.jets(ts)


SCENE_ATTRIBUTES = frozenset(f.name for f in dataclasses.fields(Scene))
