"""``derive control TASK.toml -o DIR`` and ``derive.control(task)``: a controller closed
around the plant a task's ``[disturbance]`` makes, measured against the open loop.

A control task is a plan task (``[plan]``, as for ``derive plan``) with a ``[control]``
table (``mode``, ``period``, ...) and, optionally, a ``[disturbance]``.  The pipeline
dispatches on ``[control].mode`` (:data:`MODES`): each mode's module has
``run(task, progress) -> ControlResult``.  This module holds what every mode shares:
reading the task, the plant scene of a plan (its law as samples, the disturbance
applied), measuring a run in the plan's own terms (the keys of plan.json's
``achieved.runtime``) and writing the outputs.
"""
from __future__ import annotations

import importlib
import math
import shutil
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import abi
from ..scene import SceneError

# mode -> (module, function): run(task, progress) -> ControlResult
MODES = {
    "replan": ("derive.control.replan", "run"),
    "hop": ("derive.control.core", "scene_mode"),
    "mirror": ("derive.control.core", "scene_mode"),
}
# the files a run writes, for clearing what an earlier run left
OUTPUT_FILES = ("control.json", "trajectory.csv", "events.csv", "law.csv", "motion.gif")
LAND_MARGIN = 0.2           # land's default duration: the plan's horizon and a fifth more
DEFAULT_PERIOD = {"replan": 0.02, "mirror": 0.002, "hop": 0.0}
GOAL_TOLERANCE_DEG = 2.0    # a loop meets its goal within this (control.json: goal_met)


class ControlError(RuntimeError):
    """The pipeline could not close the loop (the offline plan or its solution failed, or
    its scene did not run as the plant)."""


SCENE_MODES = ("hop", "mirror")      # closed around a scene's own gait: derive simulate


def _scene_mode_message(mode: str) -> str:
    return (f"{mode} closes the loop around a scene's gait, not a planned task: run the "
            "scene with `derive simulate` (derive/control/examples/hop.toml, mirror.toml)")


def load_control_task(task):
    """A plan task that carries ``[control]`` (SceneError otherwise; a scene of mode hop
    or mirror, which has no [plan], is told where it runs)."""
    from ..planner.task import load_task
    try:
        task = load_task(task)
    except SceneError as exc:
        mode = _mode_of(task)
        if mode in SCENE_MODES and "[plan]" in str(exc):
            raise SceneError("[control].mode", _scene_mode_message(mode)) from None
        raise
    if task.scene.control is None:
        raise SceneError("[control]", "is required (derive control closes a loop around "
                                      "a planned task: give mode = \"replan\")")
    if task.spin_weight and task.bodies:
        raise SceneError("[plan].spin_weight", "is weighed for the paper's one point; a "
                                               "task of [[point]] and [[rotor]] does not "
                                               "weigh it: remove it to close the loop")
    return task


def _mode_of(task) -> str | None:
    """[control].mode of a task given as a path or a dict, if it can be read."""
    try:
        if isinstance(task, dict):
            doc = task
        else:
            import tomllib
            from ..scene.parse import read_file
            doc = tomllib.loads(read_file(task, "task"))
        mode = doc.get("control", {}).get("mode")
        return mode if isinstance(mode, str) else None
    except Exception:                     # the load's own error is the one to report
        return None


def mode_runner(mode: str):
    module, name = MODES[mode]
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name != module:              # a module it imports is missing: a real error
            raise
        raise SceneError("[control].mode", f"{mode} is not available in this version") \
            from None
    return getattr(mod, name)


def scene_mode(task, progress: bool = False):
    """hop and mirror close the loop around a scene's own gait (derive.control.closed),
    not around a plan: say where they run."""
    raise SceneError("[control].mode", _scene_mode_message(task.scene.control.mode))


def control(task, progress: bool = False) -> "ControlResult":
    """Close the loop of a control task (a path, a dict or a Task); see the module."""
    task = load_control_task(task)
    return mode_runner(task.scene.control.mode)(task, progress=progress)


def default_duration(task, T_plan: float) -> float:
    """[control].duration, else: land, the plan's touchdown and a fifth more (a push may
    delay it); reorient, the plan's horizon (its goal's time, where the attitude is
    measured)."""
    ctl = task.scene.control
    if ctl.duration is not None:
        return float(ctl.duration)
    return T_plan * (1 + LAND_MARGIN) if task.goal == "land" else T_plan


def period_of(task) -> float:
    ctl = task.scene.control
    return float(ctl.period if ctl.period is not None else DEFAULT_PERIOD[ctl.mode])


