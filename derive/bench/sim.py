"""``derive bench sim``: time to simulate a scene (default: the built-in one, 5 s, all
impacts) to a max state error of 1e-9, against two peer routes, in one run.

* the runtime: every method, tolerance (or RK4 step) swept, the loosest setting that
  meets the error target timed (``crt_init`` + ``crt_advance`` through ctypes);
* SciPy: ``solve_ivp`` DOP853 with the NumPy evaluation of the derived RHS, a terminal
  event on the gap, the derived impact map and a restart at each impact;
* CasADi: the ``cvodes`` integrator on the emitted CasADi RHS (time scaled so one
  integrator serves every segment), run over the output grid segment by segment; a sign
  change of the gap at a segment end is located by the secant method on re-integrations
  from the segment start, then the emitted impact map applies.

Error: the max over a common output grid (every 0.05 s) of the state error in the
``general`` layout against a reference run at tolerance 1e-14 (itself checked against
SciPy at 1e-13), and the max error of the impact times.  Time: the minimum of several
repetitions after a warm-up; compile and specialisation times are reported apart.
"""
from __future__ import annotations

import copy
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

from ..emit.casadi_backend import Translator, build_function
from ..emit.numpy_backend import compile_spec
from ..models import flight_rhs, gap, impact, lowest_point
from ..runtime.driver import Session, prepare
from ..runtime.scene import DEFAULT_SCENE, Scene, law_functions, parse_scene

GRID_DT = 0.05
TARGET = 1e-9


@dataclass
class Route:
    name: str
    setting: str
    seconds: float
    error: float
    impact_error: float
    impacts: int
    evaluations: int = 0


def _grid(scene: Scene) -> np.ndarray:
    n = int(round(scene.duration / GRID_DT))
    return scene.t0 + GRID_DT * np.arange(n + 1)


def _pick_grid(t, q, kinds, grid):
    """Rows of the uniform output (kind 0) at the grid times."""
    rows = kinds == 0
    tt, qq = t[rows], q[rows]
    idx = np.searchsorted(tt, grid - 1e-12)
    idx = np.clip(idx, 0, len(tt) - 1)
    if np.max(np.abs(tt[idx] - grid)) > 1e-9:
        raise RuntimeError("the output grid was not produced")
    return qq[idx]


# ---- the runtime ------------------------------------------------------------------------
class Runtime:
    def __init__(self, doc: dict, method: str, setting: float):
        d = copy.deepcopy(doc)
        run = d.setdefault("run", {})
        run.update(method=method, output_dt=GRID_DT, outputs=["pose", "impacts"])
        if method == "rk4":
            run["step"] = setting
        else:
            run.update(rtol=setting, atol=setting * 1e-2)
        self.scene, self.model, self.library, self.info = prepare(d)
        self.grid = _grid(self.scene)
        self.session = Session(self.library, self.scene, self.model,
                               options=self.info["options"])

    def run(self):
        return self.session.run()

    def result(self):
        t, Q, kinds, ev, stats, status = self.run()
        general = self.model.to_general(t, Q)
        states = _pick_grid(t, general, kinds, self.grid)
        impacts = np.array([r[0] for r in ev if int(r[1]) == 1])
        return states, impacts, stats["rhs_evaluations"], status


# ---- SciPy ---------------------------------------------------------------------------------
class Scipy:
    def __init__(self, scene: Scene, rtol: float):
        self.scene, self.rtol = scene, rtol
        self.rhs = compile_spec(flight_rhs("general"))
        self.gap = compile_spec(gap("general"))
        self.imp = compile_spec(impact("general"))
        self.lp = compile_spec(lowest_point("sphere" if scene.shape == "sphere" else "ellipsoid"))
        self.law = law_functions(scene)
        self.p = np.array(scene.p)
        self.size = [scene.size[0]] if scene.shape == "sphere" else list(scene.size)
        self.grid = _grid(scene)

    def u(self, t):
        v = self.law(np.array([t]))[:, 0]
        return v[[0, 3, 6, 1, 4, 7, 2, 5, 8]]

    def result(self):
        s = self.scene
        nfev = [0]

        def f(t, q):
            return self.rhs(q, self.u(t), self.p)[0]

        def event(t, q):
            sv = self.lp(q[15:18], s.center, self.size)[0]
            return self.gap(q, self.u(t), sv, self.p)[0][0]
        event.terminal, event.direction = True, -1
        t, q = s.t0, np.r_[s.com, s.com_velocity, s.omega, s.A0.reshape(-1)]
        t_end = s.t0 + s.duration
        states = np.empty((len(self.grid), 18))
        filled = 0
        impacts = []
        while t < t_end - 1e-15:
            grid = self.grid[filled:]
            sol = solve_ivp(f, (t, t_end), q, method="DOP853", rtol=self.rtol,
                            atol=self.rtol * 1e-2, events=event,
                            t_eval=grid[grid <= t_end], dense_output=False)
            nfev[0] += sol.nfev
            n = sol.y.shape[1]
            states[filled:filled + n] = sol.y.T
            filled += n
            t, q = sol.t[-1], sol.y[:, -1]
            if sol.status == 1:
                t, q = sol.t_events[0][0], sol.y_events[0][0]
                sv = self.lp(q[15:18], s.center, self.size)[0]
                q = self.imp(q, self.u(t), sv, self.p, [s.e])[0]
                impacts.append(t)
                # leave the plane before the terminal event may fire again
                step = solve_ivp(f, (t, t + 1e-9), q, method="DOP853", rtol=self.rtol,
                                 atol=self.rtol * 1e-2)
                nfev[0] += step.nfev
                t, q = step.t[-1], step.y[:, -1]
            elif sol.status != 0:
                raise RuntimeError(sol.message)
            else:
                break
        return states[:filled], np.array(impacts), nfev[0], "done"


