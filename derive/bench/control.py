"""``derive bench control``: the re-planning controller (mode = "replan") against what
is reachable, on landings users meet (:mod:`derive.bench.control_draws`: spheres and
ellipsoids, M 0.5-2 kg, drops 0.8-4 m, spins up to 1.5 rad/s, tilts up to 25 deg; a
model error and one push of four sizes, up to 0.25 N s).

Each drawn task is planned, its controller generated and compiled, and each of its
disturbances landed three ways on the same plant:

* **C**: the generated C controller (Gauss-Newton real-time iterations, the dense QP
  with its end conditions soft), timed inside the C at every sample;
* **open**: the offline plan played, nothing read;
* **oracle**: IPOPT at every sample (the same problem, converged from the shifted last
  solution, :class:`~derive.control.solvers.IpoptReplan`): what a re-planner that
  solves every sample reaches, the reference for reachability.

A landing succeeds when the first touchdown is within 2 deg of the target attitude.
Targets (PASS or FAIL; exit 1 on a FAIL):

* of the landings the oracle lands, the share the C controller lands too: >= 95 %;
* the landings where the closed loop ends worse than the open loop beyond the noise's
  effect (closed error > open error + the closed loop's error on the undisturbed model
  with the same noise): none;
* the C controller's solve per sample: median <= 5 ms, p99 <= 10 ms.

Beside them: the table by disturbance size and the push's time (early: before half the
fall), the chart ``control-robustness.png``, where the QPs without a solution fall
(seconds before touchdown) and how many runs stalled (three in a row before the last
0.1 s), IPOPT's time per sample, and the QP alone against qpOASES on QPs of the first
task (the soft rows as explicit slacks).  ``--seed`` draws other tasks: the targets
must hold on draws the bench was not tuned on.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import abi
from ..commands import Target, all_pass
from ..control.core import GOAL_TOLERANCE_DEG
from ..control.replan import MEDIAN_TARGET_MS as MEDIAN_MS
from ..control.replan import P99_TARGET_MS as P99_MS
from . import control_draws as D

UPRIGHT_DEG = GOAL_TOLERANCE_DEG
SHARE = 0.95
LAST_S = 0.1                  # failures this close to touchdown are the end's
STALL = 3                     # failed samples in a row before the last 0.1 s: a stall
QP_SAMPLE = 20                # QPs of the first task solved by ours and by qpOASES


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


def touchdown_time(result) -> float:
    imp = [e["t"] for e in result.events if e["kind"] == "impact"]
    return imp[0] if imp else math.inf


def _stalled(t, failed, t_down) -> bool:
    """STALL failed samples in a row before the last LAST_S s."""
    run = 0
    for tt, f in zip(t, failed):
        if tt >= t_down - LAST_S:
            break
        run = run + 1 if f else 0
        if run >= STALL:
            return True
    return False


def _one_task(args) -> dict:
    """Plan task k, compile its controller, land its disturbances three ways."""
    from ..control.core import load_control_task
    from ..control.replan import ControlError, setup
    seed, k, per_task, oracle, keep_qps = args
    rng = np.random.default_rng([seed, k])
    doc = D.task_doc(rng, k)
    out = {"k": k, "task": D.describe(doc), "rows": []}
    tick = time.perf_counter()
    try:
        su = setup(load_control_task(doc))
        compiled = su.compiled
    except ControlError as exc:
        out["error"] = str(exc)
        return out
    out["setup_s"] = time.perf_counter() - tick
    out["start"] = su.start["from"]
    target, fall = su.task.target, su.T_plan
    for j in range(per_task):
        draw = D.disturbance(rng, doc, j % len(D.SIZES), fall, seed=1000 * k + j)
        dist = draw.disturbance
        prep = su.plant(dist)
        closed, _ = su.closed(prep, dist, compiled.controller())
        solves = compiled.solves()
        row = {"size": draw.size, "late": draw.late, "fraction": draw.fraction,
               "impulse": draw.impulse, "closed": upright_error_deg(closed, target),
               "open": upright_error_deg(su.open(prep, dist), target),
               "ms": (solves["seconds"] * 1e3).tolist(),
               "qp_iterations": solves["qp_iterations"].tolist(),
               "softened": int(np.sum(solves["softened"]))}
        t_down = touchdown_time(closed)
        row["failures_before_touchdown"] = (t_down - solves["t"][solves["failed"]]).tolist()
        row["stalled"] = _stalled(solves["t"], solves["failed"], t_down)
        quiet = D.noise_only(dist.seed)
        noisy, _ = su.closed(su.plant(quiet), quiet, compiled.controller())
        row["noise"] = upright_error_deg(noisy, target)
        if oracle:
            ctl = su.ipopt()
            landed, _ = su.closed(prep, dist, ctl)
            row["oracle"] = upright_error_deg(landed, target)
            row["oracle_ms"] = (np.array(ctl.stats.solve_s) * 1e3).tolist()
            row["oracle_failures"] = ctl.stats.failures
        out["rows"].append(row)
    if keep_qps:
        out["qps"] = _some_qps(su, prep, dist)
    out["seconds"] = time.perf_counter() - tick
    return out


def _some_qps(su, prep, dist) -> list:
    """QPs of the Python route on one disturbed landing (for the QP alone)."""
    py = su.python()
    solve, qps = py.qp.solve, []

    def keep(*args):
        qps.append(tuple(np.array(a, dtype=float) for a in args))
        return solve(*args)
    py.qp.solve = keep
    su.closed(prep, dist, py)
    return qps[::max(1, len(qps) // QP_SAMPLE)][:QP_SAMPLE]


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


def qp_against_qpoases(qps: list) -> dict:
    """Ours in C (ctl_qp.h through its shim) against qpOASES on the same QPs, the soft
    rows written out as explicit slacks for qpOASES: the time (median ms) and the
    largest difference of the steps."""
    import casadi as ca
    from ..control.qp import CDenseQP
    from ..control.problem import MAX_QP_ITER
    H, g, A, lba, uba, lbx, ubx, z1, z2 = qps[0]
    n, m = len(g), len(lba)
    soft = [i for i in range(m) if z1[i] > 0]
    ns = 2 * len(soft)
    c_qp = CDenseQP(n, m, MAX_QP_ITER, ns)
    sp = {"h": ca.Sparsity.dense(n + ns, n + ns), "a": ca.Sparsity.dense(m, n + ns)}
    with _Quiet():
        peer = ca.conic("qp", "qpoases", sp, {"printLevel": "none", "error_on_fail": False})
    ours, theirs, worst, failed = [], [], 0.0, 0
    for H, g, A, lba, uba, lbx, ubx, z1, z2 in qps:
        tick = time.perf_counter()
        x, status, _ = c_qp.solve(H, g, A, lba, uba, lbx, ubx, z1, z2)
        ours.append(time.perf_counter() - tick)
        Ha = np.zeros((n + ns, n + ns))
        Ha[:n, :n] = H
        ga, Aa = np.r_[g, np.zeros(ns)], np.c_[A, np.zeros((m, ns))]
        for j, i in enumerate(soft):
            for c, sign in ((n + 2 * j, 1.0), (n + 2 * j + 1, -1.0)):
                Aa[i, c], Ha[c, c], ga[c] = sign, z2[i], z1[i]
        with _Quiet():
            tick = time.perf_counter()
            sol = peer(h=Ha, g=ga, a=Aa, lba=lba, uba=uba, lbx=np.r_[lbx, np.zeros(ns)],
                       ubx=np.r_[ubx, np.full(ns, np.inf)])
            theirs.append(time.perf_counter() - tick)
        ok = peer.stats()["success"]
        failed += not ok
        if ok and status == 0:
            ref = np.array(sol["x"]).ravel()[:n]
            worst = max(worst, float(np.max(np.abs(x - ref)) / (1 + np.max(np.abs(ref)))))
    return {"qps": len(qps), "ours_ms": float(np.median(ours) * 1e3),
            "qpoases_ms": float(np.median(theirs) * 1e3), "qpoases_failed": failed,
            "worst_difference": worst}


def run(tasks: int = 12, per_task: int = 4, seed: int = 1, workers: int | None = None,
        out_dir: str = "bench-out", progress=lambda m: None) -> dict:
    import resource
    from ..parallel import run as run_all
    start = time.perf_counter()
    cpu0 = [resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                resource.RUSAGE_CHILDREN)]
    jobs = [(seed, k, per_task, True, k == 0) for k in range(tasks)]
    done = []

    def collect(index, result):
        done.append(index)
        progress(f"task {len(done)} of {tasks}: {result['task']} "
                 f"({result.get('seconds', 0.0):.0f} s)")
    results, executor, n = run_all(_one_task, jobs, workers=workers, collect=collect)
    out = {"seed": seed, "tasks": tasks, "per_task": per_task, "executor": executor,
           "workers": n, "results": results}
    qps = next((r["qps"] for r in results if r.get("qps")), None)
    out["qp"] = qp_against_qpoases(qps) if qps else None
    out["seconds"] = time.perf_counter() - start
    out["cpu_seconds"] = sum(
        (u.ru_utime + u.ru_stime) - (u0.ru_utime + u0.ru_stime)
        for u, u0 in zip([resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                              resource.RUSAGE_CHILDREN)],
                         cpu0))
    out.update(summarise(results))
    out["chart"] = str(chart(out, Path(out_dir)))
    return out


def summarise(results: list) -> dict:
    rows = [r for res in results for r in res["rows"]]
    ok = UPRIGHT_DEG
    table = []
    for size in range(len(D.SIZES)):
        for late in (False, True):
            sel = [r for r in rows if r["size"] == size and r["late"] == late]
            table.append({"size": size, "late": late, "n": len(sel),
                          "closed": sum(r["closed"] < ok for r in sel),
                          "open": sum(r["open"] < ok for r in sel),
                          "oracle": sum(r["oracle"] < ok for r in sel),
                          "worse": sum(_worse(r) for r in sel)})
    reach = [r for r in rows if r["oracle"] < ok]
    ms = np.concatenate([r["ms"] for r in rows]) if rows else np.zeros(0)
    oracle_ms = np.concatenate([r["oracle_ms"] for r in rows]) if rows else np.zeros(0)
    before = np.concatenate([r["failures_before_touchdown"] for r in rows]) \
        if rows else np.zeros(0)
    return {
        "table": table, "landings": len(rows),
        "errors": [res for res in results if "error" in res],
        "reachable": len(reach), "both": sum(r["closed"] < ok for r in reach),
        "share": sum(r["closed"] < ok for r in reach) / len(reach) if reach else math.nan,
        "missed": [(res["k"], res["task"], r["size"], round(r["fraction"], 2),
                    round(r["impulse"], 3), round(r["closed"], 2), round(r["oracle"], 2))
                   for res in results for r in res["rows"]
                   if r["oracle"] < ok <= r["closed"]],
        "worse": sum(_worse(r) for r in rows),
        "closed_rate": np.mean([r["closed"] < ok for r in rows]) if rows else math.nan,
        "open_rate": np.mean([r["open"] < ok for r in rows]) if rows else math.nan,
        "oracle_rate": np.mean([r["oracle"] < ok for r in rows]) if rows else math.nan,
        "c_median_ms": float(np.median(ms)) if len(ms) else math.nan,
        "c_p99_ms": float(np.percentile(ms, 99)) if len(ms) else math.nan,
        "c_max_ms": float(np.max(ms)) if len(ms) else math.nan, "c_samples": int(len(ms)),
        "qp_iterations_p99": float(np.percentile(np.concatenate(
            [r["qp_iterations"] for r in rows]), 99)) if rows else math.nan,
        "oracle_median_ms": float(np.median(oracle_ms)) if len(oracle_ms) else math.nan,
        "oracle_p99_ms": float(np.percentile(oracle_ms, 99)) if len(oracle_ms) else math.nan,
        "failures": int(len(before)),
        "failures_last": int(np.sum(before <= LAST_S)),
        "stalls": sum(r["stalled"] for r in rows),
        "softened": sum(r["softened"] for r in rows),
        "oracle_failures": sum(r["oracle_failures"] for r in rows),
        "setup_s": float(np.median([res["setup_s"] for res in results if "setup_s" in res]))
        if any("setup_s" in res for res in results) else math.nan,
    }


def _worse(r: dict) -> bool:
    """Closed ends worse than open beyond the noise's own effect."""
    return r["closed"] > r["open"] + r["noise"]


