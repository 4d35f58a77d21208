"""``derive.plan(task) -> Plan``: solve, tabulate, write the scene, re-simulate, measure.

The achieved error of every plan is measured on the written ``scene.toml`` and
``law.csv`` by :mod:`derive.planner.resim` (and by the runtime when it reads tables), never
taken from the NLP; the NLP's own estimate is reported beside it.
"""
from __future__ import annotations

import json
import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from ..scene import toml
from . import cemit
from .law import Law
from .resim import BC, Trajectory, rotation_angle, resimulate, runtime_resimulate
from .solve import SolveReport, solve
from .task import Task, load_task

LAND_EXTENSION = 0.05        # the table runs this fraction of T past touchdown
HOP_PERIODS = 4              # periods re-simulated for a hop


@dataclass
class Plan:
    task: Task
    status: str                      # solved | infeasible | failed
    message: str
    summary: dict                    # the content of plan.json
    law: Law | None = None
    table: np.ndarray | None = None  # law.csv rows
    scene_toml: str = ""
    sources: dict = field(default_factory=dict)    # law.c, law.h
    trajectories: dict = field(default_factory=dict)
    report: SolveReport | None = None

    @property
    def ok(self) -> bool:
        return self.status == "solved"

    def write(self, out) -> list[Path]:
        """Write law.csv, scene.toml, plan.json, law.c, law.h and the plots to ``out``."""
        from .outputs import write_plan
        return write_plan(self, Path(out))


# ---- the law as a table -------------------------------------------------------------
def table_ends(task: Task) -> str:
    if task.goal == "hop":
        return "periodic"
    if task.goal == "reorient" and task.rest_at_ends:
        return "periodic" if task.circle is None else "rest"
    return "free"


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
        sp = CubicSpline(t, u[0:3].T, axis=0, bc_type=bc)
        mid = 0.5 * (t[1:] + t[:-1])
        quarter = t[:-1] + 0.25 * np.diff(t)
        probe = np.r_[mid, quarter]
        err = float(np.max(np.abs(sp(probe).T - law.u(probe)[0:3])))
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
    if sc.shape == "sphere":
        body["radius"] = sc.size[0]
    elif sc.shape == "ellipsoid":
        body["semi_axes"] = list(sc.size)
    if sc.shape != "none":
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


def _initial_from_task(task: Task) -> dict:
    sc = task.scene
    return {"time": 0.0, "com": list(sc.com), "com_velocity": list(sc.com_velocity),
            "omega": list(sc.omega), "matrix": [list(r) for r in np.asarray(sc.A0)]}


def _matrix_from_n(n) -> np.ndarray:
    n = np.asarray(n, float) / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    r1 = helper - n * (n @ helper)
    r1 /= np.linalg.norm(r1)
    r2 = np.cross(n, r1)
    return np.array([r1, r2, n])


# ---- measuring -------------------------------------------------------------------------
def measure(task: Task, law: Law, traj: Trajectory, extra: dict) -> dict:
    """The achieved errors of a re-simulation, in the goal's terms."""
    out = {"source": traj.source, "status": traj.status}
    g = task.scene.g
    if task.goal == "reorient":
        A = traj.q[-1, 9:18].reshape(3, 3)
        out.update(t_end=float(traj.t[-1]), attitude_error_rad=rotation_angle(task.target, A),
                   omega_end=traj.q[-1, 6:9].tolist(),
                   orthonormality=float(np.max(np.abs(A @ A.T - np.eye(3)))))
        return out
    if not traj.impacts:
        out["error"] = "no impact in the re-simulation"
        return out
    first = traj.impacts[0]
    if task.goal == "land":
        qm = first["q_minus"]
        out.update(touchdown_time=first["t"], touchdown_time_error=first["t"] - law.T,
                   v_n_minus=first["v_minus"])
        if task.at_touchdown == "attitude":
            out["attitude_error_rad"] = rotation_angle(task.target, qm[9:18].reshape(3, 3))
        else:
            from .functions import load, lowest_point
            sc = task.scene
            s = np.array(lowest_point(sc.shape, qm[15:18], sc.center, sc.size).full()).ravel()
            p = [sc.M, sc.m, *sc.J, sc.g]
            _, d = load("lever")(qm, first["u"], s, p)
            out["d_norm"] = float(np.linalg.norm(np.array(d.full()).ravel()))
            out["omega_jump"] = float(np.linalg.norm(first["q_plus"][6:9] - qm[6:9]))
        return out
    # hop: every impact, the post-impact vertical state against the planned one
    planned = extra["post_impact"]
    T = law.T
    rows = []
    for k, imp in enumerate(traj.impacts):
        qp = imp["q_plus"]
        vert = np.r_[qp[2], qp[5], qp[6:9], qp[15:18]]
        apex = qp[2] + qp[5] ** 2 / (2 * g)
        rows.append({"t": imp["t"], "apex": apex, "state_error": float(np.max(np.abs(
            vert - planned))), "phase_error": float((imp["t"] - round(imp["t"] / T) * T))})
    out.update(impacts=len(rows), period=T,
               apex_error=float(max(abs(r["apex"] - task.apex_height) for r in rows)),
               first_period_state_error=rows[0]["state_error"],
               first_period_phase_error=rows[0]["phase_error"],
               max_state_error=float(max(r["state_error"] for r in rows)),
               per_impact=[{k: float(v) for k, v in r.items()} for r in rows])
    return out


