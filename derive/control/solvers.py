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

from .problem import MAX_QP_ITER, Problem, freeze
from .qp import DenseQP, SOLVED
from .spline import ctrl_from_jets, play, shift


def ms_solver(problem: Problem, tol: float = 1e-12, max_iter: int = 500):
    """IPOPT on the multiple-shooting form of the problem (the Hessian of one piece,
    mapped; expanded to SX)."""
    import casadi as ca
    return ca.nlpsol("replan_ms", "ipopt", problem.functions["nlp_ms"],
                     {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
                      "ipopt.tol": tol, "ipopt.max_iter": max_iter, "expand": True})


def ms_solve(problem: Problem, solver, w: np.ndarray, p: np.ndarray, T_fixed):
    """Solve the multiple-shooting form from w (the states by the motion w gives from
    p's q): (w, IPOPT's status, iterations)."""
    N = problem.N
    C = w[:-1].reshape(problem.nc, 3, order="F")
    Q = [p[7:]]
    for k in range(N):
        Q.append(np.array(problem.functions["piece"](Q[-1], C[k:k + 4].ravel(order="F"),
                                                     w[-1])).ravel())
    x0 = np.r_[w, np.concatenate(Q)]
    nlp = problem.functions["nlp_ms"]
    lbw, ubw = problem.bounds(T_fixed)
    nx = nlp["x"].shape[0]
    lbx = np.r_[lbw, np.full(nx - problem.nw, -np.inf)]
    ubx = np.r_[ubw, np.full(nx - problem.nw, np.inf)]
    n_extra = nlp["g"].shape[0] - problem.ng
    lbg = np.r_[problem.lbg, np.zeros(n_extra)]
    ubg = np.r_[problem.ubg, np.zeros(n_extra)]
    sol = solver(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    st = solver.stats()
    return np.array(sol["x"]).ravel()[:problem.nw], st["return_status"], int(st["iter_count"])


def initial_solution(problem: Problem, plan, q0: np.ndarray, u0: np.ndarray,
                     t0: float = 0.0):
    """The problem at the start solved to convergence by IPOPT (multiple shooting), from
    the offline plan's law (its jets on the problem's knots) and the motion it gives:
    (w, IPOPT's status, iterations)."""
    law = plan.law
    T = law.T if problem.land else law.T - t0
    N = problem.N
    h = T / N
    t = t0 + h * np.arange(N + 1)
    uu = law.u(t)
    jets = np.stack([uu[0:3].T, uu[3:6].T, uu[6:9].T], axis=1)
    w0 = np.r_[ctrl_from_jets(jets, h).ravel(order="F"), T]
    return ms_solve(problem, ms_solver(problem), w0, problem.params(u0, T, q0),
                    None if problem.land else T)


# ---- the Python route ------------------------------------------------------------------------
@dataclass
class Stats:
    calls: int = 0
    replans: int = 0
    failures: int = 0
    solve_t: list = field(default_factory=list)
    solve_s: list = field(default_factory=list)
    laws: list = field(default_factory=list)     # (t, Segments) of every re-plan


class PyReplan:
    """The controller in Python: ``controller(call) -> Segments | None`` (the loop of
    ``controller.c``, line for line).  ``keep_laws``: record every law set (plots)."""

    def __init__(self, problem: Problem, w0: np.ndarray, t0: float, T_end: float,
                 period: float, iterations: int = 1, keep_laws: bool = False):
        self.problem, self.iterations = problem, iterations
        self.w0, self.t0, self.T_end, self.period = np.array(w0), t0, T_end, period
        self.keep_laws = keep_laws
        self.qp = DenseQP(problem.nw, problem.ng, MAX_QP_ITER)
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
        start = time.perf_counter()
        w = self.step(call.t, call.q, call.u, T)
        self.stats.solve_s.append(time.perf_counter() - start)
        self.stats.solve_t.append(call.t)
        if w is None:
            self.stats.failures += 1
            return None
        self.w, self.t_prev = w, call.t
        self.stats.replans += 1
        seg = play(w, call.t, call.u)
        if self.keep_laws:
            self.stats.laws.append((call.t, seg))
        return seg

    def step(self, t: float, q, u, T: float):
        """The real-time iterations at t: the new w, or None when a QP fails."""
        pr = self.problem
        w = shift(self.w, self.t_prev, t, T)
        p = pr.params(u, T, q)
        lbx, ubx = pr.bounds(None if pr.land else T)
        for _ in range(self.iterations):
            H, g, A, lba, uba = (np.array(v) for v in pr.qp_data(w, p))
            dx, status, _ = self.qp.solve(H, g.ravel(), A, lba.ravel(), uba.ravel(),
                                          lbx - w, ubx - w)
            if status != SOLVED or not np.all(np.isfinite(dx)):
                return None
            w = w + dx
        return w


class IpoptReplan(PyReplan):
    """Every sample solved to convergence by IPOPT in-process (multiple shooting, from
    the shifted previous solution): the latency peer of the generated controller."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.solver = ms_solver(self.problem, tol=1e-8, max_iter=200)

    def step(self, t, q, u, T):
        pr = self.problem
        w = shift(self.w, self.t_prev, t, T)
        w, status, _ = ms_solve(pr, self.solver, w, pr.params(u, T, q),
                                None if pr.land else T)
        if status not in ("Solve_Succeeded", "Solved_To_Acceptable_Level"):
            return None
        return w