def chart(out: dict, folder: Path) -> Path:
    """control-robustness.png: the share landed within 2 deg by disturbance size, early
    and late pushes apart, for the oracle, the C controller and the open loop."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    folder.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(9.0, 4.2), dpi=90)
    FigureCanvasAgg(fig)
    names = (("oracle", "IPOPT at every sample (the oracle)", "0.3"),
             ("closed", "generated C controller", "tab:blue"),
             ("open", "open loop (the plan played)", "tab:orange"))
    for panel, late in enumerate((False, True)):
        ax = fig.add_subplot(1, 2, panel + 1)
        rows = [r for r in out["table"] if r["late"] == late]
        x = np.arange(len(rows))
        for j, (key, label, colour) in enumerate(names):
            share = [100 * r[key] / r["n"] if r["n"] else 0.0 for r in rows]
            ax.bar(x + (j - 1) * 0.27, share, 0.27, color=colour,
                   label=label if panel == 0 else None)
        ax.set_xticks(x, [f"{D.SIZES[r['size']][1]:g}-{D.SIZES[r['size']][2]:g} N s\n"
                          f"\u00b1{100 * D.SIZES[r['size']][0]:g} %\n(n = {r['n']})"
                          for r in rows], fontsize=8)
        ax.set_ylim(0, 105)
        ax.set_ylabel(f"landed within {UPRIGHT_DEG:g} deg (%)")
        ax.set_title(("late" if late else "early") + " push (" + ("after" if late else
                     "before") + " half the fall)", fontsize=10)
    fig.legend(loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle(f"derive bench control: {out['landings']} landings of {out['tasks']} "
                 f"drawn tasks (seed {out['seed']}); push size and model error",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    path = folder / "control-robustness.png"
    fig.savefig(path)
    return path


def targets(out: dict) -> list:
    return [
        Target(f"of the {out['reachable']} landings the oracle lands within "
               f"{UPRIGHT_DEG:g} deg, the C controller lands {out['both']} "
               f"({100 * out['share']:.1f} %) >= {100 * SHARE:g} %", out["share"] >= SHARE),
        Target(f"closed loop worse than open beyond the noise's effect: {out['worse']} of "
               f"{out['landings']} == 0", out["worse"] == 0),
        Target(f"re-plan latency of the C controller: median {out['c_median_ms']:.3f} ms "
               f"<= {MEDIAN_MS:g} ms", out["c_median_ms"] <= MEDIAN_MS),
        Target(f"re-plan latency of the C controller: p99 {out['c_p99_ms']:.3f} ms "
               f"<= {P99_MS:g} ms", out["c_p99_ms"] <= P99_MS),
    ]


def report(out: dict) -> str:
    lines = [f"{out['tasks']} landing tasks drawn (seed {out['seed']}), {out['per_task']} "
             f"disturbances each: {out['landings']} landings ({out['executor']}, "
             f"{out['workers']} workers, {out['seconds']:.0f} s, {out['cpu_seconds']:.0f} s "
             f"of CPU; a task's plan, problem, start and C build: median "
             f"{out['setup_s']:.1f} s)"]
    for e in out["errors"]:
        lines.append(f"  task {e['k']} ({e['task']}): {e['error']}")
    lines.append(f"{'size':<22}{'push':<7}{'n':>4}{'oracle':>8}{'C':>6}{'open':>6}"
                 f"{'C worse':>9}   landed within {UPRIGHT_DEG:g} deg")
    for r in out["table"]:
        err, lo, hi = D.SIZES[r["size"]]
        lines.append(f"{f'{lo:g}-{hi:g} N s, +-{100 * err:g} %':<22}"
                     f"{'late' if r['late'] else 'early':<7}{r['n']:>4}{r['oracle']:>8}"
                     f"{r['closed']:>6}{r['open']:>6}{r['worse']:>9}")
    lines.append(f"{'all':<29}{out['landings']:>4}{100 * out['oracle_rate']:>7.0f}%"
                 f"{100 * out['closed_rate']:>5.0f}%{100 * out['open_rate']:>5.0f}%"
                 f"{out['worse']:>9}")
    for k, task, size, frac, imp, c, o in out["missed"]:
        lines.append(f"  missed where the oracle lands: task {k} ({task}), size {size}, "
                     f"{imp:g} N s at {frac:g} of the fall: C {c:g} deg, oracle {o:g} deg")
    lines.append(
        f"solve per sample: C median {out['c_median_ms']:.3f} ms, p99 "
        f"{out['c_p99_ms']:.3f} ms, max {out['c_max_ms']:.2f} ms ({out['c_samples']} "
        f"samples; QP iterations p99 {out['qp_iterations_p99']:.0f}); IPOPT every "
        f"sample median {out['oracle_median_ms']:.1f} ms, p99 {out['oracle_p99_ms']:.0f} "
        f"ms (ratio of the medians {out['oracle_median_ms'] / out['c_median_ms']:.0f})")
    lines.append(
        f"QPs without a solution (the law in use went on): {out['failures']}, "
        f"{out['failures_last']} of them in the last {LAST_S:g} s before touchdown; runs "
        f"stalled ({STALL} in a row earlier): {out['stalls']}; laws meeting the end "
        f"conditions in part (soft rows active): {out['softened']}; IPOPT samples not "
        f"converged: {out['oracle_failures']}")
    q = out.get("qp")
    if q:
        lines.append(f"the QP alone ({q['qps']} QPs of task 0, median ms): ours (C, dense "
                     f"dual active set) {q['ours_ms']:.3f}, qpOASES {q['qpoases_ms']:.2f} "
                     f"(slacks explicit; failed {q['qpoases_failed']}); steps differ by "
                     f"{q['worst_difference']:.1e} at most")
    lines.append(f"chart: {out['chart']}")
    lines += [str(t) for t in targets(out)]
    return "\n".join(lines)


def passed(out: dict) -> bool:
    return all_pass(targets(out))