def plan(task, progress: bool = False, runtime: bool = True) -> Plan:
    """Plan the point's law for a task (a path, a dict or a :class:`Task`)."""
    t_start = time.perf_counter()
    task = load_task(task)
    report = solve(task, progress=progress)
    stability, attempts = None, []
    if task.goal == "hop" and report.success:
        report, stability, attempts = _stable_hop(task, report, progress)
    tr = report.tr
    summary = {"goal": task.goal, "objective": {"kind": task.objective},
               "solver": {"ipopt_and_defect_correction_seconds": report.solver_seconds,
                          "nlp_build_seconds": report.build_seconds,
                          "solves": report.rounds,
                          "iterations": int(sum(r["iterations"] for r in report.rounds)),
                          "intervals": tr.N, "rk4_substeps": tr.m,
                          "variables": int(tr.w.shape[0]), "constraints": int(tr.g.shape[0]),
                          "continuity_with_exact_flow": report.continuity_exact}}
    if attempts:
        summary["stability_attempts"] = attempts
    if report.success and task.goal == "hop" and task.require_stable \
            and not stability["stable"]:
        report.success = False
        tried = f"the effort-optimal orbit is {attempts[0]['verdict']}"
        if len(attempts) > 1:
            tried += f"; with the stability conditions: {attempts[1]['verdict']}"
        report.message = f"infeasible: require_stable: no stable orbit ({tried})"
    if not report.success:
        status = "infeasible" if "infeasible" in report.message or report.blocking else "failed"
        summary.update(status=status, message=report.message,
                       blocking=report.blocking or None,
                       total_seconds=time.perf_counter() - t_start)
        return Plan(task, status, report.message, summary, report=report)

    ctrl, Q, T = tr.unpack(report.result.w)
    law = Law(tr.spline, ctrl, T, tr.kind, task.circle[:3] if task.circle else (),
              table_ends(task), rest=task.rest_at_ends and task.goal != "hop")
    extra = {}
    if task.goal == "reorient":
        initial, duration, t_table = _initial_from_task(task), T, T
        nlp_est = {"attitude_error_rad": rotation_angle(task.target, tr.layout.A_of(Q[:, -1]))}
    elif task.goal == "land":
        initial, duration = _initial_from_task(task), T * (1 + 0.5 * LAND_EXTENSION)
        t_table = T * (1 + LAND_EXTENSION)
        qN = Q[:, -1]
        nlp_est = {"touchdown_time": T}
        if task.at_touchdown == "attitude":
            nlp_est["attitude_error_rad"] = rotation_angle(task.target, tr.layout.A_of(qN))
    else:
        k = tr.N // 2
        qm = Q[:, k]
        A = _matrix_from_n(qm[5:8])
        initial = {"time": k * T / tr.N, "com": [0.0, 0.0, qm[0]],
                   "com_velocity": [0.0, 0.0, qm[1]], "omega": list(qm[2:5]),
                   "matrix": [list(r) for r in A]}
        duration, t_table = HOP_PERIODS * T, T
        extra["post_impact"] = Q[:, 0]
        nlp_est = {"period": T, "apex": float(Q[0, 0] + Q[1, 0] ** 2 / (2 * task.scene.g)),
                   "post_impact_state": Q[:, 0].tolist()}
    table, repro = tabulate(law, t_table)
    doc = scene_document(task, law, initial, duration)
    text = scene_toml(doc)
    sources = cemit.render(law)
    u = law.u(np.linspace(0, T, 64 * tr.N + 1))
    summary["law"] = {"kind": law.kind, "pieces": tr.N, "duration": T, "ends": law.ends,
                      "table_rows": int(table.shape[0]),
                      "table_reproduction_error": repro,
                      "max_acceleration": float(np.max(np.linalg.norm(u[6:9], axis=0))),
                      "max_distance_from_region_center": float(np.max(np.linalg.norm(
                          u[0:3].T - task.region_center, axis=1))),
                      "effort": float(np.array(_effort(tr, report.result.w)))}
    summary["objective"] = ({"kind": "effort", "value": summary["law"]["effort"],
                             "unit": "m^2/s^3 (integral of |OP''|^2)"}
                            if task.objective == "effort" else
                            {"kind": "time", "value": T, "unit": "s"})
    summary["nlp_estimate"] = nlp_est
    # re-simulate the written files
    trajectories = {}
    with tempfile.TemporaryDirectory() as tmp:
        _write_table(Path(tmp) / "law.csv", table)
        (Path(tmp) / "scene.toml").write_text(text, encoding="utf-8")
        traj = resimulate(Path(tmp) / "scene.toml")
        _attach_u(traj, Path(tmp) / "scene.toml")
        trajectories["scipy"] = traj
        achieved = {"scipy": measure(task, law, traj, extra)}
        if runtime:
            rt = runtime_resimulate(Path(tmp) / "scene.toml")
            if isinstance(rt, str):
                achieved["runtime"] = {"available": False, "reason": rt}
            else:
                _attach_u(rt, Path(tmp) / "scene.toml")
                trajectories["runtime"] = rt
                achieved["runtime"] = measure(task, law, rt, extra)
    summary["achieved"] = achieved
    if stability is not None:
        summary["stability"] = stability
    summary.update(status="solved", message=report.message,
                   total_seconds=time.perf_counter() - t_start)
    return Plan(task, "solved", report.message, summary, law, table, text, sources,
                trajectories, report)


