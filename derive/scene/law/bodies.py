"""The law of a scene's internal bodies as one object, :class:`BodiesLaw`: every point's
x, y, z and every rotor's psi, with their first two derivatives, in one evaluation.

The formula laws become one program (:func:`~.parse.compile_outputs`: one builder for
every string, so a subexpression common to several bodies, ``sin(3*t)`` in two points'
laws, is one node, evaluated once); the points given as tables become one spline on the
union of their knots (each cubic re-expanded about the new knots: the same polynomial,
rounded once).  Each output is a node of the program or a column of the spline.  The C
runtime evaluates it (``crt_set_law_bodies``, ``crt_law.h``); :meth:`BodiesLaw.u` is its
NumPy twin, in the same order (:func:`derive.layout.law_width`): point j at
``u[9 j : 9 j + 9]`` as (x, y, z, x', y', z', x'', y'', z''), then rotor r at
``u[9 n_points + 3 r : ... + 3]`` as (psi, psi', psi'').
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import abi, layout
from ..errors import LawError
from .parse import CoordinateError, compile_outputs
from .program import Program


@dataclass(eq=False)
class BodiesLaw:
    """``out[k]`` for output k (x, y, z of each point, then psi of each rotor): a node
    of ``program`` (>= 0) or ``-1 - c``, column c of the spline (``knots``, ``coef``
    (n_knots - 1, n_columns, 4): c0 s^3 + c1 s^2 + c2 s + c3 with s = t - knot)."""
    n_points: int
    n_rotors: int
    program: Program | None
    out: tuple
    knots: np.ndarray | None = None
    coef: np.ndarray | None = None
    periodic: bool = False

    kind = "bodies"

    @property
    def width(self) -> int:
        """The numbers of u: 9 per point, 3 per rotor."""
        return layout.law_width(self.n_points, self.n_rotors)

    @property
    def n_columns(self) -> int:
        return 0 if self.coef is None else self.coef.shape[1]

    def slot(self, k: int) -> tuple[int, int]:
        """Where output k's value sits in u, and the step to its derivatives."""
        if k < 3 * self.n_points:
            return 9 * (k // 3) + k % 3, 3
        return layout.rotor_slice(self.n_points, k - 3 * self.n_points).start, 1

    def _columns(self, ts: np.ndarray) -> np.ndarray:
        """(n_columns, 3, N): each column's value and two derivatives (as crt_law.h:
        a periodic spline wraps t into its period, another holds its ends)."""
        knots = self.knots
        t0, t1 = knots[0], knots[-1]
        tt = t0 + np.mod(ts - t0, t1 - t0) if self.periodic else np.clip(ts, t0, t1)
        i = np.clip(np.searchsorted(knots, tt, side="right") - 1, 0, len(knots) - 2)
        s = (tt - knots[i])[:, None]
        c = self.coef[i]                                     # (N, n_columns, 4)
        c0, c1, c2, c3 = c[..., 0], c[..., 1], c[..., 2], c[..., 3]
        x = ((c0 * s + c1) * s + c2) * s + c3
        dx = (3.0 * c0 * s + 2.0 * c1) * s + c2
        ddx = 6.0 * c0 * s + 2.0 * c1
        return np.stack([x, dx, ddx]).transpose(2, 0, 1)

    def u(self, ts) -> np.ndarray:
        """(width, N): u at the times ``ts`` (the C's order)."""
        ts = np.asarray(ts, dtype=float).reshape(-1)
        out = np.empty((self.width, ts.size))
        nodes = self.program.node_jets(ts) if self.program is not None else None
        cols = self._columns(ts) if self.knots is not None else None
        for k, src in enumerate(self.out):
            jet = nodes[src] if src >= 0 else cols[-1 - src]
            at, step = self.slot(k)
            for d in range(3):
                out[at + d * step] = jet[d]
        return out

    def arrays(self) -> dict:
        """What crt_set_law_bodies takes (the session keeps these arrays referenced)."""
        prog = self.program.arrays() if self.program is not None else None
        return {"n_points": self.n_points, "n_rotors": self.n_rotors,
                "out": np.array(self.out or (0,), dtype=np.int32),
                "code": prog["code"] if prog else np.zeros((1, 3), dtype=np.int32),
                "n_nodes": len(prog["code"]) if prog else 0,
                "n_const": prog["n_const"] if prog else 0,
                "consts": prog["consts"] if prog else np.zeros(1),
                "knots": np.ascontiguousarray(self.knots if self.knots is not None
                                              else np.zeros(1), dtype=float),
                "n_knots": 0 if self.knots is None else len(self.knots),
                "n_columns": self.n_columns,
                "coef": np.ascontiguousarray((self.coef if self.coef is not None
                                              else np.zeros(1)).reshape(-1), dtype=float),
                "periodic": 1 if self.periodic else 0}


def combine(points: tuple, rotors: tuple) -> BodiesLaw:
    """The law of every body: ``points`` each a point's law (a three-output
    :class:`Program`, or a table law with ``knots``, ``coef`` (n - 1, 3, 4) and
    ``periodic``), ``rotors`` each a one-output Program or a table law whose x is psi.
    Raises LawError when the formulas together pass the runtime's workspace, and
    CoordinateError(k) when table k (of the points', then the rotors' given as tables, in
    order) cannot share a spline with the first."""
    formulas = [(j, p) for j, p in enumerate(points) if p.kind == "program"]
    tables = [(j, p) for j, p in enumerate(points) if p.kind != "program"]
    n_points = len(points)
    tables += [(n_points + r, p) for r, p in enumerate(rotors) if p.kind != "program"]
    texts, slots = [], []
    for j, p in formulas:
        texts += p.text
        slots += [3 * j, 3 * j + 1, 3 * j + 2]
    for r, p in enumerate(rotors):
        if p.kind == "program":
            texts += p.text
            slots.append(3 * n_points + r)
    out = [0] * (3 * n_points + len(rotors))
    program = None
    if texts:
        program = compile_outputs(tuple(texts), abi.LAW_MAX_NODES)
        for slot, node in zip(slots, program.outputs):
            out[slot] = node
    knots = coef = None
    periodic = False
    if tables:
        knots, coef, periodic = merge_tables([p for _, p in tables])
        for c, (j, _) in enumerate(tables):
            if j >= n_points:                    # a rotor's: psi is the table's x
                out[3 * n_points + j - n_points] = -1 - 3 * c
                continue
            for k in range(3):
                out[3 * j + k] = -1 - (3 * c + k)
    return BodiesLaw(n_points, len(rotors), program, tuple(out), knots, coef, periodic)


def merge_tables(tables: list) -> tuple:
    """One spline for several tables: (knots, coef (n - 1, 3 len(tables), 4),
    periodic).  The knots are the union of theirs (two within 1e-12 of the span are
    one); each cubic is re-expanded about the new knots inside it (exact but for one
    rounding), and beyond the ends of a table that does not repeat its end cubics go on.
    Periodic tables share their first and last times; a periodic table and one that
    does not repeat cannot share a spline (CoordinateError(k), k the later table)."""
    first = tables[0]
    if len(tables) == 1:
        return first.knots, first.coef, first.periodic
    for k, tab in enumerate(tables[1:], start=1):
        if tab.periodic != first.periodic:
            raise CoordinateError(k, "is periodic and another table is not (or the other "
                                     "way round): the tables of one scene share one spline, "
                                     "all periodic or none")
        if tab.periodic:
            span = first.knots[-1] - first.knots[0]
            if abs(tab.knots[0] - first.knots[0]) > 1e-12 * span or \
                    abs(tab.knots[-1] - first.knots[-1]) > 1e-12 * span:
                raise CoordinateError(k, "is periodic over "
                                         f"[{tab.knots[0]:.6g}, {tab.knots[-1]:.6g}], another "
                                         f"over [{first.knots[0]:.6g}, "
                                         f"{first.knots[-1]:.6g}]: periodic tables of one "
                                         "scene share their first and last times")
    knots = np.unique(np.concatenate([t.knots for t in tables]))
    if first.periodic:
        knots = knots[(knots >= first.knots[0]) & (knots <= first.knots[-1])]
        knots[0], knots[-1] = first.knots[0], first.knots[-1]
    span = knots[-1] - knots[0]
    keep = np.concatenate([[True], np.diff(knots) > 1e-12 * max(span, 1e-300)])
    keep[-1] = True
    knots = knots[keep]
    if len(knots) > 2 and knots[-1] - knots[-2] <= 1e-12 * span:
        knots = np.delete(knots, -2)
    left = knots[:-1]
    coef = np.concatenate([_reexpand(t, left) for t in tables], axis=1)
    if not np.all(np.isfinite(coef)):
        raise LawError("the spline through the tables is not finite")
    return knots, np.ascontiguousarray(coef), first.periodic


def _reexpand(tab, left: np.ndarray) -> np.ndarray:
    """(len(left), 3, 4): the table's cubics about the knots ``left`` (p(s0 + s) in
    powers of s); outside its span its first and last cubics go on (the runs stay inside
    the span of a table that does not repeat; at its last time the spline is its last
    cubic, as the table's own evaluation)."""
    k = tab.knots
    i = np.clip(np.searchsorted(k, left, side="right") - 1, 0, len(k) - 2)
    s0 = (left - k[i])[:, None]
    c = tab.coef[i]                                          # (M, 3, 4)
    c0, c1, c2, c3 = c[..., 0], c[..., 1], c[..., 2], c[..., 3]
    new = np.stack([c0, c1 + 3.0 * c0 * s0, c2 + (2.0 * c1 + 3.0 * c0 * s0) * s0,
                    ((c0 * s0 + c1) * s0 + c2) * s0 + c3], axis=-1)
    return new
