"""IPOPT over the transcription, and defect correction.

A :class:`Session` holds one transcription and one IPOPT instance and runs it with any
values of the task's limits (:class:`~derive.planner.transcribe.Limits`), from any start,
warm or cold, with an optional cap on the iterations: the solve, the defect-correction
rounds, the continuation in the acceleration bound and the diagnosis of an infeasible
task (:mod:`derive.planner.diagnose`) all reuse it, so no NLP is built twice.

``solve(task, goal)`` runs, in order: the initial guess, an IPOPT solve with the NLP's
RK4, then rounds of defect correction (the accurate flow's defects as parameters of the
same NLP, warm-started) until the defects stop changing by more than the task's
tolerance.  A progress line per IPOPT iteration goes to stderr when asked.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

from .continuation import solve_with_continuation
from .diagnose import diagnose as diagnose_failure
from .functions import Fast
from .transcribe import Limits, NLPResult, Transcription

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


class Printer(ca.Callback):
    """IPOPT's iteration callback: one line per iteration on stderr."""

    def __init__(self, label: str, tr: Transcription, enabled: bool):
        ca.Callback.__init__(self)
        self.label, self.tr, self.enabled = label, tr, enabled
        self.nx, self.ng = tr.w.shape[0], tr.g.shape[0]
        self.iteration, self.round, self.cap = 0, 0, math.inf
        self.bounds = (tr.lbg, tr.ubg)
        self.construct("progress", {})

    def start(self, round_: int, label: str, bounds, cap: float = math.inf):
        """A new run: its round, its label, its constraint bounds, its iteration cap."""
        self.round, self.iteration, self.label = round_, 0, label
        self.bounds, self.cap = bounds, cap

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        name = ca.nlpsol_out(i)
        if name == "f":
            return ca.Sparsity.scalar()
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        if self.enabled:
            g = np.array(arg[2]).ravel()
            viol = violations(self.tr, g, self.bounds)
            worst = max(viol, key=lambda kv: kv[1]) if viol else ("", 0.0)
            print(f"  plan {self.label}  round {self.round}  it {self.iteration:4d}  objective "
                  f"{float(arg[1]):.6e}  violation {worst[1]:.2e}"
                  + (f" ({worst[0]})" if worst[1] > 0 else ""), file=sys.stderr, flush=True)
        self.iteration += 1
        return [1 if self.iteration > self.cap else 0]       # 1: IPOPT stops


def violations(tr: Transcription, g, bounds=None) -> list:
    """(group name, max violation) for every constraint group at constraint values g
    (bounds: the run's (lbg, ubg), the task's by default)."""
    lbg, ubg = bounds if bounds is not None else (tr.lbg, tr.ubg)
    g = np.asarray(g, dtype=float).ravel()
    v = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
    return [(grp.name, float(np.max(v[grp.start:grp.stop])) if grp.stop > grp.start else 0.0)
            for grp in tr.groups]


def _solver(tr: Transcription, printer: Printer, max_iter: int, tol: float):
    """One IPOPT instance serves every round (building one costs time): warm-start
    options throughout, so that the defect-correction rounds, started from the previous
    primal and dual solution, take a few iterations; the adaptive barrier update picks a
    small mu there by itself."""
    nlp = {"x": tr.w, "f": tr.J, "g": tr.g, "p": tr.params}
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
            "ipopt.max_iter": max_iter, "ipopt.tol": tol, "ipopt.constr_viol_tol": 1e-12,
            "ipopt.mu_strategy": "adaptive", "iteration_callback": printer,
            "ipopt.warm_start_init_point": "yes", "ipopt.warm_start_bound_push": 1e-9,
            "ipopt.warm_start_mult_bound_push": 1e-9,
            "ipopt.warm_start_slack_bound_push": 1e-9, "expand": True,
            # derivatives from the NLP's structure (one RK4 interval differentiated once):
            # the same matrices, built in a fraction of the time CasADi takes on the
            # whole expanded NLP
            "hess_lag": tr.hessian_function(), "jac_g": tr.jacobian_function()}
    return ca.nlpsol("plan", "ipopt", nlp, opts)