# ---- the plant ---------------------------------------------------------------------------
def planned_doc(plan, duration: float) -> dict:
    """The plan's scene (scene.toml) as a dict with its law as samples, held as the plan
    defines it beyond the table (at rest, or the last piece going on) up to ``duration``,
    and the general model (pushes and the attitude need it)."""
    import tomllib
    doc = tomllib.loads(plan.scene_toml)
    rows = np.asarray(plan.table)[:, :4]
    t_last = float(rows[-1, 0])
    if duration > t_last:
        dt = 8 * float(np.min(np.diff(rows[:, 0])))
        n = max(2, math.ceil((duration - t_last) / dt) + 1)
        extra = t_last + (duration - t_last) * np.arange(1, n + 1) / n
        u = plan.law.u(extra)
        rows = np.vstack([rows, np.column_stack([extra, u[0:3].T])])
        if doc["point"].get("ends") == "periodic":     # held, not repeated
            doc["point"]["ends"] = "rest" if plan.law.rest else "free"
    point = doc["point"]
    point.pop("table", None)
    point["samples"] = rows.tolist()
    doc["run"]["duration"] = float(duration)
    doc["run"]["model"] = "general"
    doc["run"]["outputs"] = ["pose", "omega", "impacts"]
    return doc


def planned_bodies_doc(plan, duration: float, folder) -> dict:
    """The plan of a task of several bodies as the plant's scene: its scene (scene.toml)
    as a dict, each decided body's table written into ``folder`` (the scene's base),
    run up to ``duration`` on the moments model.  A table shorter than the run is
    tabulated again up to ``duration`` with the law held as the plan defines it beyond
    its end (at rest, or the last piece going on), as :func:`planned_doc` does for one
    point: land's default duration, touchdown and a fifth, outran the plan's table
    (touchdown and a twentieth) and the plant was refused."""
    import tomllib
    from ..planner.bodies_plan import tabulate, write_table
    doc = tomllib.loads(plan.scene_toml)
    tables = plan.tables
    if duration > min(float(rows[-1, 0]) for rows in tables.values()):
        tables, _ = tabulate(plan.law, plan.report.tr.channels, float(duration))
    for name, rows in tables.items():
        write_table(Path(folder) / name, rows)
    doc["run"]["duration"] = float(duration)
    doc["run"]["model"] = "moments"
    doc["run"]["outputs"] = ["pose", "omega", "impacts"]
    return doc


def plant_of(doc: dict, disturbance, base=None):
    """The plant's prepared scene: the planned scene with the disturbance applied
    (``base``: the folder of its tables).  A plant refused is [disturbance]'s doing when
    the planned scene alone runs (SceneError naming it), else the plan's (ControlError:
    it had named [disturbance] in a task without one)."""
    from ..runtime.driver import prepare
    from ..scene import parse_scene
    from .plant import plant_doc
    base = None if base is None else Path(base)
    try:
        scene = parse_scene(plant_doc(doc, disturbance), "plant", base)
    except SceneError as exc:
        try:                                 # [disturbance]'s doing, or the plan's own?
            parse_scene(plant_doc(doc, None), "plant", base)
        except SceneError:
            raise ControlError(f"the offline plan's scene does not run as the plant: "
                               f"{exc}") from None
        raise SceneError("[disturbance]", f"gives a plant that is not a valid scene: "
                                          f"{exc}") from None
    return prepare(scene)


def open_loop(prep, disturbance):
    """The plan played on the plant (the pushes applied, nothing read)."""
    from ..runtime.driver import run_prepared
    from .plant import loop
    scene = replace(prep.scene, disturbance=disturbance)
    return run_prepared(prep, loop=loop(lambda call: None, scene, 0.0))


# ---- measuring -------------------------------------------------------------------------------
def trajectory_of(result, law, source: str):
    """A run as the planner's :class:`~derive.planner.resim.Trajectory` (general layout,
    its impacts with the state just before and after and the law's u there; ``law``
    None: a plan of bodies played, whose measure reads no u, as the planner's own)."""
    from ..planner.resim import Trajectory
    impacts = []
    kinds = np.asarray(result.row_kind)
    imp = {round(float(e["t"]), 12): e for e in result.events if e["kind"] == "impact"}
    for i in np.flatnonzero(kinds == abi.ROW_KIND["before_event"]):
        ev = imp.get(round(float(result.t[i]), 12))
        if ev is not None and i + 1 < len(kinds) and kinds[i + 1] == abi.ROW_KIND["after_event"]:
            impacts.append({"t": float(result.t[i]), "I": ev["value"],
                            "v_minus": ev["v_minus"], "v_plus": ev["v_plus"],
                            "q_minus": result.q[i], "q_plus": result.q[i + 1],
                            "u": None if law is None else law.point(float(result.t[i]))})
    return Trajectory(np.asarray(result.t), np.asarray(result.q), impacts, result.status,
                      source)


def measure_run(task, plan, result, law, source: str) -> dict:
    """The keys of plan.json's achieved.runtime for a run (``law``: the law it ran)."""
    from ..planner.goals import goal_of
    return goal_of(task).measure(task, plan.law, trajectory_of(result, law, source), {})