def _hop_law(report: SolveReport) -> tuple:
    ctrl, Q, T = report.tr.unpack(report.result.w)
    return Law(report.tr.spline, ctrl, T, "cartesian", (), "periodic"), Q


def _stable_hop(task: Task, report: SolveReport, progress: bool):
    """The effort-optimal orbit; if its multipliers say unstable, the orbit with the
    stability conditions of :meth:`Transcription._hop_stability`, kept if stable (or
    less unstable)."""
    from .stability import analyse
    law, Q = _hop_law(report)
    first = analyse(report.tr, law, Q)
    attempts = [{"conditions": False, "verdict": first["verdict"],
                 "max_modulus": first["max_modulus"], "effort": _effort(report.tr,
                                                                        report.result.w)}]
    if first["stable"]:
        return report, first, attempts
    second = solve(task, progress=progress, w0=report.result.w, stabilize=True,
                   diagnose=False)
    if not second.success:
        attempts.append({"conditions": True, "verdict": second.message})
        return report, first, attempts
    law2, Q2 = _hop_law(second)
    stab2 = analyse(second.tr, law2, Q2)
    attempts.append({"conditions": True, "verdict": stab2["verdict"],
                     "max_modulus": stab2["max_modulus"],
                     "effort": _effort(second.tr, second.result.w)})
    second.rounds = report.rounds + second.rounds
    second.solver_seconds += report.solver_seconds
    second.build_seconds += report.build_seconds
    if stab2["stable"] or stab2["max_modulus"] < first["max_modulus"]:
        return second, stab2, attempts
    return report, first, attempts


def _effort(tr, w):
    import casadi as ca
    f = ca.Function("effort", [tr.w], [tr.effort])
    return float(f(w))


def _attach_u(traj: Trajectory, scene_path: Path):
    from .resim import read_scene
    _, law, _ = read_scene(scene_path)
    for imp in traj.impacts:
        imp["u"] = law(imp["t"])


def _write_table(path: Path, table: np.ndarray):
    head = "t,x,y,z,x',y',z',x'',y'',z''"
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(head + "\n")
        for row in table:
            fh.write(",".join(repr(float(v)) for v in row) + "\n")


def summary_json(summary: dict) -> str:
    def default(o):
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.floating, np.integer)):
            return o.item()
        raise TypeError(type(o))
    return json.dumps(summary, indent=2, default=default) + "\n"
