"""``derive bench control``: the re-planning controller (mode = "replan") by measurement.

On the landing of ``derive/control/examples/land_push.toml`` (dropped from 2 m with a
tumble, upright at touchdown; 30 intervals, one real-time iteration every 20 ms):

* **Re-plan latency**: the generated C controller's solve per sample (a call that runs
  the solver: the shift, qp_data, the QP, the step and the law), timed inside the C over
  every sample of every closed-loop run below; beside it, the same problem solved to
  convergence every sample by IPOPT in-process (CasADi's, from the same shifted start)
  over a few runs, and the QP alone (20 QPs of those runs) by CasADi's qrqp (the QP
  solver its libm-only code generation offers) and qpOASES against ours.  Targets:
  median <= 5 ms, p99 <= 10 ms.
* **Landing under disturbance**: ``n`` seeded disturbances, each a plant that differs
  from the model (M, m and each of J_x, J_y, J_z by a factor uniform in [0.85, 1.15]),
  one push (at a uniform time in [0.1, 0.75] of the plan's horizon, a horizontal impulse
  of uniform direction and magnitude uniform in [0, 0.05] N s, at a uniform point of the
  sphere's surface) and noise on what the controller reads (omega 0.01 rad/s, attitude
  0.002 rad, C 1 mm, C' 0.01 m/s); upright within 2 deg at touchdown: the closed loop's
  rate and, beside it, the plan played open loop on the same plant.  Target: >= 95 %.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import abi
from ..commands import Target
from ..control.replan import MEDIAN_TARGET_MS as MEDIAN_MS
from ..control.replan import P99_TARGET_MS as P99_MS

TASK = Path(__file__).resolve().parents[1] / "control" / "examples" / "land_push.toml"
UPRIGHT_DEG, RATE = 2.0, 0.95
FACTOR = 0.15                 # M, m, J each by a factor uniform in 1 +- this
PUSH_MAX = 0.05               # N s
PUSH_WINDOW = (0.1, 0.75)     # the push's time, in fractions of the plan's horizon
NOISE = (0.01, 0.002, 0.001, 0.01)
QP_SAMPLE = 20                # QPs of the IPOPT runs' samples solved by every QP solver


def disturbance(k: int, T: float, radius: float):
    """The k-th seeded disturbance."""
    from ..scene.scene import Disturbance
    rng = np.random.default_rng(1000 + k)
    f = rng.uniform(1 - FACTOR, 1 + FACTOR, 5)
    t_push = rng.uniform(*PUSH_WINDOW) * T
    ang = rng.uniform(0.0, 2 * math.pi)
    P = rng.uniform(0.0, PUSH_MAX)
    at = rng.normal(size=3)
    at *= radius / np.linalg.norm(at)
    return Disturbance(seed=k, mass_factor=f[0], point_mass_factor=f[1],
                       inertia_factor=tuple(f[2:5]), noise=NOISE,
                       pushes=((t_push, P * math.cos(ang), P * math.sin(ang), 0.0,
                                *at),))


def upright_error_deg(result, target) -> float:
    """The angle to the target at the first impact (inf: no impact)."""
    from .. import layout
    imp = [e["t"] for e in result.events if e["kind"] == "impact"]
    if not imp:
        return math.inf
    i = np.flatnonzero((result.row_kind == abi.ROW_KIND["before_event"]) & (result.t == imp[0]))[0]
    A = result.q[i, layout.GENERAL.A].reshape(3, 3)
    R = np.asarray(target).T @ A
    s = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return math.degrees(math.atan2(s, 0.5 * (np.trace(R) - 1.0)))


class _Quiet:
    """stdout of the C libraries (qpOASES prints its licence banner) to /dev/null."""

    def __enter__(self):
        import os
        import sys
        sys.stdout.flush()
        self.saved = os.dup(1)
        self.null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(self.null, 1)

    def __exit__(self, *exc):
        import os
        os.dup2(self.saved, 1)
        os.close(self.saved)
        os.close(self.null)


def _qrqp_against_ours(su, qps: list) -> dict:
    """The QP alone on the same data: ours in C (ctl_qp.h, timed through its shim)
    against CasADi's qrqp and qpOASES in-process."""
    import casadi as ca
    from ..control.qp import CDenseQP
    from ..control.replan import max_qp_iter
    n, m = su.problem.nw, su.problem.ng
    c_qp = CDenseQP(n, m, max_qp_iter(su.problem))
    sp = {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(m, n)}
    peers = {"qrqp": ca.conic("qp", "qrqp", sp, {"print_iter": False, "print_header": False,
                                                  "error_on_fail": False,
                                                  "print_info": False}),
             "qpoases": ca.conic("qp", "qpoases", sp, {"printLevel": "none",
                                                       "error_on_fail": False})}
    ours = []
    theirs = {name: [] for name in peers}
    fails = {name: 0 for name in peers}
    for H, g, A, lba, uba, lbx, ubx in qps:
        tick = time.perf_counter()
        c_qp.solve(H, g, A, lba, uba, lbx, ubx)
        ours.append(time.perf_counter() - tick)
        for name, solver in peers.items():
            tick = time.perf_counter()
            solver(h=H, g=g, a=A, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
            theirs[name].append(time.perf_counter() - tick)
            fails[name] += not solver.stats()["success"]
    out = {"ours_ms": float(np.median(ours) * 1e3), "qps": len(qps)}
    for name in peers:
        out[f"{name}_ms"] = float(np.median(theirs[name]) * 1e3)
        out[f"{name}_failed"] = fails[name]
    return out


def run(n: int = 1000, ipopt_runs: int = 3, progress=lambda m: None) -> dict:
    from ..control.core import load_control_task
    from ..control.replan import setup
    task = load_control_task(TASK)
    progress("the offline plan and the controller")
    su = setup(task)
    compiled = su.compiled
    T, radius, target = su.T_plan, task.scene.size[0], task.target
    closed_err, open_err, times, failures = [], [], [], 0
    start = time.perf_counter()
    for k in range(n):
        if k % 100 == 0:
            progress(f"closed and open loop, disturbance {k + 1} of {n}")
        dist = disturbance(k, T, radius)
        prep = su.plant(dist)
        res, _ = su.closed(prep, dist, compiled.controller())
        times.append(compiled.times()[:, 1])
        failures += compiled.stats()["failures"]
        closed_err.append(upright_error_deg(res, target))
        open_err.append(upright_error_deg(su.open(prep, dist), target))
    sweep_s = time.perf_counter() - start
    times = np.concatenate(times) * 1e3
    progress("IPOPT in-process on the same samples")
    ipopt = []
    qps = []
    for k in range(ipopt_runs):
        dist = disturbance(k, T, radius)
        prep = su.plant(dist)
        ctl = su.ipopt()
        su.closed(prep, dist, ctl)
        ipopt.extend(ctl.stats.solve_s)
        py = su.python()
        solve = py.qp.solve

        def keep(*args, solve=solve):
            qps.append(tuple(np.array(a, dtype=float) for a in args))
            return solve(*args)
        py.qp.solve = keep
        su.closed(prep, dist, py)
    progress("the QP alone: ours against qrqp and qpOASES")
    with _Quiet():            # qrqp runs to its 1000 iterations on most: 20 QPs suffice
        qp = _qrqp_against_ours(su, qps[::max(1, len(qps) // QP_SAMPLE)][:QP_SAMPLE])
    ipopt = np.array(ipopt) * 1e3
    closed_err, open_err = np.array(closed_err), np.array(open_err)
    return {"n": n, "horizon": T, "intervals": su.problem.N, "period": su.period,
            "variables": su.problem.nw, "constraints": su.problem.ng,
            "c_median_ms": float(np.median(times)), "c_p99_ms": float(np.percentile(times, 99)),
            "c_max_ms": float(np.max(times)), "c_samples": int(len(times)),
            "ipopt_median_ms": float(np.median(ipopt)),
            "ipopt_p99_ms": float(np.percentile(ipopt, 99)), "ipopt_samples": int(len(ipopt)),
            "qp": qp, "failed_qps": int(failures),
            "closed_rate": float(np.mean(closed_err < UPRIGHT_DEG)),
            "open_rate": float(np.mean(open_err < UPRIGHT_DEG)),
            "closed_median_deg": float(np.median(closed_err)),
            "closed_worst_deg": float(np.max(closed_err)),
            "open_median_deg": float(np.median(open_err)),
            "sweep_seconds": sweep_s}


def targets(out: dict) -> list:
    return [
        Target(f"re-plan latency of the C controller: median {out['c_median_ms']:.3f} ms "
               f"<= {MEDIAN_MS:g} ms", out["c_median_ms"] <= MEDIAN_MS),
        Target(f"re-plan latency of the C controller: p99 {out['c_p99_ms']:.3f} ms "
               f"<= {P99_MS:g} ms", out["c_p99_ms"] <= P99_MS),
        Target(f"landing under disturbance: upright within {UPRIGHT_DEG:g} deg in "
               f"{100 * out['closed_rate']:.1f} % of {out['n']} closed-loop runs >= "
               f"{100 * RATE:g} % (open loop: {100 * out['open_rate']:.1f} %)",
               out["closed_rate"] >= RATE),
    ]


def report(out: dict) -> str:
    q = out["qp"]
    lines = [
        f"land (derive/control/examples/land_push.toml): {out['intervals']} intervals over "
        f"the horizon left (the plan's {out['horizon']:.4f} s at the start), one real-time "
        f"iteration every {out['period']:g} s; {out['variables']} variables, "
        f"{out['constraints']} constraints",
        f"{'solve per sample':<44}{'median ms':>11}{'p99 ms':>10}{'samples':>9}",
        f"{'generated C controller (Gauss-Newton RTI)':<44}{out['c_median_ms']:>11.3f}"
        f"{out['c_p99_ms']:>10.3f}{out['c_samples']:>9d}",
        f"{'IPOPT in-process, converged every sample':<44}{out['ipopt_median_ms']:>11.3f}"
        f"{out['ipopt_p99_ms']:>10.3f}{out['ipopt_samples']:>9d}",
        f"  ratio IPOPT / C (median): {out['ipopt_median_ms'] / out['c_median_ms']:.0f}",
        f"the QP alone ({q['qps']} QPs of these runs, median ms): ours (C, dense dual "
        f"active set) {q['ours_ms']:.3f}; in-process: CasADi's qrqp (the QP of its "
        f"libm-only code generation) {q['qrqp_ms']:.1f} (no solution within its 1000 "
        f"iterations: {q['qrqp_failed']}), qpOASES {q['qpoases_ms']:.2f} (failed: "
        f"{q['qpoases_failed']})",
        f"landing under {out['n']} seeded disturbances (M, m, J x U[{1 - FACTOR:g}, "
        f"{1 + FACTOR:g}]; a push of up to {PUSH_MAX:g} N s; noise): upright within "
        f"{UPRIGHT_DEG:g} deg at touchdown: closed loop {100 * out['closed_rate']:.1f} % "
        f"(median error {out['closed_median_deg']:.3f} deg, worst "
        f"{out['closed_worst_deg']:.3f}), open loop {100 * out['open_rate']:.1f} % "
        f"(median {out['open_median_deg']:.2f} deg); QPs without a solution: "
        f"{out['failed_qps']} (the law goes on); {out['sweep_seconds']:.1f} s",
    ]
    lines += [str(t) for t in targets(out)]
    return "\n".join(lines)


def passed(out: dict) -> bool:
    return all(t.ok for t in targets(out))
