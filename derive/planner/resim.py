"""Re-simulation of a planned scene: the *achieved* result, not the NLP's estimate.

A planned ``scene.toml`` carries its law as a table (``[point].table``, ``ends``), which
the runtime interpolates with a C^2 cubic spline (SciPy ``CubicSpline`` semantics).
Until the runtime on this branch reads tables, this adapter integrates the scene itself:

* :func:`resimulate` — the same spline (``CubicSpline`` with bc ``periodic``,
  ``clamped`` for ``rest``, ``not-a-knot`` for ``free``), the derived ``general`` flight
  right-hand side, gap, lowest point and impact map (CasADi functions from
  ``generated/casadi``), integrated by the SciPy peer the benchmarks use
  (:mod:`derive.scipy_hybrid`: DOP853 at rtol 1e-12, impacts located as events of the
  gap, the impact map applied when v_n < 0);
* :func:`runtime_resimulate` — ``derive.simulate`` itself, tried on the scene: when the
  runtime accepts ``[point].table`` its result is used too; otherwise the reason is
  recorded.

Both return a :class:`Trajectory`, which :func:`derive.planner.measure` reads.  This module is
the only place to change when the runtime alone should be used.
"""
from __future__ import annotations

import bisect
import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from .. import abi
from ..models import STATE_LABELS
from ..scene import Scene, SceneError, load_scene
from ..scipy_hybrid import Functions, Hybrid
from .functions import Fast, load