def effort_reference(tr: Transcription, w) -> float:
    """The effort that scales the objective: that of the start w, or, for a start at
    rest, that of one loop of the region's radius per horizon."""
    effort = tr.effort_of(w)
    if effort > 1e-9:
        return effort
    if tr.bodies:
        return tr.fallback_effort()
    T = tr.T_guess_value()
    return (tr.task.region_radius * (2 * math.pi / T) ** 2) ** 2 * T


def transcription(task, goal, stabilize: bool = False) -> Transcription:
    """The task's NLP: of the paper's model for a [point] task, of the moments models for
    one of [[point]] and [[rotor]] (:mod:`derive.planner.bodies`)."""
    if task.bodies:
        from .bodies import BodiesTranscription
        return BodiesTranscription(task, goal, stabilize)
    return Transcription(task, goal, stabilize)


class Session:
    """One transcription and one IPOPT instance for every run of a task."""

    def __init__(self, task, goal, progress: bool = False, stabilize: bool = False, w0=None):
        t_build = time.perf_counter()
        self.task, self.goal = task, goal
        self.tr = tr = transcription(task, goal, stabilize)
        self.w_guess = goal.guess(tr) if w0 is None else np.asarray(w0, dtype=float)
        tr.set_effort_scale(effort_reference(tr, self.w_guess))
        self.label = task.goal + (" (stability conditions)" if stabilize else "")
        self.printer = Printer(self.label, tr, progress)
        self.solver = _solver(tr, self.printer, task.max_iterations,
                              tol=min(1e-10, task.tolerance))
        self.limits = Limits.of(task)
        self.build_seconds = time.perf_counter() - t_build
        self.runs = 0                   # IPOPT runs
        self.seconds = 0.0              # in IPOPT

    def zero_delta(self) -> np.ndarray:
        return np.zeros((self.tr.layout.nq, self.tr.N))

    def run(self, w0, limits: Limits | None = None, delta=None, lam=None,
            cap: float = math.inf, round_: int = 0, label: str = "") -> NLPResult:
        """IPOPT from w0 (with the multipliers ``lam = (lam_g, lam_x)`` if given), the
        limits' values (the task's by default), at most ``cap`` iterations."""
        tr = self.tr
        limits = self.limits if limits is None else limits
        delta = self.zero_delta() if delta is None else delta
        lbx, ubx, lbg, ubg = tr.bounds(limits)
        args = {"x0": np.clip(w0, lbx, ubx), "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg,
                "p": tr.parameters(delta, limits)}
        if lam is not None:
            args["lam_g0"], args["lam_x0"] = lam
        self.printer.start(round_, label or self.label, (lbg, ubg), cap)
        start = time.perf_counter()
        sol = self.solver(**args)
        seconds = time.perf_counter() - start
        self.runs += 1
        self.seconds += seconds
        st = self.solver.stats()
        return NLPResult(w=np.array(sol["x"]).ravel(), lam_g=np.array(sol["lam_g"]).ravel(),
                         lam_x=np.array(sol["lam_x"]).ravel(), status=st["return_status"],
                         success=st["return_status"] in SUCCESS,
                         iterations=int(st["iter_count"]), seconds=seconds,
                         objective=float(sol["f"]),
                         extra={"g": np.array(sol["g"]).ravel(), "limits": limits,
                                "bounds": (lbg, ubg)})


def accurate_flow(tr: Transcription, w, rtol: float = 1e-13):
    """(q at the end of each interval by DOP853, by the NLP's RK4): shape (nq, N) each."""
    ctrl, Q, T = tr.unpack(w)
    zero = np.zeros(tr.layout.nq)
    exact, rk4 = [], []
    G = Fast(tr.G)
    for k in range(tr.N):
        cl = tr.local_ctrl(ctrl, k)

        def rhs(s, q, cl=cl):
            return G(s, q, cl, T)[0]
        sol = solve_ivp(rhs, (0.0, 1.0), Q[:, k], method="DOP853", rtol=rtol,
                        atol=rtol * 1e-2)
        exact.append(sol.y[:, -1])
        out = tr.F.call([Q[:, k], cl, T, zero])
        rk4.append(np.array(out[0].full()).ravel())
    return np.array(exact).T, np.array(rk4).T


