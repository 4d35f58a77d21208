"""The controller's three columns on a task of several bodies (``[[point]]``,
``[[rotor]]``, ``[plan].decide``): what each column of the re-planned law drives.

The C runtime's controller ABI (``crt_call.h``, ``crt_control.h``) carries three columns,
x, y, z with their two derivatives: one point's law, or, on a law of several bodies,
up to three of its outputs (``crt_control_channels``).  The decided bodies fill them in
``[plan].decide``'s order: a decided point its x, y, z; a decided rotor its psi; the
columns left over are pinned at zero (no rows, bounds 0: the QP sees no variable
there).  The model sees the law only through the bodies' moments
(:class:`derive.planner.bodies.Channels`, the moments the planner composes), the kept
bodies' laws at rest or a kept rotor at a constant rate (a known input: its share reads
psi' and psi'' alone; a kept law that moves otherwise would make the moments depend on
the time, which the controller's state does not carry).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .. import layout
from ..planner.bodies import Channels

ROTOR_STEP_SECONDS = 1.0   # a rotor's control point moves per QP at most STEP_FRACTION
#                            times the angle its rate bound turns in this time


@dataclass(frozen=True)
class Column:
    kind: str         # point | rotor | none
    index: int        # the body in scene.points / scene.rotors (-1: none)
    coordinate: int   # a point's x, y, z (0, 1, 2); 0 for a rotor

    @property
    def name(self) -> str:
        if self.kind == "point":
            return f"point{self.index + 1}_{'xyz'[self.coordinate]}"
        return f"rotor{self.index + 1}_psi" if self.kind == "rotor" else "none"


def check(task) -> str | None:
    """Why the controller cannot re-plan this task of bodies (None: it can)."""
    chans = Channels(task)
    if chans.D > 3:
        return (f"the re-planning controller drives at most three columns (one point, or "
                f"up to three rotors: the runtime's controller carries x, y, z); "
                f"{', '.join(ch.name for ch in chans.channels)} make {chans.D}")
    if chans.timed:
        return (f"the bodies the controller does not decide must be at rest, or a rotor "
                f"at a constant rate ({chans.moving[0]}'s law moves otherwise: the "
                "controller's state has no time to evaluate it at)")
    return None


class Columns:
    """What the three columns drive on a task of bodies (see the module)."""

    def __init__(self, task):
        why = check(task)
        if why is not None:
            raise ValueError(f"replan: {why}")
        self.task = task
        self.channels = Channels(task)
        cols = []
        for ch in self.channels.channels:
            if ch.kind == "point":
                cols += [Column("point", ch.index, c) for c in range(3)]
            else:
                cols.append(Column("rotor", ch.index, 0))
        cols += [Column("none", -1, 0)] * (3 - len(cols))
        self.columns = tuple(cols)
        self.real = [c for c, col in enumerate(cols) if col.kind != "none"]
        self.points = [c for c, col in enumerate(cols) if col.kind == "point"]
        self.rotors = [c for c, col in enumerate(cols) if col.kind == "rotor"]
        # the runtime's output numbers (crt_control_channels): point j's x, y, z at 3 j,
        # 3 j + 1, 3 j + 2, rotor r's psi after every point's, at 3 n_points + r
        n_points = len(task.scene.points)
        self.outputs = tuple(3 * col.index + col.coordinate if col.kind == "point"
                             else 3 * n_points + col.index if col.kind == "rotor" else -1
                             for col in cols)

    @property
    def names(self) -> tuple:
        return tuple(col.name for col in self.columns)

    def moments(self, u9):
        """The 27 moments (CasADi) from the columns' values, rates and accelerations (u9:
        x, y, z, x', ...): the decided bodies' from theirs, the kept ones' at rest."""
        real = self.real
        uD = ca.vertcat(*[u9[d * 3 + c] for d in range(3) for c in real])
        return self.channels.moments(uD, 0.0)

    def bound(self, c: int) -> float:
        """The bound the effort weighs column c's acceleration by."""
        col = self.columns[c]
        return (self.task.max_acceleration if col.kind == "point"
                else self.task.max_rotor_acceleration)

    def step(self, c: int, region_step: float, fraction: float) -> float:
        """Column c's trust region on a control point per QP step."""
        col = self.columns[c]
        if col.kind == "point":
            return region_step
        if col.kind == "rotor":
            return fraction * self.task.max_rotor_rate * ROTOR_STEP_SECONDS
        return 0.0

    def u9(self, law, t) -> np.ndarray:
        """(9, len(t)): a planned law of the decided bodies (D columns of values, rates,
        accelerations) as the controller's three columns (zeros where none)."""
        u = np.asarray(law.u(np.atleast_1d(np.asarray(t, float))))
        D = self.channels.D
        out = np.zeros((9, u.shape[1]))
        for d in range(3):
            for k, c in enumerate(self.real):
                out[3 * d + c] = u[d * D + k]
        return out


class DrivenLaw:
    """A law of bodies (:class:`~derive.scene.law.bodies.BodiesLaw`) with the outputs a
    controller drove replaced by its realised law (``driven``, a table law of three
    columns; ``outputs`` as crt_control_channels'): the law the closed loop ran, which
    the runtime plays as crt_law.h's ctl_* over a BODIES law, for the run's outputs
    (the bodies' positions and angles, their energy, the pictures)."""

    def __init__(self, base, driven, outputs: tuple):
        self.base, self.driven, self.outputs = base, driven, tuple(outputs)

    def __getattr__(self, name):
        return getattr(self.base, name)

    def u(self, t) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        u = np.array(self.base.u(t), dtype=float, copy=True)
        jets = layout.u_of_jets(self.driven.jets(t))
        for c, o in enumerate(self.outputs):
            if o < 0:
                continue
            at, step = self.base.slot(o)
            for d in range(3):
                u[at + d * step] = jets[3 * d + c]
        return u
