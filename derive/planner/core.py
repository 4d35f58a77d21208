"""``derive.plan(task) -> Plan``: solve, tabulate, write the scene, re-simulate, measure.

The pipeline, one way: the task's goal object (:mod:`derive.planner.goals`) is asked
what differs between goals; :func:`derive.planner.solve.solve` gives the NLP's solution
(or the diagnosis of a task it could not solve); the law is tabulated, written as a scene
and re-simulated, and the goal measures what the re-simulation achieves; the summary
(:class:`~derive.planner.summary.Summary`) is plan.json.  Writing the files is
:mod:`derive.planner.outputs`, which imports nothing from here.

The achieved error of every plan is measured on the written ``scene.toml`` and
``law.csv`` by :mod:`derive.planner.resim` (and by the runtime when it reads tables), never
taken from the NLP; the NLP's own estimate is reported beside it.
"""
from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from .. import layout, shapes
from ..scene import toml
from . import cemit
from .goals import goal_of
from .law import Law
from .outputs import write_plan, write_table
from .resim import BC, Trajectory, read_scene, resimulate, runtime_resimulate
from .solve import SolveReport, solve
from .summary import LawStats, Objective, SolverStats, Summary
from .task import Task, load_task
from .transcribe import ACC, POS


@dataclass(repr=False)
class Plan:
    task: Task
    status: str                      # solved | infeasible | failed
    message: str
    summary: Summary                 # plan.json (Summary.to_json)
    law: Law | None = None
    table: np.ndarray | None = None  # law.csv rows
    scene_toml: str = ""
    tables: dict = field(default_factory=dict)     # several bodies: {point1.csv: rows, ...}
    sources: dict = field(default_factory=dict)    # law.c, law.h
    trajectories: dict = field(default_factory=dict)
    report: SolveReport | None = None

    @property
    def ok(self) -> bool:
        return self.status == "solved"

    def __repr__(self) -> str:                 # (the fields hold whole trajectories)
        what = (f"{self.law.spline.n} pieces over {self.law.T:.6g} s"
                if self.ok and self.law is not None else self.message[:120])
        return f"<Plan {self.summary.goal}: {self.status}; {what}>"

    def write(self, out) -> list[Path]:
        """Write law.csv, scene.toml, plan.json, law.c, law.h and the plots to ``out``."""
        return write_plan(self, Path(out))


# ---- the law as a table -------------------------------------------------------------
def tabulate(law: Law, t_end: float | None = None, per_piece: int = 32):
    """(rows (t, x, y, z, x', ..., z''), reproduction error): a grid containing the knots,
    refined until the runtime's spline reproduces the law's position to 1e-11."""
    T = law.T
    t_end = T if t_end is None else t_end
    bc = BC[law.ends] if law.ends != "rest" else ((1, np.zeros(3)), (1, np.zeros(3)))
    h = T / law.spline.n
    err = np.inf
    while True:
        n_main = law.spline.n * per_piece
        t = np.linspace(0.0, T, n_main + 1)
        if t_end > T:
            extra = max(2, math.ceil((t_end - T) / (h / per_piece)))
            t = np.r_[t, np.linspace(T, t_end, extra + 1)[1:]]
        u = law.u(t)
        if law.ends == "periodic":
            u[:, -1] = u[:, 0]
        sp = CubicSpline(t, u[layout.U.r].T, axis=0, bc_type=bc)
        mid = 0.5 * (t[1:] + t[:-1])
        quarter = t[:-1] + 0.25 * np.diff(t)
        probe = np.r_[mid, quarter]
        err = float(np.max(np.abs(sp(probe).T - law.u(probe)[layout.U.r])))
        if err < 1e-11 or per_piece >= 2048:
            break
        per_piece *= 2
    return np.column_stack([t, u.T]), err


# ---- the planned scene --------------------------------------------------------------
def scene_document(task: Task, law: Law, initial: dict, duration: float) -> dict:
    """The task's scene with the planned law as a table: only numbers and fixed
    strings from the whitelists are written (the task's name is not copied)."""
    sc = task.scene
    body = {"mass": sc.M, "inertia": list(sc.J), "shape": sc.shape}
    if sc.shape != shapes.NONE:
        body.update(shapes.fields_of(shapes.of(sc.shape), sc.size))
        body["center"] = list(sc.center)
    doc = {"name": f"planned-{task.goal}", "body": body,
           "point": {"mass": sc.m, "table": "law.csv", "ends": law.ends}}
    if sc.plane:
        doc["plane"] = {"restitution": sc.e}
    doc["initial"] = initial
    doc["run"] = {"duration": duration, "method": "dop853", "rtol": 1e-12, "atol": 1e-14,
                  "g": sc.g, "outputs": ["pose", "omega", "impacts"]}
    return doc


def scene_toml(doc: dict) -> str:
    """The planned scene as TOML: numbers and the fixed strings of scene_document only
    (the task's own strings, its name included, are not copied)."""
    return toml.dumps(doc, ("Planned by `derive plan`: the task's scene with the planned law "
                            "as a table.", "`derive simulate scene.toml` reproduces the plan."))


