"""``[plan].goal = "travel"``: the periodic law of a point on a guide that makes a body
resting on its face crawl fastest, under bounds on the point's displacement (the guide,
``region``), velocity (``max_velocity``) and acceleration (``max_acceleration``).

**The class.**  The point's acceleration along the guide is periodic and piecewise linear
through the breakpoints of five phases: a hold (``x'' = 0``), a throw (``-A1``), a coast
(0), a brake (``+a2``) and a return (``+a3``), joined by linear corners of width ``e``; the
return's length makes the velocity periodic and the velocity's constant the position.
Such a law is a C^2 piecewise cubic whose knots are the breakpoints, so the runtime's
periodic cubic spline through its values at those knots (``law.csv``, ``ends =
"periodic"``) *is* the law, to round-off: the printed law runs as the scene it writes.
Its extremes are exact: ``|x''|`` at the breakpoints, ``|x'|`` at the knots (the
acceleration keeps one sign on each piece), the stroke at the roots of ``x'`` on each
piece.  Time is scaled (the accelerations kept) until the stroke or the velocity bound is
met: a crawl covers more the larger its stroke.

**The search.**  Seven unknowns (``A1/A``, ``a2/A``, ``a3/A``, the coast, hold, brake and
corner over the throw), adaptive Nelder-Mead from the law of the best of
:mod:`derive.capsule`'s classes for the same bounds; every candidate is run by the base
model's C runtime from rest for ``PERIODS`` periods and scored by C's displacement over
the last one along the guide (a run that stops early, tipping say, scores nothing; a
start that stops throws softer first).  ``max_iterations`` caps the simplex's iterations.

**The comparison.**  The best of derive/capsule.py's three derived classes with the same
``L``, ``U``, ``A``, ``mu``, ``mu_s``, each at the sticking limit (a supremum: the return
on the edge of the friction cone): :func:`~derive.capsule.optimum_bounded` (rest: the
throw, the slide, the return at rest), :func:`~derive.capsule.sawtooth_bounded` (the
return at once, overlapping the slide) and :func:`~derive.capsule.brake_bounded` (a coast
and a brake at +A ending the slide, the return at rest).  The search's class holds all
three but for its corners (at least ``MIN_CORNER`` of the period each).  The search of
Chernousko's own closed forms (J. Appl. Math. Mech. 66, 2002; Meccanica 2016) found no
text of them, so they are not quoted.
"""
from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import capsule, json_text
from .travel_scene import scene_document, scene_toml

PERIODS = 2              # periods run per candidate; the last one is measured
RUN_PERIODS = 10         # the written scene's duration, in periods (derive simulate)
MIN_CORNER = 1e-3        # the corners' width at least this share of the period
ROWS_PER_PIECE = 4       # law.csv: the breakpoints and 3 points inside each piece
GUESS_KAPPA = 0.97       # the guess's return at this share of the static limit


@dataclass(frozen=True)
class Law:
    """The law along the guide: breakpoints ``t`` (from 0 to the period), ``s``, ``v``,
    ``a`` there (the position from the guide's middle, its rate and acceleration)."""
    t: np.ndarray
    s: np.ndarray
    v: np.ndarray
    a: np.ndarray
    phases: dict                 # durations (s) and levels (m/s^2) of the five phases

    @property
    def period(self) -> float:
        return float(self.t[-1])

    def at(self, ts) -> tuple:
        """s, s', s'' at times ``ts`` (periodic): the cubic of each piece."""
        ts = np.mod(np.asarray(ts, dtype=float), self.period)
        i = np.clip(np.searchsorted(self.t, ts, side="right") - 1, 0, len(self.t) - 2)
        h = self.t[i + 1] - self.t[i]
        x = ts - self.t[i]
        j = (self.a[i + 1] - self.a[i]) / h
        a = self.a[i] + j * x
        v = self.v[i] + self.a[i] * x + j * x * x / 2
        s = self.s[i] + self.v[i] * x + self.a[i] * x * x / 2 + j * x ** 3 / 6
        return s, v, a

    def extremes(self) -> dict:
        """max |s''|, max |s'| and the range of s, exactly (see the module's text)."""
        lo, hi = float(self.s.min()), float(self.s.max())
        for i in range(len(self.t) - 1):
            h = self.t[i + 1] - self.t[i]
            j = (self.a[i + 1] - self.a[i]) / h
            roots = np.roots([j / 2, self.a[i], self.v[i]]) if j != 0 else (
                np.array([-self.v[i] / self.a[i]]) if self.a[i] != 0 else np.array([]))
            for r in roots:
                if abs(r.imag) < 1e-300 and 0 < r.real < h:
                    sv = self.at(self.t[i] + r.real)[0]
                    lo, hi = min(lo, float(sv)), max(hi, float(sv))
        return {"max_acceleration": float(np.abs(self.a).max()),
                "max_velocity": float(np.abs(self.v).max()), "range": hi - lo,
                "min": lo, "max": hi}

    def rows(self, center: np.ndarray, d: np.ndarray) -> np.ndarray:
        """law.csv: t, x, y, z, x', y', z', x'', y'', z'' at the breakpoints and
        ``ROWS_PER_PIECE - 1`` points inside each piece (all on the same C^2 cubics, so
        the runtime's periodic spline through them is the law)."""
        ts = [np.linspace(self.t[i], self.t[i + 1], ROWS_PER_PIECE + 1)[:-1]
              for i in range(len(self.t) - 1)]
        ts = np.r_[np.concatenate(ts), self.period]
        s, v, a = self.at(ts)
        s[-1], v[-1], a[-1] = s[0], v[0], a[0]           # the last row is the first
        return np.column_stack([ts, center + np.outer(s, d), np.outer(v, d),
                                np.outer(a, d)])


