"""In-flight re-planning (``[control] mode = "replan"``, goals reorient and land): the
planner's problem solved again at every sample from the state read, over the horizon
that remains, as a real-time solver generated to C.  This module is the pipeline of
``derive control``; the parts live apart, as acados keeps them:

* :mod:`~derive.control.problem`: the problem's description (CasADi functions: the QP's
  data of a Gauss-Newton SQP step, the NLP for IPOPT);
* :mod:`~derive.control.spline`: the re-planned law (a cubic B-spline), its shift onto a
  new horizon and the segments the runtime plays;
* :mod:`~derive.control.render`: the C controller's sources (``templates/control/``:
  ``controller.c``, ``controller.h``, ``ctl_qp.h``, ``CMakeLists.txt``; CasADi's code of
  the QP's data, ``controller_data.c``); :mod:`~derive.control.compiled`: compiled and
  loaded;
* :mod:`~derive.control.solvers`: the Python route (:class:`PyReplan`), IPOPT at every
  sample (:class:`IpoptReplan`) and the problem at the start solved by IPOPT from the
  offline plan (a start at rest has a zero gradient: the attitude moves at second order
  in the point's loops);
* :mod:`~derive.control.qp`: the dense QP solver (Goldfarb-Idnani) in NumPy, the
  statement of ``ctl_qp.h``.

:func:`setup` makes everything a task's closed loops need once (:class:`Setup`);
:func:`run` is ``derive control`` for mode = "replan".
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import layout
from .compiled import Compiled
from .core import ControlError
from .problem import Problem, freeze
from .render import render
from .solvers import IpoptReplan, PyReplan, initial_solution

G = layout.GENERAL
MEDIAN_TARGET_MS, P99_TARGET_MS = 5.0, 10.0   # the C solve per sample (bench control)


# ---- derive control, mode = "replan" -------------------------------------------------------
def check_task(task) -> None:
    """What replan needs of a task (SceneError naming the field)."""
    from ..scene import SceneError
    if task.goal not in ("reorient", "land"):
        raise SceneError("[control].mode", f"replan re-plans the goals reorient and land "
                                           f"(this task's goal is {task.goal})")
    if task.circle is not None:
        raise SceneError("[plan].circle", "replan re-plans P in a region (give region, "
                                          "not circle)")
    ctl = task.scene.control
    if ctl.period is not None and not ctl.period > 0:
        raise SceneError("[control].period", "replan samples every period: must be > 0")
    if task.bodies:
        from .columns import check
        why = check(task)
        if why is not None:
            raise SceneError("[plan].decide", why)
        if task.goal == "land" and task.at_touchdown != "attitude":
            raise SceneError("[plan].at_touchdown", "replan lands a task of bodies with "
                                                    "\"attitude\" (d_zero reads one point)")


def initial_state_of(task) -> np.ndarray:
    """The general-layout state at the start, from the task's [initial]."""
    sc = task.scene
    return G.assemble(com=sc.com, com_velocity=sc.com_velocity, omega=sc.omega,
                      A=np.asarray(sc.A0).ravel())


@dataclass
class Setup:
    """Everything a closed loop of one task needs, made once: the offline plan, the
    problem, its solution at the start, the C sources (and the compiled controller, on
    first use), the planned scene for the plant.  ``derive control``, the tests and
    ``derive bench control`` run many plants from one."""
    task: object
    plan: object
    problem: Problem
    w0: np.ndarray
    t0: float
    period: float
    duration: float
    doc: dict
    sources: dict
    seconds: dict
    start: dict
    _compiled: object = None
    folder: object = None     # a task of bodies: the plan's tables (a TemporaryDirectory)

    @property
    def channels(self) -> tuple:
        """The outputs of the plant's law of bodies the controller drives (() for one
        point's law)."""
        cols = self.problem.columns
        return () if cols is None else cols.outputs

    @property
    def T_plan(self) -> float:
        return self.plan.law.T

    def plan_u(self, t) -> np.ndarray:
        """The offline plan's law at times t as the controller's columns (9, len(t))."""
        return self.problem.law_u(self.plan.law, t)

    @property
    def compiled(self) -> "Compiled":
        if self._compiled is None:
            tick = time.perf_counter()
            self._compiled = Compiled(self.sources)
            self.seconds["c_build"] = time.perf_counter() - tick
        return self._compiled

    def python(self, iterations: int | None = None, keep_laws: bool = False) -> PyReplan:
        return PyReplan(self.problem, self.w0, self.t0, self.T_plan, self.period,
                        iterations or self.task.scene.control.iterations, keep_laws)

    def ipopt(self, keep_laws: bool = False) -> IpoptReplan:
        return IpoptReplan(self.problem, self.w0, self.t0, self.T_plan, self.period,
                           keep_laws=keep_laws)

    def plant(self, disturbance):
        """The plant's prepared scene for a disturbance (None: the model itself)."""
        from .core import plant_of
        return plant_of(self.doc, disturbance,
                        None if self.folder is None else self.folder.name)

    def closed(self, prep, disturbance, controller):
        """A closed-loop run: (Result with the realised law as its scene's law, the law)."""
        from dataclasses import replace
        from ..runtime.driver import run_prepared
        from ..runtime.loop import realised_law
        from .plant import loop as make_loop
        scene = replace(prep.scene, disturbance=disturbance)
        lp = make_loop(controller, scene, self.period, self.channels)
        result = run_prepared(prep, loop=lp)
        law = realised_law(lp.law_rows(), "the closed loop's realised law")
        if self.channels:                # the bodies' law, the driven outputs the loop's
            from .columns import DrivenLaw
            result.scene = replace(result.scene, bodies_law=DrivenLaw(
                result.scene.bodies_law, law, self.channels))
        else:
            result.scene = replace(result.scene, law=law, law_text=())
        return result, law

    def open(self, prep, disturbance):
        from .core import open_loop
        return open_loop(prep, disturbance)