def with_goal(task, m: dict) -> dict:
    """A run's measures (:func:`measure_run`) with ``goal_met`` and ``goal_tolerance``:
    the run ended done and its goal's error is within GOAL_TOLERANCE_DEG (the attitude
    at touchdown, or at the end of a reorientation; for d = CS x n = 0, |d| within the
    body's size times sin of it: CS that near the vertical for a lever that long)."""
    m = dict(m)
    tol = math.radians(GOAL_TOLERANCE_DEG)
    if "attitude_error_rad" in m:
        m["goal_tolerance"] = {"attitude_error_rad": tol, "degrees": GOAL_TOLERANCE_DEG}
        ok = m["attitude_error_rad"] <= tol
    elif "d_norm" in m:
        size = float(task.scene.size[0])
        m["goal_tolerance"] = {"d_norm": size * math.sin(tol), "degrees": GOAL_TOLERANCE_DEG}
        ok = m["d_norm"] <= size * math.sin(tol)
    else:                                   # no touchdown
        m["goal_tolerance"] = {"degrees": GOAL_TOLERANCE_DEG}
        ok = False
    m["goal_met"] = bool(ok and m.get("status") == "done")
    return m


def disturbance_dict(d) -> dict:
    if d is None:
        return {}
    return {"seed": d.seed, "mass_factor": d.mass_factor,
            "point_mass_factor": d.point_mass_factor,
            "inertia_factor": list(d.inertia_factor), "restitution": d.restitution,
            "noise": dict(zip(("omega", "attitude", "com", "com_velocity"), d.noise)),
            "pushes": [{"time": p[0], "impulse": list(p[1:4]), "at": list(p[4:7])}
                       for p in d.pushes]}


def percentiles_ms(seconds) -> dict:
    s = np.asarray(seconds, dtype=float) * 1e3
    if len(s) == 0:
        return {"median": None, "p99": None, "max": None, "samples": 0}
    return {"median": float(np.median(s)), "p99": float(np.percentile(s, 99)),
            "max": float(np.max(s)), "samples": int(len(s))}


# ---- the result and its files ----------------------------------------------------------------
@dataclass(repr=False)
class ControlResult:
    """A closed loop and its open-loop comparison.  ``summary`` is control.json;
    ``closed``/``open`` the runtime's results (``closed.scene`` carries the realised law);
    ``law`` the realised law; ``sources`` the controller's files; ``figures`` (name,
    function(path)) the mode's plots."""
    task: object
    mode: str
    summary: dict
    closed: object = None
    open: object = None
    law: object = None
    sources: dict = field(default_factory=dict)
    figures: list = field(default_factory=list)

    def __repr__(self) -> str:                 # (the fields hold whole runs)
        closed = self.summary.get("closed_loop", {})
        return (f"<ControlResult {self.mode}: closed loop "
                + ", ".join(f"{k} {v:.3g}" for k, v in closed.items()
                            if isinstance(v, float))[:160] + ">")

    def write(self, out, animation: bool = True) -> list[Path]:
        """control.json, the closed loop's trajectory.csv and events.csv, law.csv (the
        realised law), the controller's sources, the plots and motion.gif.  Written into
        a hidden folder first and moved into place (an interrupted write leaves whole
        files)."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        stage = Path(tempfile.mkdtemp(prefix=".writing-", dir=out))
        try:
            written = self._write(stage, animation)
            final = []
            for path in written:
                target = out / path.name
                if target.is_dir():
                    shutil.rmtree(target)
                path.replace(target)
                final.append(target)
            return final
        finally:
            shutil.rmtree(stage, ignore_errors=True)

    def _write(self, out: Path, animation: bool) -> list[Path]:
        from ..runtime.motion import motion
        from ..runtime.outputs import write_csv, write_tables
        written = []
        if self.closed is not None:
            mo = motion(self.closed)
            paths = write_tables(self.closed, mo, out)
            (out / "impacts.csv").unlink(missing_ok=True)
            written += [p for p in paths if p.name != "impacts.csv"]
        if self.law is not None:
            law = self.law
            rows = np.column_stack([law.knots[:-1], law.knots[1:],
                                    law.coef.reshape(len(law.knots) - 1, 12)])
            head = ["t_from", "t_to"] + [f"{c}_{k}" for c in "xyz" for k in range(4)]
            write_csv(out / "law.csv", head, rows)
            written.append(out / "law.csv")
        for name, text in self.sources.items():
            (out / name).write_text(text, encoding="utf-8")
            written.append(out / name)
        for name, draw in self.figures:
            written.append(draw(out / name))
        if animation and self.closed is not None:
            from ..runtime.animation import write_gif
            from ..runtime.motion import for_pictures
            fine = for_pictures(self.closed)
            mo_fine = motion(fine)
            if mo_fine.r_O is not None:
                written.append(write_gif(fine, mo_fine, out / "motion.gif"))
        (out / "control.json").write_text(summary_json(self.summary), encoding="utf-8")
        written.append(out / "control.json")
        return written


def summary_json(summary: dict) -> str:
    from ..json_text import dumps
    return dumps(summary)