def law_of(theta, A: float, L: float, U: float | None) -> Law | None:
    """The law of the class for the unknowns ``theta`` (None: not a law of it)."""
    q1, q2, q3, l_coast, l_hold, l_brake, le = theta
    A1, a2, a3 = (A * min(max(q, lo), 1.0) for q, lo in ((q1, 0.01), (q2, 1e-3), (q3, 1e-3)))
    d1, d2, d4, db = 1.0, math.exp(l_coast), math.exp(l_hold), math.exp(l_brake)
    e = math.exp(le)
    e = max(e, MIN_CORNER * (d1 + d2 + d4 + db + A1 / a3 + 5 * e))
    # a hold, coast or brake shorter than half a corner is empty: the spline through its
    # knots, from positions, would amplify their round-off by 1/h^2 in the acceleration
    d2, d4, db = (d if d >= 0.5 * e else 0.0 for d in (d2, d4, db))
    d3 = (A1 * (d1 + e) - a2 * (db + e)) / a3 - e         # the velocity periodic
    if d3 < 0.5 * e or not all(math.isfinite(x) for x in (d2, d4, db, e)):
        return None
    spans = [d4, e, d1, e, d2, e, db, e, d3, e]
    levels = [0.0, 0.0, -A1, -A1, 0.0, 0.0, a2, a2, a3, a3, 0.0]
    t = np.r_[0.0, np.cumsum(spans)]
    keep = np.r_[True, np.diff(t) > 0.0]                  # an empty phase
    t, acc = t[keep], np.array(levels)[keep]
    h = np.diff(t)
    v = np.r_[0.0, np.cumsum(h * (acc[:-1] + acc[1:]) / 2)]
    v[-1] = 0.0                                           # (round-off of the balance)
    s = np.r_[0.0, np.cumsum(v[:-1] * h + h * h * (2 * acc[:-1] + acc[1:]) / 6)]
    mean = s[-1] / t[-1]                                  # the constant of x'
    v, s = v - mean, s - mean * t
    law = Law(t, s, v, acc, {})
    ext = law.extremes()
    c = math.sqrt(L / ext["range"])                       # time scaled by c: x by c^2
    if U is not None:
        c = min(c, U / ext["max_velocity"])
    mid = (ext["min"] + ext["max"]) / 2 * c * c
    phases = {"hold": d4 * c, "throw": d1 * c, "coast": d2 * c, "brake": db * c,
              "return": d3 * c, "corner": e * c, "throw_acceleration": -A1,
              "brake_acceleration": a2, "return_acceleration": a3}
    return Law(t * c, s * c * c - mid, v * c, acc, phases)


