"""IPOPT over the transcription, defect correction, and the infeasibility report.

``solve(task)`` runs, in order: the initial guess, an IPOPT solve with the NLP's
RK4, then rounds of defect correction (the accurate flow's defects as parameters of the
same NLP, warm-started) until the defects stop changing by more than the task's
tolerance.  A progress line per IPOPT iteration goes to stderr when asked.  When IPOPT
fails, the constraint groups are ranked by their violation and each of the task's limits
(max_acceleration, region, horizon) is lifted in turn: a limit whose removal makes the
task solvable is named as the one that blocks it, with the value the plan would need.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

from .functions import Fast
from .guess import initial_guess
from .transcribe import NLPResult, Relax, Transcription

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


class Printer(ca.Callback):
    """IPOPT's iteration callback: one line per iteration on stderr."""

    def __init__(self, label: str, tr: Transcription, enabled: bool):
        ca.Callback.__init__(self)
        self.label, self.tr, self.enabled = label, tr, enabled
        self.nx, self.ng = tr.w.shape[0], tr.g.shape[0]
        self.iteration, self.round = 0, 0
        self.construct("progress", {})

    def start(self, round_: int):
        self.round, self.iteration = round_, 0

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
            viol = violations(self.tr, g)
            worst = max(viol, key=lambda kv: kv[1]) if viol else ("", 0.0)
            print(f"  plan {self.label}  round {self.round}  it {self.iteration:4d}  objective "
                  f"{float(arg[1]):.6e}  violation {worst[1]:.2e}"
                  + (f" ({worst[0]})" if worst[1] > 0 else ""), file=sys.stderr, flush=True)
        self.iteration += 1
        return [0]


def violations(tr: Transcription, g) -> list:
    """(group name, max violation) for every constraint group at constraint values g."""
    g = np.asarray(g, dtype=float).ravel()
    v = np.maximum(np.maximum(tr.lbg - g, g - tr.ubg), 0.0)
    return [(grp.name, float(np.max(v[grp.start:grp.stop])) if grp.stop > grp.start else 0.0)
            for grp in tr.groups]


def _solver(tr: Transcription, printer: Printer, max_iter: int, tol: float):
    """One IPOPT instance serves every round (building one costs time): warm-start
    options throughout, so that the defect-correction rounds, started from the previous
    primal and dual solution, take a few iterations; the adaptive barrier update picks a
    small mu there by itself."""
    nlp = {"x": tr.w, "f": tr.J, "g": tr.g, "p": ca.vec(tr.delta)}
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


def _run(solver, tr, w0, delta, lam_g=None, lam_x=None) -> NLPResult:
    args = {"x0": w0, "lbx": tr.lbx, "ubx": tr.ubx, "lbg": tr.lbg, "ubg": tr.ubg,
            "p": np.asarray(delta).ravel(order="F")}
    if lam_g is not None:
        args["lam_g0"], args["lam_x0"] = lam_g, lam_x
    start = time.perf_counter()
    sol = solver(**args)
    seconds = time.perf_counter() - start
    st = solver.stats()
    return NLPResult(w=np.array(sol["x"]).ravel(), lam_g=np.array(sol["lam_g"]).ravel(),
                     lam_x=np.array(sol["lam_x"]).ravel(), status=st["return_status"],
                     success=st["return_status"] in SUCCESS,
                     iterations=int(st["iter_count"]), seconds=seconds,
                     objective=float(sol["f"]),
                     extra={"g": np.array(sol["g"]).ravel()})


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


