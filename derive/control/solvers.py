"""The re-planning problem's solvers in Python (:mod:`derive.control.problem`):

* :class:`PyReplan`: the controller's loop in Python, for research and for checking the
  C (the same CasADi functions evaluated in-process, :class:`~derive.control.qp.DenseQP`);
* :class:`IpoptReplan`: every sample solved to convergence by IPOPT in-process (the
  latency peer of ``derive bench control``, and ``solver = "ipopt"``);
* :func:`initial_solution`: the problem at the start solved by IPOPT from the offline
  plan (the first warm start of every route).

The C controller is :mod:`derive.control.render` (its sources) and
:mod:`derive.control.compiled` (compiled and loaded).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .problem import MAX_QP_ITER, QP_BUDGET, SOFT_ITERATIONS, Problem, freeze
from .qp import DenseQP, SOLVED
from .spline import ctrl_from_jets, play, shift


# IPOPT for the start and at every sample of IpoptReplan: warm starts (the barrier begins
# small, the bounds' push slight); a point it stops at by its iteration limit is used when
# its constraints hold to USABLE_VIOLATION (its tail, at a small barrier parameter, can
# creep for hundreds of iterations: a drop from 3.4 m with a spin of 1.4 rad/s took 314
# to converge to 1e-10 from a start that already met the constraints to 1e-6)
IPOPT_OPTIONS = {"ipopt.tol": 1e-8, "ipopt.max_iter": 100, "ipopt.mu_init": 1e-3,
                 "ipopt.bound_push": 1e-6, "ipopt.bound_frac": 1e-6}
USABLE_VIOLATION = 1e-4


def ms_solver(problem: Problem):
    """IPOPT on the multiple-shooting form of the problem with its end conditions soft,
    as the QP has them (the Hessian of one piece, mapped; expanded to SX): built once
    per problem (about 5 s) and shared by the start and every sample of
    :class:`IpoptReplan`.  Where the hard problem is feasible the exact penalty gives
    its solution, the slacks 0."""
    import casadi as ca
    if "ipopt" not in problem.functions:
        problem.functions["ipopt"] = ca.nlpsol(
            "replan_ms", "ipopt", problem.functions["nlp_ms_soft"],
            {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
             "expand": True, **IPOPT_OPTIONS})
    return problem.functions["ipopt"]


def ms_solve(problem: Problem, w: np.ndarray, p: np.ndarray, T_fixed,
             scale: float = 1.0) -> dict:
    """Solve the multiple-shooting form from w (the states by the motion w gives from
    p's q, the slacks from 0; ``scale``: the soft rows' penalties' factor): {w, status
    (IPOPT's), iterations, violation, slack (the largest), usable}."""
    N = problem.N
    C = w[:-1].reshape(problem.nc, 3, order="F")
    Q = [p[7:]]
    for k in range(N):
        Q.append(np.array(problem.functions["piece"](Q[-1], C[k:k + 4].ravel(order="F"),
                                                     w[-1])).ravel())
    ns = problem.ns
    x0 = np.r_[w, np.concatenate(Q), np.zeros(ns)]
    nlp = problem.functions["nlp_ms_soft"]
    lbw, ubw = problem.bounds(T_fixed)
    nx = nlp["x"].shape[0]
    lbx = np.r_[lbw, np.full(nx - problem.nw - ns, -np.inf), np.zeros(ns)]
    ubx = np.r_[ubw, np.full(nx - problem.nw, np.inf)]
    n_extra = nlp["g"].shape[0] - problem.ng
    lbg = np.r_[problem.lbg, np.zeros(n_extra)]
    ubg = np.r_[problem.ubg, np.zeros(n_extra)]
    solver = ms_solver(problem)
    sol = solver(x0=x0, p=np.r_[p, scale], lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    st = solver.stats()
    x = np.array(sol["x"]).ravel()
    g = np.array(sol["g"]).ravel()
    violation = float(max(np.max(lbg - g), np.max(g - ubg),
                          np.max(lbx - x), np.max(x - ubx), 0.0))
    converged = st["return_status"] in CONVERGED
    return {"w": x[:problem.nw], "status": st["return_status"],
            "iterations": int(st["iter_count"]), "violation": violation,
            "slack": float(np.max(x[nx - ns:])) if ns else 0.0,
            "usable": bool(np.all(np.isfinite(x))) and (converged
                                                        or violation <= USABLE_VIOLATION)}


CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def initial_solution(problem: Problem, plan, q0: np.ndarray, u0: np.ndarray,
                     t0: float = 0.0) -> dict:
    """The problem at the start, from the offline plan's law (its jets on the problem's
    knots) and the motion it gives, solved by IPOPT (multiple shooting): its solution if
    usable (:func:`ms_solve`), else the offline plan's law itself, which solved the
    task (the first real-time iterations improve on it).  :func:`ms_solve`'s dict with
    ``start``: where w comes from."""
    law = plan.law
    T = law.T if problem.land else law.T - t0
    N = problem.N
    h = T / N
    t = t0 + h * np.arange(N + 1)
    uu = problem.law_u(law, t)
    jets = np.stack([uu[0:3].T, uu[3:6].T, uu[6:9].T], axis=1)
    w0 = np.r_[ctrl_from_jets(jets, h).ravel(order="F"), T]
    out = ms_solve(problem, w0, problem.params(u0, T, q0), None if problem.land else T)
    if out["status"] in CONVERGED:
        out["start"] = "IPOPT converged from the offline plan"
    elif out["usable"]:
        out["start"] = (f"IPOPT's last point from the offline plan (stopped: "
                        f"{out['status']}; its constraints hold to {out['violation']:.1e})")
    else:
        out["start"] = (f"the offline plan's law (IPOPT from it stopped with "
                        f"{out['status']})")
        out["w"] = w0
    return out


# ---- the Python route ------------------------------------------------------------------------
SOFTENED_TOL = 1e-8    # a re-plan whose slacks exceed this missed its end conditions


@dataclass
class Stats:
    """The counters of a run, named as the C's (controller.h's CTL_STAT_*): calls,
    re-plans, samples whose solver failed (the law in use went on: a QP without a
    solution within its iteration limit, or IPOPT not converged) and re-plans that met
    their end conditions only in part (the soft rows' slacks positive)."""
    calls: int = 0
    replans: int = 0
    failures: int = 0
    softened: int = 0
    solve_t: list = field(default_factory=list)
    solve_s: list = field(default_factory=list)   # the thread's CPU time per solve
    laws: list = field(default_factory=list)     # (t, Segments) of every re-plan


class PyReplan:
    """The controller in Python: ``controller(call) -> Segments | None`` (the loop of
    ``controller.c``, line for line).  ``keep_laws``: record every law set (plots)."""

    def __init__(self, problem: Problem, w0: np.ndarray, t0: float, T_end: float,
                 period: float, iterations: int = 1, keep_laws: bool = False):
        self.problem, self.iterations = problem, iterations
        self.w0, self.t0, self.T_end, self.period = np.array(w0), t0, T_end, period
        self.keep_laws = keep_laws
        self.qp = DenseQP(problem.nw, problem.ng, MAX_QP_ITER, problem.ns)
        self.softened = False
        self.reset()

    def reset(self):
        self.w = self.w0.copy()
        self.t_prev = self.t0
        self.done = False
        self.stats = Stats()

    def horizon(self, t: float) -> float:
        """T at a call at t: reorient, the time to the plan's end; land, the previous
        horizon less the time since."""
        if not self.problem.land:
            return self.T_end - t
        return self.w[-1] - (t - self.t_prev)

    def __call__(self, call):
        self.stats.calls += 1
        if self.done:
            return None
        if call.reason == "event":         # touchdown (or contact, lift-off): the goal's end
            self.done = True
            return None
        T = self.horizon(call.t)
        if T < freeze(self.period):
            self.done = True
            return None
        start = time.thread_time()
        w = self.step(call.t, call.q, call.u, T)
        self.stats.solve_s.append(time.thread_time() - start)
        self.stats.solve_t.append(call.t)
        if w is None:
            self.stats.failures += 1
            return None
        self.w, self.t_prev = w, call.t
        self.stats.replans += 1
        self.stats.softened += self.softened
        seg = play(w, call.t, call.u)
        if self.keep_laws:
            self.stats.laws.append((call.t, seg))
        return seg

    def step(self, t: float, q, u, T: float):
        """The real-time iterations at t, linearised at the measured state and the last
        solution shifted onto the new horizon: ``iterations`` Gauss-Newton steps, and
        more while a step leaves the end conditions unmet (up to SOFT_ITERATIONS, the
        QPs' iterations within QP_BUDGET in all); the new w, or None when the first QP
        fails (its iteration limit)."""
        pr = self.problem
        w = shift(self.w, self.t_prev, t, T)
        p = pr.params(u, T, q)
        z1, z2 = pr.penalties(T, self.w0[-1])
        self.softened = False
        budget = QP_BUDGET
        for it in range(max(self.iterations, SOFT_ITERATIONS)):
            H, g, A, lba, uba = (np.array(v) for v in pr.qp_data(w, p))
            lbq, ubq = pr.step_bounds(w, None if pr.land else T)
            self.qp.max_iter = min(budget, MAX_QP_ITER)
            dx, status, its = self.qp.solve(H, g.ravel(), A, lba.ravel(),
                                            pr.region_rows(uba.ravel()), lbq, ubq, z1, z2)
            budget -= its
            if status != SOLVED or not np.all(np.isfinite(dx)):
                return w if it > 0 else None
            soft = bool(np.max(self.qp.slack) > SOFTENED_TOL)
            w = w + dx
            self.softened = soft
            if (it + 1 >= self.iterations and not soft) or budget <= 0:
                break
        return w


class IpoptReplan(PyReplan):
    """Every sample solved to convergence by IPOPT in-process (multiple shooting, from
    the shifted previous solution, the end conditions soft as in the QP): the latency
    peer of the generated controller and the reachability oracle of ``derive bench
    control``."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        ms_solver(self.problem)
        self.ipopt_iterations: list = []

    def step(self, t, q, u, T):
        pr = self.problem
        w = shift(self.w, self.t_prev, t, T)
        out = ms_solve(pr, w, pr.params(u, T, q), None if pr.land else T,
                       pr.penalty_scale(T, self.w0[-1]))
        self.ipopt_iterations.append(out["iterations"])
        if not out["usable"]:
            return None
        self.softened = out["slack"] > SOFTENED_TOL
        return out["w"]