def guess(task, cf: dict) -> list:
    """The law of the best of derive/capsule.py's classes for the task's bounds (``cf``:
    :func:`closed_form`), in the unknowns of :func:`law_of`, with corners of 2 % of the
    throw and the return at GUESS_KAPPA of the static limit."""
    sc, A = task.scene, task.max_acceleration
    nu = sc.m / (sc.M + sc.m)
    a_k, a_st = sc.friction * sc.g / nu, sc.mu_static * sc.g / nu
    q3 = min(GUESS_KAPPA * a_st / A, 1.0)
    t1 = 1.0                                  # the throw; the body slides nu (A - a_k) t1
    V1 = nu * (A - a_k) * t1
    if cf["class"] == "brake":                # a coast, then a brake at +A to the stop
        t2 = cf["brake"]["coast_share"] * V1 / (nu * a_k)
        tb, q2 = (V1 - nu * a_k * t2) / (nu * (A + a_k)), 1.0
    elif cf["class"] == "sawtooth":           # the return at once
        t2, tb, q2 = 0.0, 0.0, q3
    else:                                     # the slide to rest, then the return
        t2, tb, q2 = V1 / (nu * a_k), 0.0, q3
    e = 0.02 * t1
    d1 = t1 - e
    return [1.0, q2, q3, math.log(max(t2 - e, 1e-3 * d1) / d1), math.log(1e-3),
            math.log(max(tb - e, 1e-3 * d1) / d1), math.log(e / d1)]


@dataclass
class Evaluator:
    """Runs a law as the task's scene in the base model's C runtime and measures C's
    mean velocity over the last of ``periods`` periods from rest."""
    task: object
    periods: int = PERIODS
    evaluations: int = 0
    seconds: float = 0.0

    def scene(self, law: Law, periods: int) -> dict:
        t = self.task
        rows = law.rows(t.region_center, t.direction)
        return scene_document(t.scene, {"samples": [[float(x) for x in r[:4]] for r in rows],
                                        "ends": "periodic"}, periods * law.period)

    def run(self, law: Law) -> dict:
        from ..runtime.choice import base_c_at
        from ..runtime.driver import simulate
        start = time.perf_counter()
        ends = {}
        for k in (self.periods - 1, self.periods):
            res = simulate(self.scene(law, k))
            if res.status != "done":
                self.evaluations += 1
                self.seconds += time.perf_counter() - start
                return {"status": res.status, "t": float(res.t[-1]), "model": res.model}
            ends[k] = base_c_at(res.scene, float(res.t[-1]), res.model_q[-1])
        self.evaluations += 1
        self.seconds += time.perf_counter() - start
        dC = (ends[self.periods] - ends[self.periods - 1])[:2]
        fixed = (self.task.scene.A0 @ self.task.direction)[:2]
        vel = dC / law.period
        return {"status": "done", "model": res.model, "mean_velocity": [float(x) for x in vel],
                "mean_speed": float(np.hypot(*vel)),
                "forward_speed": float(vel @ fixed / np.linalg.norm(fixed))}


@dataclass(repr=False)
class TravelPlan:
    """A travel plan: ``summary`` is plan.json; ``write(dir)`` writes law.csv,
    scene.toml, plan.json, law.png and motion.png."""
    task: object
    status: str
    message: str
    summary: dict
    law: Law | None = None
    table: np.ndarray | None = None
    scene_toml: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "solved"

    def __repr__(self) -> str:
        what = (f"{self.summary['mean_speed']:.6g} m/s, {self.summary['ratio']:.4f} of the "
                "closed form" if self.ok else self.message[:120])
        return f"<Plan travel: {self.status}; {what}>"

    def write(self, out) -> list[Path]:
        from .outputs import write_table
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = []
        if self.ok:
            write_table(out / "law.csv", self.table)
            (out / "scene.toml").write_text(self.scene_toml, encoding="utf-8")
            written += [out / "law.csv", out / "scene.toml"]
        (out / "plan.json").write_text(json_text.dumps(self.summary), encoding="utf-8")
        written.append(out / "plan.json")
        if self.ok:
            written += plot(self, out)
        return written


def closed_form(task) -> dict:
    """derive/capsule.py's three classes for the task's bounds: the best one is the
    comparison."""
    sc = task.scene
    L, U, A = 2 * task.region_radius, task.max_velocity, task.max_acceleration
    kw = dict(M=sc.M, m=sc.m, mu=sc.friction, L=L, U=U, mu_s=sc.mu_static, g=sc.g)
    nu = sc.m / (sc.M + sc.m)
    brake, rho = capsule.brake_bounded(A=A, **kw)
    classes = {"brake": brake, "sawtooth": capsule.sawtooth_bounded(A=A, **kw),
               "rest": capsule.optimum_bounded(A=A, **kw)}
    best = max(classes, key=lambda k: classes[k])
    return {"source": "derive/capsule.py (derived there; Chernousko's closed forms were "
                      "not found, so not quoted)",
            "class": best, "speed": classes[best],
            "brake": {"speed": brake, "coast_share": rho,
                      "what": "the throw at -A, a coast, a brake at +A ending as the body "
                              "stops, the return at the static limit at rest (the best "
                              "coast share on a grid of 2001)"},
            "sawtooth": {"speed": classes["sawtooth"],
                         "what": "the throw at -A, at once the return at the static limit "
                                 "mu_s g/nu overlapping the slide, no rests"},
            "rest": {"speed": classes["rest"],
                     "what": "the throw at -A, the slide, the return at the static limit "
                             "with the body at rest (V* = min(sqrt(2 nu mu g L)/3, nu U/3) "
                             "for the jump)"},
            "static_limit_acceleration": sc.mu_static * sc.g / nu}