# ---- CasADi cvodes --------------------------------------------------------------------------
class Casadi:
    def __init__(self, scene: Scene, rtol: float):
        self.scene, self.rtol = scene, rtol
        self.grid = _grid(scene)
        rhs = build_function(flight_rhs("general"))
        self.gap_f = build_function(gap("general"))
        self.imp_f = build_function(impact("general"))
        self.lp_f = build_function(lowest_point("sphere" if scene.shape == "sphere"
                                                else "ellipsoid"))
        self.size = [scene.size[0]] if scene.shape == "sphere" else list(scene.size)
        x = ca.SX.sym("x", 18)
        prm = ca.SX.sym("prm", 2)                     # segment start and length
        tau = ca.SX.sym("tau")
        t_sym = ca.SX.sym("t")
        import sympy as sp
        from .. import notation as nt
        tr = Translator({nt.t: t_sym})
        law = []
        for f in scene.law:
            law += [tr(f), tr(sp.diff(f, nt.t)), tr(sp.diff(f, nt.t, 2))]
        u_of_t = ca.vertcat(*[law[i] for i in (0, 3, 6, 1, 4, 7, 2, 5, 8)])
        self.u_fun = ca.Function("u", [t_sym], [u_of_t])
        t_here = prm[0] + tau * prm[1]
        ode = prm[1] * rhs(x, self.u_fun(t_here), ca.DM(scene.p))
        dae = {"x": x, "p": prm, "t": tau, "ode": ode}
        self.integrator = ca.integrator("I", "cvodes", dae, 0.0, 1.0,
                                        {"abstol": rtol * 1e-2, "reltol": rtol,
                                         "linear_multistep_method": "adams",
                                         "max_num_steps": 100000})

    def _flow(self, t0, length, x0):
        return np.array(self.integrator(x0=x0, p=[t0, length])["xf"].full()).ravel()

    def _gap(self, t, x):
        s = self.scene
        sv = self.lp_f(x[15:18], s.center, self.size)
        h, _ = self.gap_f(x, self.u_fun(t), sv, s.p)
        return float(h)

    def result(self):
        s = self.scene
        x = np.r_[s.com, s.com_velocity, s.omega, s.A0.reshape(-1)]
        t = s.t0
        states = [x.copy()]
        impacts = []
        calls = 0
        tol_t = 1e-13 * s.duration
        for target in self.grid[1:]:
            while True:
                x_end = self._flow(t, target - t, x)
                calls += 1
                if self._gap(target, x_end) >= 0.0:
                    t, x = target, x_end
                    break
                # the gap changed sign in (t, target): regula falsi with the Illinois
                # modification on re-integrations from the segment start
                a, ga, b, gb = t, self._gap(t, x), target, self._gap(target, x_end)
                xb = x_end
                side = 0
                for _ in range(200):
                    c = b - gb * (b - a) / (gb - ga)
                    if not (a < c < b):
                        c = 0.5 * (a + b)
                    xc = self._flow(t, c - t, x)
                    calls += 1
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
                # leave the plane before the next search, as the SciPy route does
                x = self._flow(b, 1e-9, np.array(q_plus.full()).ravel())
                t = b + 1e-9
                calls += 1
                if len(impacts) > 10000:
                    raise RuntimeError("CasADi route: impacts do not stop")
            states.append(x.copy())
        return np.array(states), np.array(impacts), calls, "done"