@dataclass
class SolveReport:
    tr: Transcription
    result: NLPResult
    delta: np.ndarray
    rounds: list = field(default_factory=list)      # per solve: status, iterations, s
    success: bool = False
    message: str = ""
    blocking: dict = field(default_factory=dict)
    solver_seconds: float = 0.0
    build_seconds: float = 0.0    # the transcription, the guess and IPOPT's derivatives
    continuity_exact: float = float("nan")   # max |Q_{k+1} - flow(Q_k)| at the end
    session: Session | None = None


def solve(task, goal, progress: bool = False, max_rounds: int = 6, w0=None,
          diagnose: bool = True, stabilize: bool = False) -> SolveReport:
    """The task solved from the goal's guess (or w0), then made exact by defect
    correction; on failure, diagnosed (which limit blocks it)."""
    session = Session(task, goal, progress, stabilize, w0)
    tr = session.tr
    stages = solve_with_continuation(session)     # [(result, stage)], the task's last
    res = stages[-1][0]
    rounds = [_round(0, r, stage) for r, stage in stages]
    report = SolveReport(tr, res, session.zero_delta(), rounds,
                         build_seconds=session.build_seconds, session=session)
    if not res.success:
        report.message = failure_message(tr, res, stages[-1][1])
        if diagnose:
            found = diagnose_failure(session, res)
            report.blocking = found.to_dict()
            if found.solution is not None:          # feasible after all: a new start
                res = found.solution
                report.rounds.append(_round(0, res, "restart: " + found.message))
            elif found.limit:
                report.message = ("infeasible: " + found.message + "; "
                                  + report.message.removeprefix("infeasible: "))
            elif found.feasible:
                # the task is shown feasible: the violations left are where IPOPT stopped,
                # not evidence that the task is infeasible
                report.message = ("failed: " + report.message.removeprefix("infeasible: ")
                                  + "; " + found.message)
            else:
                report.message += "; " + found.message
        if not res.success:
            report.solver_seconds = sum(r["seconds"] for r in report.rounds)
            return report
        report.result = res
    return correct(session, report, max_rounds)


def _round(r: int, res: NLPResult, stage: str = "") -> dict:
    out = {"round": r, "status": res.status, "iterations": res.iterations,
           "seconds": res.seconds}
    if stage:
        out["stage"] = stage
    return out


def correct(session: Session, report: SolveReport, max_rounds: int) -> SolveReport:
    """Defect correction: the continuity constraints carry the accurate flow's defects at
    the last solution, re-solved warm (primal and dual) until they stop changing."""
    tr, task, res = session.tr, session.task, report.result
    delta = session.zero_delta()
    change = np.inf
    for r in range(1, max_rounds + 1):
        t0 = time.perf_counter()
        exact, rk4 = accurate_flow(tr, res.w)
        session.seconds += time.perf_counter() - t0
        new_delta = exact - rk4
        change = float(np.max(np.abs(new_delta - delta)))
        _, Q, _ = tr.unpack(res.w)
        report.continuity_exact = float(np.max(np.abs(Q[:, 1:] - exact)))
        if change <= task.tolerance:
            break
        delta = new_delta
        nxt = session.run(res.w, delta=delta, lam=(res.lam_g, res.lam_x), round_=r)
        report.rounds.append({**_round(r, nxt), "defect_change": change})
        if not nxt.success:
            report.result = nxt
            report.message = failure_message(tr, nxt) + " (in defect correction)"
            report.solver_seconds = session.seconds
            report.delta = delta
            return report
        res = nxt
    report.result, report.delta, report.solver_seconds = res, delta, session.seconds
    report.success = True
    report.message = (f"solved: {len(report.rounds)} IPOPT solves, "
                      f"{sum(r['iterations'] for r in report.rounds)} iterations, defect "
                      f"change {change:.1e}")
    return report


def failure_message(tr: Transcription, res: NLPResult, stage: str = "") -> str:
    viol = sorted(violations(tr, res.extra["g"], res.extra.get("bounds")),
                  key=lambda kv: -kv[1])
    worst = [f"{name} (violated by {v:.2e})" for name, v in viol[:3] if v > 1e-8]
    status = res.status.replace("_", " ").lower()
    where = f" at {stage}" if stage else ""
    if worst:
        return f"infeasible: IPOPT stopped{where} with '{status}'; largest violations: " + \
               ", ".join(worst)
    return f"IPOPT stopped{where} with '{status}' after {res.iterations} iterations"