def plan(task, progress: bool = False) -> TravelPlan:
    """The fastest crawl of the class for a travel task (see the module's text)."""
    from scipy.optimize import minimize
    t_start = time.perf_counter()
    sc, A = task.scene, task.max_acceleration
    L, U = 2 * task.region_radius, task.max_velocity
    cf = closed_form(task)
    summary = {"goal": "travel", "closed_form": cf,
               "bounds": {"range": L, "max_velocity": U, "max_acceleration": A}}
    if cf["speed"] == 0.0:
        msg = (f"infeasible: max_acceleration {A:g} m/s^2 is at most the static limit "
               f"mu_s g/nu = {cf['static_limit_acceleration']:.6g} m/s^2: the point cannot "
               "push the body off its rest, no law moves it")
        summary.update(status="infeasible", message=msg,
                       total_seconds=time.perf_counter() - t_start)
        return TravelPlan(task, "infeasible", msg, summary)
    ev = Evaluator(task)
    stops = []
    scale = cf["speed"]
    best = {"f": math.inf}

    def f(theta):
        law = law_of(theta, A, L, U)
        if law is None:
            return 1.0
        got = ev.run(law)
        if got["status"] != "done":
            stops.append(got)
        val = -got["forward_speed"] / scale if got["status"] == "done" else 1.0
        if val < best["f"]:
            best.update(f=val, theta=np.array(theta), law=law, got=got)
            if progress:
                import sys
                print(f"  travel: evaluation {ev.evaluations}: {-val * scale:.6g} m/s",
                      file=sys.stderr)
        return val

    x0 = np.array(guess(task, cf))
    # a guess whose run stops (a throw or a brake that tips the body, say) throws and
    # brakes softer, down to the static limit, before the search starts
    lowest = cf["static_limit_acceleration"] / A
    while True:
        law = law_of(x0, A, L, U)
        got = ev.run(law) if law is not None else {"status": "no law"}
        stops.append(got)
        if got["status"] == "done" or x0[0] * 0.8 <= lowest:
            break
        x0[0] *= 0.8                          # the throw, and a brake above the return
        x0[1] = max(x0[1] * 0.8, x0[2])
    steps = np.array([-0.05, -0.05 if x0[1] == 1.0 else 0.3, -0.03 * x0[2], 0.3, 0.5,
                      0.3 if x0[1] == 1.0 else 3.0, 0.3])
    n = len(steps)
    simplex = np.vstack([x0] + [x0 + np.eye(n)[k] * steps[k] for k in range(n)])
    res = minimize(f, x0, method="Nelder-Mead",
                   options={"maxiter": task.max_iterations, "initial_simplex": simplex,
                            "xatol": 1e-3, "fatol": 1e-5, "adaptive": True})
    search = {"method": "Nelder-Mead (scipy) over 7 unknowns, each candidate run by the "
                        f"base model's C runtime for {PERIODS} periods from rest",
              "iterations": int(res.nit), "evaluations": ev.evaluations,
              "seconds": ev.seconds, "stopped": str(res.message)}
    summary["search"] = search
    if "law" not in best or best["f"] >= 0:
        why = next((f"{g['status']} at t = {g['t']:.6g} s" for g in stops
                    if g["status"] not in ("done", "no law")), "or went back")
        msg = ("failed: no law of the class moved the body forward (the guess's runs, their "
               f"throw softened down to the static limit, stopped: {why})")
        summary.update(status="failed", message=msg, total_seconds=time.perf_counter() - t_start)
        return TravelPlan(task, "failed", msg, summary)
    law, got = best["law"], best["got"]
    ext = law.extremes()
    table = law.rows(task.region_center, task.direction)
    doc = scene_document(sc, {"table": "law.csv", "ends": "periodic"},
                         RUN_PERIODS * law.period)
    text = scene_toml(doc)
    achieved, run = _achieved(table, text)
    summary.update({
        "status": "solved", "message": "the fastest law of the class found",
        "law": {"kind": "five phases of constant acceleration along the guide, linear "
                        "corners", "period": law.period, "phases": law.phases,
                "direction": [float(x) for x in task.direction],
                "guide_center": [float(x) for x in task.region_center],
                "breakpoints": [[float(t), float(a)] for t, a in zip(law.t, law.a)],
                "max_acceleration": ext["max_acceleration"],
                "max_velocity": ext["max_velocity"], "range": ext["range"],
                "table_rows": int(table.shape[0])},
        "mean_velocity": got["mean_velocity"], "mean_speed": got["mean_speed"],
        "forward_speed": got["forward_speed"],
        "ratio": got["forward_speed"] / cf["speed"],
        "achieved": achieved, "total_seconds": time.perf_counter() - t_start})
    return TravelPlan(task, "solved", summary["message"], summary, law=law, table=table,
                      scene_toml=text, extra={"run": run})