# ---- the sweep --------------------------------------------------------------------------------
def _time(fn, repeats: int) -> float:
    fn()                                                   # warm-up
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _errors(states, impacts, ref_states, ref_impacts):
    n = min(len(states), len(ref_states))
    err = float(np.max(np.abs(states[:n] - ref_states[:n]))) if n else np.inf
    if len(states) != len(ref_states):
        err = np.inf
    if len(impacts) != len(ref_impacts):
        return err, np.inf
    ierr = float(np.max(np.abs(impacts - ref_impacts))) if len(impacts) else 0.0
    return err, ierr


def run(scene_doc: dict | None = None, progress=lambda m: None, repeats: int = 5,
        target: float = TARGET) -> dict:
    doc = copy.deepcopy(scene_doc) if scene_doc is not None else None
    if doc is None:
        import tomllib
        doc = tomllib.loads(DEFAULT_SCENE)
    scene = parse_scene(doc)
    progress("reference: DOP853 at 1e-14, checked against SciPy at 1e-13")
    ref = Runtime(doc, "dop853", 1e-14)
    ref_states, ref_impacts, _, _ = ref.result()
    check_states, check_impacts, _, _ = Scipy(scene, 1e-13).result()
    reference_agreement = _errors(check_states, check_impacts, ref_states, ref_impacts)

    rows: list[Route] = []
    sweeps = {"runtime dop853": ("dop853", [1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]),
              "runtime dopri5": ("dopri5", [1e-8, 1e-9, 1e-10, 1e-11, 1e-12]),
              "runtime rk4": ("rk4", [4e-3, 2e-3, 1e-3, 5e-4])}
    for label, (method, settings) in sweeps.items():
        for setting in settings:
            progress(f"{label} at {setting:g}")
            rt = Runtime(doc, method, setting)
            states, impacts, nrhs, status = rt.result()
            err, ierr = _errors(states, impacts, ref_states, ref_impacts)
            if err <= target and ierr <= target:
                seconds = _time(rt.run, repeats)
                rows.append(Route(label, f"{'step' if method == 'rk4' else 'tol'} {setting:g}",
                                  seconds, err, ierr, len(impacts), nrhs))
                break
        else:
            rows.append(Route(label, "target not met", np.nan, err, ierr, len(impacts)))
    for label, cls, settings in (("scipy DOP853", Scipy, [1e-9, 1e-10, 1e-11, 1e-12, 1e-13]),
                                 ("casadi cvodes", Casadi, [1e-11, 1e-12, 1e-13, 1e-14])):
        for setting in settings:
            progress(f"{label} at {setting:g}")
            route = cls(scene, setting)
            states, impacts, calls, _ = route.result()
            err, ierr = _errors(states, impacts, ref_states, ref_impacts)
            if err <= target and ierr <= target:
                seconds = _time(route.result, max(1, repeats // 2))
                rows.append(Route(label, f"tol {setting:g}", seconds, err, ierr,
                                  len(impacts), calls))
                break
        else:
            rows.append(Route(label, "target not met", np.nan, err, ierr, len(impacts)))
    return {"scene": scene.name, "duration": scene.duration, "target": target,
            "reference_agreement": reference_agreement, "rows": rows,
            "compile_s": ref.info["timings"]}


def report(out: dict) -> str:
    rows = out["rows"]
    ours = [r for r in rows if r.name.startswith("runtime") and np.isfinite(r.seconds)]
    best = min(ours, key=lambda r: r.seconds) if ours else None
    lines = [f"scene {out['scene']} ({out['duration']:g} s), target max state error "
             f"{out['target']:g}; reference vs SciPy at 1e-13: state "
             f"{out['reference_agreement'][0]:.1e}, impact times "
             f"{out['reference_agreement'][1]:.1e}",
             f"{'route':<16}{'setting':<16}{'time [ms]':>11}{'state err':>11}"
             f"{'impact err':>12}{'impacts':>9}{'evals':>8}{'x best':>9}"]
    for r in rows:
        ratio = r.seconds / best.seconds if best and np.isfinite(r.seconds) else np.nan
        lines.append(f"{r.name:<16}{r.setting:<16}{1e3 * r.seconds:>11.3f}{r.error:>11.1e}"
                     f"{r.impact_error:>12.1e}{r.impacts:>9d}{r.evaluations:>8d}"
                     f"{ratio:>9.1f}")
    if best:
        for peer, goal in (("scipy DOP853", 1000), ("casadi cvodes", 20)):
            r = next((x for x in rows if x.name == peer), None)
            if r is not None and np.isfinite(r.seconds):
                lines.append(f"speed-up of the runtime ({best.name}) over {peer}: "
                             f"{r.seconds / best.seconds:.0f}x (target >= {goal}x)")
    return "\n".join(lines)