def plan(task, progress: bool = False, runtime: bool = True) -> Plan:
    """Plan the point's law for a task (a path, a dict or a :class:`Task`)."""
    t_start = time.perf_counter()
    task = load_task(task)
    if task.goal == "travel":               # no NLP: a search over the base model's runs
        from .travel import plan as plan_travel
        return plan_travel(task, progress=progress)
    goal = goal_of(task)
    report = solve(task, goal, progress=progress)
    stability, attempts = None, []
    if report.success:
        report, stability, attempts = goal.refine(task, report, progress)
    summary = Summary(goal=task.goal, objective=Objective(task.objective),
                      solver=SolverStats.of(report), stability_attempts=attempts)
    if not report.success:
        infeasible = "infeasible" in report.message or report.blocking.get("limit")
        summary.status = "infeasible" if infeasible else "failed"
        summary.message, summary.blocking = report.message, report.blocking or None
        summary.total_seconds = time.perf_counter() - t_start
        return Plan(task, summary.status, report.message, summary, report=report)

    if task.bodies:
        return _plan_bodies(task, goal, report, summary, t_start, runtime)
    tr = report.tr
    ctrl, Q, T = tr.unpack(report.result.w)
    law = Law(tr.spline, ctrl, T, tr.kind, task.circle[:3] if task.circle else (),
              goal.table_ends(task), rest=goal.law_rests(task))
    sched = goal.schedule(task, tr, Q, T)
    table, repro = tabulate(law, sched.t_table)
    text = scene_toml(scene_document(task, law, sched.initial, sched.duration))
    sources = cemit.render(law)
    u = law.u(np.linspace(0, T, 64 * tr.N + 1))
    summary.law = LawStats(
        kind=law.kind, pieces=tr.N, duration=T, ends=law.ends, table_rows=int(table.shape[0]),
        table_reproduction_error=repro,
        max_acceleration=float(np.max(np.linalg.norm(u[ACC], axis=0))),
        max_distance_from_region_center=float(np.max(np.linalg.norm(
            u[POS].T - task.region_center, axis=1))),
        effort=tr.effort_of(report.result.w))
    summary.objective = Objective.of(task.objective, summary.law)
    summary.nlp_estimate = sched.nlp_estimate
    # re-simulate the written files
    trajectories, achieved = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.toml"
        write_table(Path(tmp) / "law.csv", table)
        path.write_text(text, encoding="utf-8")
        traj = resimulate(path)
        _attach_u(traj, path)
        trajectories["scipy"] = traj
        achieved["scipy"] = goal.measure(task, law, traj, sched.extra)
        if runtime:
            rt = runtime_resimulate(path)
            if isinstance(rt, str):
                achieved["runtime"] = {"available": False, "reason": rt}
            else:
                _attach_u(rt, path)
                trajectories["runtime"] = rt
                achieved["runtime"] = goal.measure(task, law, rt, sched.extra)
    summary.achieved, summary.stability = achieved, stability
    summary.status, summary.message = "solved", report.message
    summary.total_seconds = time.perf_counter() - t_start
    return Plan(task, "solved", report.message, summary, law=law, table=table,
                scene_toml=text, sources=sources, trajectories=trajectories, report=report)


def _plan_bodies(task: Task, goal, report: SolveReport, summary: Summary, t_start: float,
                 runtime: bool) -> Plan:
    """The solved plan of a task of several bodies: a table per decided body, the scene,
    its re-simulations (derive.planner.bodies_plan, resim.resimulate_bodies)."""
    from . import bodies_plan as bp
    from .resim import resimulate_bodies
    tr = report.tr
    w = report.result.w
    ctrl, Q, T = tr.unpack(w)
    ends = "rest" if task.rest_at_ends else "free"
    law = Law(tr.spline, ctrl, T, "cartesian", (), ends, rest=task.rest_at_ends)
    sched = goal.schedule(task, tr, Q, T)
    tables, repro = bp.tabulate(law, tr.channels, sched.t_table)
    text = scene_toml(bp.scene_document(task, tr.channels, law, sched.initial,
                                        sched.duration))
    summary.law = bp.law_stats(task, tr, law, tables, repro, w)
    summary.objective = Objective.of(task.objective, summary.law)
    summary.nlp_estimate = sched.nlp_estimate
    trajectories, achieved = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.toml"
        for name, rows in tables.items():
            bp.write_table(Path(tmp) / name, rows)
        path.write_text(text, encoding="utf-8")
        traj = resimulate_bodies(path)
        trajectories["scipy"] = traj
        achieved["scipy"] = goal.measure(task, law, traj, sched.extra)
        if runtime:
            rt = runtime_resimulate(path)
            if isinstance(rt, str):
                achieved["runtime"] = {"available": False, "reason": rt}
            else:
                trajectories["runtime"] = rt
                achieved["runtime"] = goal.measure(task, law, rt, sched.extra)
    summary.achieved = achieved
    summary.status, summary.message = "solved", report.message
    summary.total_seconds = time.perf_counter() - t_start
    return Plan(task, "solved", report.message, summary, law=law, scene_toml=text,
                trajectories=trajectories, report=report, tables=tables)


def _attach_u(traj: Trajectory, scene_path: Path):
    _, law, _ = read_scene(scene_path)
    for imp in traj.impacts:
        imp["u"] = law(imp["t"])