def setup(task, progress: bool = False) -> Setup:
    """The offline part of mode = "replan" (see :class:`Setup`)."""
    import tempfile
    from ..planner.core import plan as make_plan
    from .core import default_duration, period_of, planned_bodies_doc, planned_doc
    from .plant import check_samples
    start = time.perf_counter()
    check_task(task)
    ctl = task.scene.control
    period = period_of(task)
    if ctl.duration is not None:           # refused before the plan where it can be
        check_samples(period, float(ctl.duration))
    pl = make_plan(task, progress=progress)
    if not pl.ok:
        raise ControlError(f"the offline plan failed: {pl.message}")
    t0, T_plan = 0.0, pl.law.T
    duration = default_duration(task, T_plan)
    check_samples(period, duration)
    seconds = {"plan": time.perf_counter() - start}
    tick = time.perf_counter()
    problem = Problem(task, ctl.intervals)
    q0 = initial_state_of(task)
    start = initial_solution(problem, pl, q0, problem.law_u(pl.law, [t0])[:, 0], t0)
    w0 = start["w"]
    seconds["problem_and_start"] = time.perf_counter() - tick
    sources = render(problem, w0, t0, T_plan, period, ctl.iterations)
    folder = None
    if task.bodies:
        folder = tempfile.TemporaryDirectory(prefix="markeev-plan-")
        doc = planned_bodies_doc(pl, duration, folder.name)
    else:
        doc = planned_doc(pl, duration)
    return Setup(task, pl, problem, w0, t0, period, duration, doc,
                 sources, seconds, {"from": start["start"],
                                    "ipopt_status": start["status"],
                                    "iterations": start["iterations"],
                                    "horizon": float(w0[-1])}, folder=folder)


def run(task, progress: bool = False, setup_: Setup | None = None):
    """``derive control`` for mode = "replan": the offline plan, the re-planning problem
    and its solution at the start, the C controller (compiled, cached), the closed loop
    on the disturbed plant and the plan played open loop on the same plant (``setup_``:
    one made before for this task)."""
    from . import plots
    from .core import (ControlResult, disturbance_dict, measure_run, percentiles_ms,
                       with_goal)
    start = time.perf_counter()
    su = setup_ or setup(task, progress)
    ctl = task.scene.control
    dist = task.scene.disturbance
    prep = su.plant(dist)
    if ctl.solver == "sqp":
        compiled = su.compiled
        controller, what = compiled.controller(), "the generated C controller"
    else:
        controller = su.ipopt(keep_laws=True)
        what = ("IPOPT in-process at every sample (the same problem, converged or its "
                "constraints held to 1e-4)")
    tick = time.perf_counter()
    closed, law = su.closed(prep, dist, controller)
    su.seconds["closed_loop"] = time.perf_counter() - tick
    if ctl.solver == "sqp":
        times, laws, st = compiled.times(), compiled.laws(), compiled.stats()
        cstats = {"calls": st["calls"], "replans": st["replans"],
                  "qp_failures": st["failures"], "softened": st["softened"]}
    else:
        st = controller.stats
        times = np.column_stack([st.solve_t, st.solve_s]).reshape(-1, 2)
        laws = st.laws
        cstats = {"calls": st.calls, "replans": st.replans, "ipopt_failures": st.failures,
                  "softened": st.softened}
    opened = su.open(prep, dist)
    pl = su.plan
    summary = {
        "mode": "replan", "goal": task.goal,
        "closed_loop": with_goal(task, measure_run(task, pl, closed, law,
                                                   "runtime, closed loop")),
        "open_loop": with_goal(task, measure_run(task, pl, opened, opened.scene.law,
                                                 "runtime, the plan played")),
        "solve_ms": percentiles_ms(times[:, 1]),
        "solver": {"kind": ctl.solver, "what": what,
                   "qp": "dense dual active set (Goldfarb-Idnani), derive/control/qp.py",
                   "iterations_per_sample": ctl.iterations, "intervals": su.problem.N,
                   "variables": su.problem.nw, "constraints": su.problem.ng,
                   "period": su.period, "freeze_below_horizon": freeze(su.period),
                   "start": su.start},
        "controller": {k: int(v) for k, v in cstats.items()},
        "disturbance": disturbance_dict(dist),
        "plan": {"status": pl.status, "horizon": su.T_plan,
                 "achieved_runtime": (pl.summary.achieved or {}).get("runtime")},
        "duration": su.duration,
    }
    su.seconds["total"] = time.perf_counter() - start
    summary["seconds"] = su.seconds
    figures = [
        ("disturbance.png", lambda p: plots.disturbance(p, task, closed, opened, dist,
                                                        su.T_plan)),
        ("replans.png", lambda p: plots.replans(p, laws, law, su.plan_u,
                                                su.problem.column_labels)),
        ("solve_times.png", lambda p: plots.solve_times(p, times, what, MEDIAN_TARGET_MS)),
    ]
    return ControlResult(task, "replan", summary, closed, opened, law, su.sources, figures)