def solve(task, progress: bool = False, max_rounds: int = 6, relax: Relax = Relax(),
          w0=None, diagnose: bool = True, stabilize: bool = False) -> SolveReport:
    t_build = time.perf_counter()
    tr = Transcription(task, relax, stabilize)
    if w0 is None:
        w0 = initial_guess(tr)
    label = task.goal + (f" (without {', '.join(sorted(relax.names))})" if relax.names else "")
    label += " (stability conditions)" if stabilize else ""
    printer = Printer(label, tr, progress)
    delta = np.zeros((tr.layout.nq, tr.N))
    solver = _solver(tr, printer, task.max_iterations, tol=min(1e-10, task.tolerance))
    build = time.perf_counter() - t_build
    printer.start(0)
    res = _run(solver, tr, w0, delta)
    rounds = [{"round": 0, "status": res.status, "iterations": res.iterations,
               "seconds": res.seconds}]
    total = res.seconds
    report = SolveReport(tr, res, delta, rounds, build_seconds=build)
    if not res.success:
        report.solver_seconds = total
        report.message = failure_message(tr, res)
        if diagnose and not relax.names:
            report.blocking = find_blocking(task, progress)
            if report.blocking.get("limit"):
                report.message = ("infeasible: " + report.blocking["message"] + "; "
                                  + report.message.removeprefix("infeasible: "))
            else:
                report.message += "; " + report.blocking["message"]
        return report
    change = np.inf
    for r in range(1, max_rounds + 1):
        t0 = time.perf_counter()
        exact, rk4 = accurate_flow(tr, res.w)
        new_delta = exact - rk4
        change = float(np.max(np.abs(new_delta - delta)))
        total += time.perf_counter() - t0
        _, Q, _ = tr.unpack(res.w)
        report.continuity_exact = float(np.max(np.abs(Q[:, 1:] - exact)))
        if change <= task.tolerance:
            break
        delta = new_delta
        printer.start(r)
        nxt = _run(solver, tr, res.w, delta, res.lam_g, res.lam_x)
        rounds.append({"round": r, "status": nxt.status, "iterations": nxt.iterations,
                       "seconds": nxt.seconds, "defect_change": change})
        total += nxt.seconds
        if not nxt.success:
            report.result = nxt
            report.message = failure_message(tr, nxt) + " (in defect correction)"
            report.solver_seconds = total
            report.delta = delta
            return report
        res = nxt
    report.result, report.delta, report.solver_seconds = res, delta, total
    report.success = True
    report.message = (f"solved: {len(rounds)} IPOPT solves, "
                      f"{sum(r['iterations'] for r in rounds)} iterations, defect change "
                      f"{change:.1e}")
    return report


def failure_message(tr: Transcription, res: NLPResult) -> str:
    viol = sorted(violations(tr, res.extra["g"]), key=lambda kv: -kv[1])
    worst = [f"{name} (violated by {v:.2e})" for name, v in viol[:3] if v > 1e-8]
    status = res.status.replace("_", " ").lower()
    if worst:
        return f"infeasible: IPOPT stopped with '{status}'; largest violations: " + \
               ", ".join(worst)
    return f"IPOPT stopped with '{status}' after {res.iterations} iterations"


def find_blocking(task, progress: bool) -> dict:
    """Lift each task limit in turn; the first whose removal makes the task solvable is
    the one that blocks it, reported with the value the relaxed plan needs."""
    from .law import Law
    candidates = ["max_acceleration", "region"]
    if task.free_time and task.horizon is not None:
        candidates.append("horizon")
    for name in candidates:
        if name == "region" and task.circle is not None:
            continue
        rep = solve(task, progress=progress, max_rounds=0, relax=Relax(frozenset([name])),
                    diagnose=False)
        if not rep.result.success:
            continue
        ctrl, Q, T = rep.tr.unpack(rep.result.w)
        law = Law(rep.tr.spline, ctrl, T, rep.tr.kind, task.circle[:3] if task.circle else ())
        t = np.linspace(0, T, 40 * rep.tr.N + 1)
        u = law.u(t)
        if name == "max_acceleration":
            need = float(np.max(np.linalg.norm(u[6:9], axis=0)))
            limit = task.max_acceleration
            text = (f"max_acceleration blocks it: without it the plan needs |OP''| up to "
                    f"{need:.4g} m/s^2 (limit {limit:.4g})")
        elif name == "region":
            need = float(np.max(np.linalg.norm(u[0:3].T - task.region_center, axis=1)))
            limit = task.region_radius
            text = (f"region blocks it: without it P goes {need:.4g} m from the centre "
                    f"(radius {limit:.4g} m)")
        else:
            need, limit = T, task.horizon
            text = f"horizon blocks it: without it the plan takes {T:.4g} s " \
                   f"(horizon {limit:.4g} s)"
        if need > limit * (1 + 1e-6):
            return {"limit": name, "needed": need, "message": text}
        return {"limit": None, "message": f"the task is feasible (solved without {name}, "
                                          "which stays inactive): IPOPT did not converge "
                                          "from this start; try more intervals or "
                                          "max_iterations"}
    return {"limit": None, "message": "no single limit (max_acceleration, region, horizon) "
                                      "unblocks it: the goal itself is out of reach"}