def plot(plan: "TravelPlan", out: Path) -> list[Path]:
    """law.png (s, s', s'' over a period with their bounds) and motion.png (O along the
    fixed axes and its velocity over the written scene's run, stick and slip as the
    runtime found them)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    law, task, cf = plan.law, plan.task, plan.summary["closed_form"]
    ts = np.linspace(0.0, law.period, 2001)
    s, v, a = law.at(ts)
    fig, ax = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
    r, U, A = task.region_radius, task.max_velocity, task.max_acceleration
    for k, (y, name, lim) in enumerate(((s, "s (m) along the guide", r), (v, "s' (m/s)", U),
                                        (a, "s'' (m/s^2)", A))):
        ax[k].plot(ts, y)
        if lim is not None:
            for sign in (1, -1):
                ax[k].axhline(sign * lim, color="k", ls="--", lw=0.8)
        ax[k].set_ylabel(name)
    ax[2].axhline(cf["static_limit_acceleration"], color="C3", ls=":", lw=0.8,
                  label="static limit mu_s g/nu")
    ax[2].legend(loc="best")
    ax[2].set_xlabel("t (s)")
    fig.suptitle(f"planned law (travel): {plan.summary['forward_speed']:.4g} m/s, "
                 f"{plan.summary['ratio']:.4f} of the {cf['class']} class")
    fig.subplots_adjust(left=0.13, right=0.97, top=0.93, bottom=0.08, hspace=0.12)
    fig.savefig(out / "law.png", dpi=110)
    plt.close(fig)
    paths = [out / "law.png"]
    run = plan.extra.get("run")
    if run is not None:
        fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        ax[0].plot(run["t"], run["x"], label="X_O")
        ax[0].plot(run["t"], run["y"], label="Y_O")
        ax[0].set_ylabel("O (m), fixed axes")
        ax[0].legend(loc="best")
        ax[1].plot(run["t"], run["vx"], label="X_O'")
        ax[1].set_ylabel("m/s")
        ax[1].set_xlabel("t (s)")
        fig.suptitle("scene.toml run by the base model (derive simulate's runtime)")
        fig.subplots_adjust(left=0.13, right=0.97, top=0.92, bottom=0.09, hspace=0.12)
        fig.savefig(out / "motion.png", dpi=110)
        plt.close(fig)
        paths.append(out / "motion.png")
    return paths


def _achieved(table: np.ndarray, text: str) -> tuple[dict, dict | None]:
    """The written scene.toml and law.csv run by derive.simulate's path (the runtime, the
    table read back): its summary's travel, per period over RUN_PERIODS periods."""
    from ..runtime import base_report
    from ..runtime.driver import simulate
    from .outputs import write_table
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.toml"
        write_table(Path(tmp) / "law.csv", table)
        path.write_text(text, encoding="utf-8")
        res = simulate(str(path))
        tr = base_report.travel(res) if res.status == "done" else {}
    q = np.asarray(res.model_q)          # X_O, Y_O, psi and their rates
    run = {"t": np.asarray(res.t), "x": q[:, 0], "y": q[:, 1], "vx": q[:, 3]}
    return {"runtime": {"status": res.status, "model": res.model,
                        "whole_periods": tr.get("whole_periods"),
                        "mean_velocity": tr.get("mean_velocity"),
                        "last_period_displacement": tr.get("last_period_displacement")}}, run