BC = {"periodic": "periodic", "rest": "clamped", "free": "not-a-knot"}
ATTITUDE = tuple(f"a{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
OMEGA = ("omega_x", "omega_y", "omega_z")


def rows(labels) -> list:
    """Where the entries ``labels`` sit in a trajectory's state (the general layout)."""
    return [STATE_LABELS["general"].index(lb) for lb in labels]


def attitude_of(q) -> np.ndarray:
    """a_ij of a state of the general layout."""
    return np.asarray(q)[rows(ATTITUDE)].reshape(3, 3)


@dataclass
class Trajectory:
    t: np.ndarray                 # (N,)
    q: np.ndarray                 # (N, 18), general layout
    impacts: list = field(default_factory=list)   # dicts: t, I, v_minus, v_plus, q_minus, q_plus
    status: str = "done"
    source: str = ""


def read_table(path: Path, names: tuple = ("t", "x", "y", "z"), where: str = "[point].table"):
    """(t, values) from a law table: header row, the columns ``names`` used (t, x, y, z;
    a rotor's t, psi)."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise SceneError(where, f"cannot be read ({exc})") from None
    if len(rows) < 3:
        raise SceneError(where, "needs a header and at least two rows")
    head = [h.strip() for h in rows[0]]
    try:
        cols = [head.index(c) for c in names]
    except ValueError:
        raise SceneError(where, f"needs columns {', '.join(names)}") from None
    data = np.array([[float(r[c]) for c in cols] for r in rows[1:]])
    if not np.all(np.isfinite(data)) or np.any(np.diff(data[:, 0]) <= 0):
        raise SceneError(where, "t must increase and every value be finite")
    return data[:, 0], data[:, 1:]


class SplineLaw:
    """The runtime's reading of a table: a C^2 cubic spline of (x, y, z) (of psi, for a
    rotor's)."""

    def __init__(self, t, xyz, ends: str):
        if ends not in BC:
            raise SceneError("[point].ends", f"must be one of {', '.join(BC)}")
        self.t0, self.t1, self.ends = float(t[0]), float(t[-1]), ends
        bc = BC[ends]
        if ends == "rest":
            width = np.asarray(xyz).shape[1]
            bc = ((1, np.zeros(width)), (1, np.zeros(width)))
        self.spline = CubicSpline(t, xyz, axis=0, bc_type=bc)
        self.d1, self.d2 = self.spline.derivative(1), self.spline.derivative(2)
        self.x, self.c = self.spline.x, self.spline.c        # c[k, i]: of (t - x_i)^(3-k)

    def __call__(self, t) -> np.ndarray:
        """(9,) for a number t, (9, N) for an array: x, y, z, x', y', z', x'', y'', z''
        (outside the table: periodic wrap, or the end pieces extended)."""
        if np.ndim(t) == 0:
            tt = float(t)
            if self.ends == "periodic":
                tt = self.t0 + (tt - self.t0) % (self.t1 - self.t0)
            i = min(max(bisect.bisect_right(self.x, tt) - 1, 0), len(self.x) - 2)
            d = tt - self.x[i]
            c = self.c[:, i, :]
            val = ((c[0] * d + c[1]) * d + c[2]) * d + c[3]
            d1 = (3 * c[0] * d + 2 * c[1]) * d + c[2]
            d2 = 6 * c[0] * d + 2 * c[1]
            return np.concatenate([val, d1, d2])
        tt = np.asarray(t, dtype=float)
        if self.ends == "periodic":
            tt = self.t0 + np.mod(tt - self.t0, self.t1 - self.t0)
        return np.concatenate([np.asarray(self.spline(tt)).T, np.asarray(self.d1(tt)).T,
                               np.asarray(self.d2(tt)).T])


def read_scene(scene_path) -> tuple[Scene, SplineLaw, dict]:
    """The planned scene, validated by the scene parser (with its table), and the table
    as a spline of SciPy's: the re-simulation evaluates the law independently of the
    runtime's spline."""
    path = Path(scene_path)
    scene = load_scene(path)
    doc = scene.doc
    point = doc.get("point", {})
    t, xyz = read_table(path.parent / point["table"])
    return scene, SplineLaw(t, xyz, point.get("ends", "free")), doc


def _state0(scene: Scene) -> np.ndarray:
    return np.r_[scene.com, scene.com_velocity, scene.omega, np.asarray(scene.A0).ravel()]


def resimulate(scene_path, rtol: float = 1e-12, max_impacts: int = 1000) -> Trajectory:
    """Integrate the planned scene with the SciPy peer (:mod:`derive.scipy_hybrid`:
    DOP853, impacts as events) on the derived CasADi functions."""
    scene, law, _ = read_scene(scene_path)
    contact = scene.contact_possible
    fns = Functions(Fast(load("general_flight_rhs")), *(
        (Fast(load("general_gap")), Fast(load("general_impact")),
         Fast(load(f"lowest_point_{scene.shape}"))) if contact else ()))
    hybrid = Hybrid(fns, law, [scene.M, scene.m, *scene.J, scene.g],
                    contact=contact, e=scene.e, center=scene.center,
                    size=scene.size, method="DOP853", rtol=rtol, max_impacts=max_impacts)
    path = hybrid.run(scene.t0, scene.t0 + scene.duration, _state0(scene))
    return Trajectory(path.t, path.q, path.impacts, path.status, "scipy-dop853")


class BodiesMoments:
    """The moments of a planned scene of several bodies at t (27 numbers): each body's
    law read independently of the runtime's spline (a table by SciPy's CubicSpline of
    its CSV, a formula by its program), its share by the derived ``point_moments`` and
    ``rotor_moments``, summed."""

    def __init__(self, scene: Scene, doc: dict, folder: Path):
        from ..layout import MOMENTS
        self.spin = MOMENTS.spin
        self.pm, self.rm = Fast(load("point_moments")), Fast(load("rotor_moments"))
        self.points, self.rotors = [], []
        for k, (p, el) in enumerate(zip(scene.points, _elements(doc, "point"))):
            where = f"[[point]] {k + 1}: table"
            law = (SplineLaw(*read_table(folder / el["table"], where=where),
                             el.get("ends", "free")) if "table" in el else p.law.point)
            self.points.append((p.mass, law))
        for k, (r, el) in enumerate(zip(scene.rotors, _elements(doc, "rotor"))):
            where = f"[[rotor]] {k + 1}: table"
            if "table" in el:
                law = SplineLaw(*read_table(folder / el["table"], ("t", "psi"), where),
                                el.get("ends", "free"))
            else:
                law = _angle(r.law)
            self.rotors.append((np.asarray(r.axis, float), r.inertia, law))

    def __call__(self, t) -> np.ndarray:
        out = np.zeros(27)
        for mass, law in self.points:
            out += self.pm(mass, law(t))[0]
        for axis, inertia, law in self.rotors:
            psi = law(t)
            out[self.spin] += self.rm(axis, inertia, psi[1:3])[0]
        return out


def _elements(doc: dict, name: str) -> list:
    items = doc.get(name, [])
    return items if isinstance(items, list) else [items]


def _angle(program):
    def psi(t):
        return program.jets([t])[:, 0]
    return psi


def resimulate_bodies(scene_path, rtol: float = 1e-12, max_impacts: int = 1000) -> Trajectory:
    """A planned scene of several bodies integrated by the SciPy peer on the moments
    models' derived functions (``moments_flight_rhs``, ``moments_gap``,
    ``moments_impact``), the moments from :class:`BodiesMoments`."""
    path = Path(scene_path)
    scene = load_scene(path)
    moments = BodiesMoments(scene, scene.doc, path.parent)
    contact = scene.contact_possible
    fns = Functions(Fast(load("moments_flight_rhs")), *(
        (Fast(load("moments_gap")), Fast(load("moments_impact")),
         Fast(load(f"lowest_point_{scene.shape}"))) if contact else ()))
    hybrid = Hybrid(fns, moments, [scene.M, scene.m, *scene.J, scene.g],
                    contact=contact, e=scene.e, center=scene.center,
                    size=scene.size, method="DOP853", rtol=rtol, max_impacts=max_impacts)
    run = hybrid.run(scene.t0, scene.t0 + scene.duration, _state0(scene))
    return Trajectory(run.t, run.q, run.impacts, run.status, "scipy-dop853")


def runtime_resimulate(scene_path) -> Trajectory | str:
    """``derive.simulate`` on the planned scene, or the reason it cannot run it."""
    try:
        from ..runtime.driver import simulate
        result = simulate(str(scene_path), progress=False)
    except SceneError as exc:
        return f"the runtime does not read this scene yet ({exc})"
    except Exception as exc:       # noqa: BLE001 - recorded, not raised: the adapter decides
        return f"the runtime failed ({type(exc).__name__}: {exc})"
    if "X_C" not in result.state_names:
        return "the runtime did not return the pose"
    impacts = []
    kinds = np.asarray(result.row_kind)
    before = np.flatnonzero(kinds == abi.ROW_KIND["before_event"])
    for i in before:
        if i + 1 < len(kinds) and kinds[i + 1] == abi.ROW_KIND["after_event"]:
            ev = [e for e in result.events if e["kind"] == "impact"
                  and abs(e["t"] - result.t[i]) <= 1e-9 * max(1.0, abs(result.t[i]))]
            if ev:
                impacts.append({"t": float(result.t[i]), "I": ev[0]["value"],
                                "v_minus": ev[0]["v_minus"], "v_plus": ev[0]["v_plus"],
                                "q_minus": result.q[i], "q_plus": result.q[i + 1]})
    return Trajectory(np.asarray(result.t), np.asarray(result.q), impacts, result.status,
                      "runtime")


def rotation_angle(A_target, A) -> float:
    """The angle of A_target^T A, robust near 0 and pi."""
    R = np.asarray(A_target).T @ np.asarray(A)
    s = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    c = 0.5 * (np.trace(R) - 1.0)
    return float(math.atan2(s, c))
