"""Ways of simulating a scene, measured side by side by the benchmarks.

Every route takes a scene (a dict of the scene schema) and a setting (a tolerance, or a
step for RK4), and ``result()`` returns a :class:`Run`: the state in the ``general``
layout on a common output grid, the impact times, the number of RHS evaluations, a
status and the lowest height of S seen on the grid.  ``timed()`` is the minimum over
repetitions after a warm-up, of the thread's CPU time (derive.bench.timing).

* :class:`Runtime` — this project's C runtime (lie and lie5, the momentum form on SO(3);
  rk4, dopri5, dop853, dop853 keeping A orthonormal), model forced to ``general`` so
  that every route integrates the same equations;
* :class:`Scipy` — the SciPy peer of :mod:`derive.scipy_hybrid` (``solve_ivp``: DOP853,
  RK45, Radau; a terminal event on the gap and the derived impact map with a restart at
  each impact) with the NumPy evaluation of the derived functions or the generated C
  through ctypes;
* :class:`Casadi` — CasADi's ``cvodes`` on the emitted CasADi RHS over the output grid,
  segment by segment, with regula falsi (Illinois) on re-integrations for impacts.

Peers stop at an evaluation budget (``StopRun``), reported as a status, never a hang.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import sympy as sp

from .. import notation as nt
from ..emit.casadi_backend import Translator, build_function
from ..emit.numpy_backend import compile_spec
from ..models import flight_rhs, gap, impact, lowest_point
from .. import abi, layout
from ..runtime import choice, geometry
from ..runtime.driver import prepare, run_prepared
from ..runtime.session import Session
from ..scene import Scene, parse_scene
from ..scipy_hybrid import Functions, Hybrid, StopRun
from .timing import least_of

GRID_DT = 0.05
EVAL_BUDGET = 3_000_000


@dataclass
class Run:
    states: np.ndarray            # (n_grid, 18), general layout
    impacts: np.ndarray           # impact times
    evaluations: int
    status: str
    min_height: float = np.inf
    extra: dict = field(default_factory=dict)


def grid_of(scene: Scene, dt: float = GRID_DT) -> np.ndarray:
    n = int(round(scene.duration / dt))
    return scene.t0 + dt * np.arange(n + 1)


def heights(scene: Scene, t: np.ndarray, states: np.ndarray) -> np.ndarray:
    if not scene.contact_possible or not len(states):
        return np.full(len(states), np.inf)
    return geometry.heights(scene, t, states[:, 2], states[:, 15:18])


def _timed(fn, repeats: int) -> float:
    """The least CPU time of ``repeats`` calls after a warm-up (derive.bench.timing)."""
    fn()
    return least_of(fn, repeats)


G = layout.GENERAL


def _initial(scene: Scene) -> np.ndarray:
    return choice.start(scene, "general").q0


# ---- the runtime -----------------------------------------------------------------------------
class Runtime:
    label_of = {"rk4": "runtime RK4", "dopri5": "runtime DOPRI5", "dop853": "runtime DOP853",
                "dop853+orth": "runtime DOP853+orth", "lie": "runtime LIE",
                "lie5": "runtime LIE5", "lie8": "runtime LIE8"}

    def __init__(self, doc: dict, method: str, setting: float, dt: float = GRID_DT,
                 model: str = "general"):
        d = copy.deepcopy(doc)
        run = d.setdefault("run", {})
        orth = method.endswith("+orth")
        run.update(method=method.replace("+orth", ""), output_dt=dt, outputs=["pose", "impacts"],
                   model=model, keep_orthonormal=orth)
        if method == "rk4":
            run["step"] = setting
        else:
            run.update(rtol=setting, atol=setting * 1e-2)
        run.setdefault("max_steps", 20_000_000)
        self.label = self.label_of[method]
        self.prep = prepare(d)
        self.scene = self.prep.scene
        self.grid = grid_of(self.scene, dt)
        self.session = Session(self.prep.library)
        self.session.set_law(self.scene.law)

    def run_raw(self):
        p = self.prep
        return self.session.run(p.scene.t0, p.scene.duration, p.start.q0, p.options,
                                p.parameters)

    def result(self) -> Run:
        res = run_prepared(self.prep, self.session)
        t, kinds, status, stats = res.t, res.row_kind, res.status, res.stats
        general = res.general
        rows = kinds == abi.ROW_KIND["step"]
        tt, qq = t[rows], general[rows]
        idx = np.clip(np.searchsorted(tt, self.grid - 1e-12), 0, max(len(tt) - 1, 0))
        states = qq[idx] if len(tt) else np.empty((0, 18))
        if len(tt) and status == "done" and np.max(np.abs(tt[idx] - self.grid)) > 1e-9:
            raise RuntimeError("the output grid was not produced")
        impacts = res.impacts[:, 0]
        h = heights(self.scene, tt, qq)
        return Run(states, impacts, stats["rhs_evaluations"], status,
                   float(np.min(h)) if len(h) else np.inf,
                   {"contacts": stats["contacts"], "steps": stats["steps"]})

    def timed(self, repeats: int) -> float:
        return _timed(self.run_raw, repeats)


# ---- SciPy -------------------------------------------------------------------------------------
class Scipy:
    """The shared SciPy peer (:mod:`derive.scipy_hybrid`) on the NumPy evaluation of the
    derived functions, or on the generated C through ctypes (``rhs="c"``)."""

    def __init__(self, doc: dict, method: str, setting: float, rhs: str = "numpy",
                 dt: float = GRID_DT, budget: int = EVAL_BUDGET, max_impacts: int = 20000):
        self.scene = parse_scene(doc)
        self.method, self.rtol, self.budget = method, setting, budget
        self.max_impacts = max_impacts
        self.label = f"scipy {method}" + (" (C RHS)" if rhs == "c" else "")
        s = self.scene
        shape = s.shape
        if rhs == "c":
            from ..clib import load_generated
            funcs = load_generated()
            fns = Functions(funcs["general_flight_rhs"], funcs["general_gap"],
                            funcs["general_impact"], funcs[f"lowest_point_{shape}"])
        else:
            fns = Functions(compile_spec(flight_rhs("general")), compile_spec(gap("general")),
                            compile_spec(impact("general")), compile_spec(lowest_point(shape)))
        self.size = list(s.size)
        self.law = s.law.jets
        self.grid = grid_of(s, dt)
        self.hybrid = Hybrid(fns, self.u, s.p, contact=s.contact_possible, e=s.e,
                             center=s.center, size=self.size, method=method, rtol=setting,
                             budget=budget, max_impacts=max_impacts)

    @property
    def calls(self) -> int:
        return self.hybrid.calls

    def u(self, t):
        v = self.law(np.array([t]))[:, 0]
        return layout.u_of_jets(v)

    def result(self) -> Run:
        s = self.scene
        path = self.hybrid.run(s.t0, s.t0 + s.duration, _initial(s), t_eval=self.grid)
        impacts = np.array([imp["t"] for imp in path.impacts])
        if path.status != "done":
            return Run(path.q, impacts, path.evaluations, path.status)
        h = heights(s, path.t, path.q)
        return Run(path.q, impacts, path.evaluations, "done",
                   float(np.min(h)) if len(h) else np.inf)

    def timed(self, repeats: int) -> float:
        return _timed(self.result, repeats)


# ---- CasADi cvodes -------------------------------------------------------------------------------
class Casadi:
    def __init__(self, doc: dict, setting: float, dt: float = GRID_DT,
                 budget: int = 200_000):
        self.scene = s = parse_scene(doc)
        self.rtol, self.budget = setting, budget
        self.label = "casadi cvodes"
        self.grid = grid_of(s, dt)
        rhs = build_function(flight_rhs("general"))
        self.gap_f = build_function(gap("general"))
        self.imp_f = build_function(impact("general"))
        shape = s.shape
        self.lp_f = build_function(lowest_point(shape))
        self.size = list(s.size)
        x = ca.SX.sym("x", 18)
        prm = ca.SX.sym("prm", 2)                       # segment start and length
        tau = ca.SX.sym("tau")
        t_sym = ca.SX.sym("t")
        tr = Translator({nt.t: t_sym})
        law = []
        for f in s.law.sympy():
            law += [tr(f), tr(sp.diff(f, nt.t)), tr(sp.diff(f, nt.t, 2))]
        u_of_t = ca.vertcat(*layout.u_of_jets(law))
        self.u_fun = ca.Function("u", [t_sym], [u_of_t])
        ode = prm[1] * rhs(x, self.u_fun(prm[0] + tau * prm[1]), ca.DM(s.p))
        self.integrator = ca.integrator(
            "I", "cvodes", {"x": x, "p": prm, "t": tau, "ode": ode}, 0.0, 1.0,
            {"abstol": setting * 1e-2, "reltol": setting, "linear_multistep_method": "adams",
             "max_num_steps": 100000})
        self.calls = 0

    def _flow(self, t0, length, x0):
        self.calls += 1
        if self.calls > self.budget:
            raise StopRun("integrator-call budget exhausted")
        return np.array(self.integrator(x0=x0, p=[t0, length])["xf"].full()).ravel()

    def _gap(self, t, x):
        s = self.scene
        sv = self.lp_f(x[G.n], s.center, self.size)
        h, _ = self.gap_f(x, self.u_fun(t), sv, s.p)
        return float(h)

    def result(self) -> Run:
        s = self.scene
        self.calls = 0
        x, t = _initial(s), s.t0
        states, impacts = [x.copy()], []
        tol_t = 1e-13 * s.duration
        plane = s.contact_possible
        try:
            for target in self.grid[1:]:
                while True:
                    x_end = self._flow(t, target - t, x)
                    if not plane or self._gap(target, x_end) >= 0.0:
                        t, x = target, x_end
                        break
                    a, ga, b, gb = t, self._gap(t, x), target, self._gap(target, x_end)
                    xb, side = x_end, 0
                    for _ in range(200):
                        c = b - gb * (b - a) / (gb - ga)
                        if not (a < c < b):
                            c = 0.5 * (a + b)
                        xc = self._flow(t, c - t, x)
                        gc = self._gap(c, xc)
                        if gc > 0:
                            if side == 1:
                                gb *= 0.5
                            a, ga, side = c, gc, 1
                        else:
                            if side == -1:
                                ga *= 0.5
                            b, gb, xb, side = c, gc, xc, -1
                        if b - a < tol_t or gc == 0.0:
                            break
                    sv = self.lp_f(xb[15:18], s.center, self.size)
                    q_plus, _ = self.imp_f(xb, self.u_fun(b), sv, s.p, s.e)
                    impacts.append(b)
                    if len(impacts) > 20000:
                        raise StopRun("impacts do not stop")
                    x = self._flow(b, 1e-9, np.array(q_plus.full()).ravel())
                    t = b + 1e-9
                states.append(x.copy())
        except StopRun as exc:
            return Run(np.array(states), np.array(impacts), self.calls, f"stopped: {exc}")
        except RuntimeError as exc:                # cvodes failures
            return Run(np.array(states), np.array(impacts), self.calls,
                       f"failed: {str(exc).splitlines()[0][:80]}")
        st = np.array(states)
        h = heights(s, self.grid[:len(st)], st)
        return Run(st, np.array(impacts), self.calls, "done",
                   float(np.min(h)) if len(h) else np.inf)

    def timed(self, repeats: int) -> float:
        return _timed(self.result, repeats)


def errors(run: Run, ref: Run) -> tuple[float, float]:
    """Max state error on the grid and max impact-time error (inf if counts differ)."""
    if len(run.states) != len(ref.states):
        return np.inf, np.inf
    err = float(np.max(np.abs(run.states - ref.states))) if len(ref.states) else 0.0
    if len(run.impacts) != len(ref.impacts):
        return err, np.inf
    ierr = float(np.max(np.abs(run.impacts - ref.impacts))) if len(ref.impacts) else 0.0
    return err, ierr
