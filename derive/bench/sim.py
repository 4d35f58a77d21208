"""``derive bench sim``: what a user pays to simulate a scene, against peer routes, all
measured in one run, with the targets of issue 10 marked PASS or FAIL.

For each scene (the built-in one and an offset ellipsoid with a two-harmonic law), every
route is run at the loosest setting (tolerances on a 1-2-5 grid) that reaches a max state
error of 1e-9 on a common output grid (and 1e-9 in the impact times) against a reference
at 1e-14 (itself checked against SciPy at 1e-13); then timed (after a warm-up, the
median and interquartile range of repeated samples, each the least of a block of calls:
:mod:`derive.bench.timing`, which also judges the targets, a miss within the spread a
tie):

* ``runtime C``: the C run alone (crt_init + crt_advance through a Session);
* ``derive.simulate`` end to end, the law seen before (other initial numbers on every
  call): validation, model choice and the run — what a parameter study pays per call;
* ``derive.simulate`` end to end, a law never seen before (its numbers changed on every
  repetition): parsing and proving the law over the run come on top;
* ``scipy DOP853``: ``solve_ivp`` with the NumPy evaluation of the derived right-hand
  side, a terminal event on the gap and the derived impact map with a restart at each
  impact; ``casadi cvodes``: CasADi's integrator segment by segment.

Then, once: the CLI on the built-in scene (static plots included, and without them),
``simulate_many`` of 1008 variants of each scene against the C run of the same variants,
SciPy at equal error and one worker (:mod:`derive.bench.batch`), and the first build of
a model on a machine with an empty cache.
"""
from __future__ import annotations

import copy
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

from ..scene import builtin_doc, overrides
from . import batch
from .routes import Casadi, Runtime, Scipy, errors
from .timing import AT_LEAST, AT_MOST, SPREAD_NOTE, Spread, children_cpu, judge, sampled

TARGET = 1e-9
GOALS = {"seen": 1000.0, "unseen": 10.0, "cli_s": 2.0}
FAST = 20          # the sub-millisecond routes: each sample the least of this many calls


def ellipsoid_doc() -> dict:
    """An offset ellipsoid, a turning asymmetric carrier, a two-harmonic 3-D law, five
    impacts in 2 s (a scene whose state is not chaotic over its duration, so that every
    route can reach the error target)."""
    return {"name": "offset-ellipsoid",
            "body": {"mass": 1.2, "inertia": [0.08, 0.11, 0.13], "shape": "ellipsoid",
                     "semi_axes": [0.5, 0.4, 0.3], "center": [0.05, -0.03, 0.02]},
            "point": {"mass": 0.3, "law": ["0.15*sin(2*t) + 0.05*cos(5*t)", "0.08*cos(3*t)",
                                           "0.1*sin(4*t + 0.3)"]},
            "plane": {"restitution": 0.8},
            "initial": {"com": [0.0, 0.0, 1.2], "com_velocity": [0.2, -0.1, 0.0],
                        "omega": [0.3, -0.2, 0.5], "quaternion": [0.9, 0.1, -0.2, 0.3]},
            "run": {"duration": 2.0, "outputs": ["pose", "impacts"]}}


def settings(loosest: float, tightest: float) -> list:
    """Tolerances from ``loosest`` down to ``tightest`` on a 1-2-5 grid (1e-9, 5e-10,
    2e-10, 1e-10, ...): every route is measured within a factor 2.5 of the loosest
    tolerance that meets the target, not within a factor 10 (a decade grid had left the
    runtime at 7x below the target error while SciPy sat at 2x)."""
    top, bottom = round(math.log10(loosest)), round(math.log10(tightest))
    grid = [float(f"{m}e{e}") for e in range(top, bottom - 1, -1) for m in (1, 5, 2)]
    return [x for x in sorted(grid, reverse=True) if tightest <= x <= loosest]


def _loosest(make, settings, ref, progress):
    """The first setting (loosest first) whose run meets the target, and that run."""
    last = None
    for setting in settings:
        route = make(setting)
        progress(f"{route.label} at {setting:g}")
        result = route.result()
        err, ierr = errors(result, ref)
        last = (route, setting, result, err, ierr)
        if err <= TARGET and ierr <= TARGET:
            return last, True
    return last, False


def _perturbed(doc: dict, k: int) -> dict:
    """The same scene with every number of its law scaled by (1 + k 1e-13): a law text the
    process has never seen (nothing cached), the motion the same to the target."""
    import re
    d = copy.deepcopy(doc)

    def bump(m):
        return repr(float(m.group(0)) * (1 + k * 1e-13))
    d["point"]["law"] = [re.sub(r"\d+\.\d+|\d+", bump, text) for text in d["point"]["law"]]
    return d


def _renumbered(doc: dict, k: int) -> dict:
    """The same scene with its initial numbers scaled by (1 + k 1e-13): other numbers (no
    cache keyed by them applies), the motion the same to the target."""
    d = copy.deepcopy(doc)
    init = d.setdefault("initial", {})
    for key, default in (("com", [0.0, 0.0, 0.0]), ("omega", [0.0, 0.0, 0.0]),
                         ("quaternion", [1.0, 0.0, 0.0, 0.0])):
        init[key] = [float(c) * (1 + k * 1e-13) for c in init.get(key, default)]
    return d


def scene_rows(doc: dict, progress, repeats: int) -> dict:
    import derive
    progress(f"{doc['name']}: reference at 1e-14, checked against SciPy at 1e-13")
    ref = Runtime(doc, "dop853", 1e-14).result()
    agreement = errors(Scipy(doc, "DOP853", 1e-13).result(), ref)
    rows = []
    # the runtime: the best of its methods at the loosest setting that meets the target
    best = None
    for method, grid in (("lie", settings(1e-8, 1e-13)), ("dop853", settings(1e-8, 1e-12)),
                         ("dopri5", settings(1e-9, 1e-12))):
        (route, setting, result, err, ierr), ok = _loosest(
            lambda s, m=method: Runtime(doc, m, s), grid, ref, progress)
        if ok:
            sec = sampled(route.run_raw, repeats, FAST)
            if best is None or sec.median < best[0].median:
                best = (sec, route, setting, err, ierr, result)
    rows.append(_row(f"runtime C ({best[1].label.split()[-1]})", best[2], best[0], best[3],
                     best[4], best[5].evaluations))
    # what the user pays: derive.simulate end to end at the same setting
    user_doc = copy.deepcopy(doc)
    user_doc.setdefault("run", {}).update(best[1].prep.scene.doc["run"])
    derive.simulate(user_doc)
    # other numbers on every call (nothing keyed by a number can be reused), the same law
    docs = iter([_renumbered(user_doc, k) for k in range(1, FAST * repeats + 2)])
    seen = sampled(lambda: derive.simulate(next(docs)), repeats, FAST)
    rows.append(_row("derive.simulate (law seen)", best[2], seen, best[3], best[4]))
    counter = [0]

    def unseen():
        counter[0] += 1
        derive.simulate(_perturbed(user_doc, counter[0]))
    new = sampled(unseen, repeats)
    rows.append(_row("derive.simulate (new law)", best[2], new, best[3], best[4]))
    for make, grid in ((lambda s: Scipy(doc, "DOP853", s), settings(1e-9, 1e-13)),
                       (lambda s: Casadi(doc, s), settings(1e-11, 1e-14))):
        (route, setting, result, err, ierr), ok = _loosest(make, grid, ref, progress)
        sec = sampled(route.result, repeats) if ok else Spread.of([])
        rows.append(_row(route.label, setting if ok else None, sec, err, ierr,
                         result.evaluations))
    return {"scene": doc["name"], "duration": doc["run"]["duration"],
            "reference_agreement": agreement, "rows": rows}


def _row(route: str, setting, spread: Spread, error: float, impact_error: float,
         evaluations=np.nan) -> dict:
    return {"route": route, "setting": setting, "seconds": spread.median, "spread": spread,
            "error": error, "impact_error": impact_error, "evaluations": evaluations}


def _spread(row: dict) -> Spread:
    """A route's time with its spread (a row made without one: exact)."""
    return row.get("spread") or Spread(row["seconds"], row["seconds"], row["seconds"])


VARIANTS = 12             # variants of every number (bench sim's "any numbers" figure)


def variation(doc: dict, rng) -> dict:
    """The overrides of every number a parameter study varies: M and m by up to +-15 % and
    +-20 %, e in [0.75, 0.95] (where the plane is), the drop height by +-15 %, the spin by
    0.7 to 1.3; the law's text the same."""
    out = {"body.mass": float(doc["body"]["mass"]) * float(rng.uniform(0.85, 1.15)),
           "point.mass": float(doc["point"]["mass"]) * float(rng.uniform(0.8, 1.2))}
    if "plane" in doc:
        out["plane.restitution"] = float(rng.uniform(0.75, 0.95))
    init = doc.get("initial", {})
    com = [float(c) for c in init.get("com", [0.0, 0.0, 0.0])]
    com[2] *= float(rng.uniform(0.85, 1.15))
    out["initial.com"] = com
    out["initial.omega"] = [float(w) * float(rng.uniform(0.7, 1.3))
                            for w in init.get("omega", [0.0, 0.0, 0.0])]
    return out


def _varied(doc: dict, changes: dict) -> dict:
    d = copy.deepcopy(doc)
    for name, value in changes.items():
        overrides.apply_to_doc(d, name, value)
    return d


def _bumped(doc: dict, k: int) -> dict:
    """The scene with M scaled by (1 + k 1e-13): a number outside [initial] that no
    cache keyed by the scene's content can have seen; the motion the same to the target."""
    d = copy.deepcopy(doc)
    d["body"]["mass"] = float(d["body"]["mass"]) * (1 + k * 1e-13)
    return d


def any_numbers(doc: dict, progress, repeats: int, n: int = VARIANTS) -> dict:
    """derive.simulate end to end against SciPy at equal error on each of ``n`` variants
    of every number (masses, restitution, height, spin), each call of derive.simulate with
    a number outside [initial] never seen before: what a parameter study pays per call
    when its variants are not only of the initial state."""
    import derive
    rng = np.random.default_rng(2026)
    rows = []
    for k in range(n):
        changes = variation(doc, rng)
        v = _varied(doc, changes)
        progress(f"{doc['name']}: variant {k + 1} of {n} with every number changed")
        ref = Runtime(v, "dop853", 1e-14).result()
        (sp, s_set, _, s_err, s_ierr), s_ok = _loosest(
            lambda s: Scipy(v, "DOP853", s), settings(1e-9, 1e-13), ref, lambda m: None)
        (rt, r_set, _, r_err, r_ierr), r_ok = _loosest(
            lambda s: Runtime(v, "lie", s), settings(1e-8, 1e-13), ref, lambda m: None)
        user = copy.deepcopy(v)
        user.setdefault("run", {}).update(rt.prep.scene.doc["run"])
        docs = iter([_bumped(user, j) for j in range(1, FAST * repeats + 3)])
        derive.simulate(next(docs))
        t_sim = sampled(lambda: derive.simulate(next(docs)), repeats, FAST)
        t_sp = sampled(sp.result, max(3, repeats // 2))
        rows.append({"scipy_s": t_sp.median, "simulate_s": t_sim.median,
                     "ratio": t_sp.median / t_sim.median, "scipy": t_sp,
                     "errors": (r_err, s_err), "impact_errors": (r_ierr, s_ierr),
                     "met": bool(s_ok and r_ok), "settings": (r_set, s_set),
                     "overrides": changes, "reference": ref, "scipy_route": sp,
                     "short": [name for name, ok in (("runtime", r_ok), ("SciPy", s_ok))
                               if not ok]})
    # a ratio counts only where both routes reached the target (equal error); a variant
    # that one of them cannot reach at its tightest setting is reported, not averaged in
    ratios = np.array([r["ratio"] for r in rows if r["met"]])
    return {"variants": rows, "met": len(ratios), "target": TARGET,
            "median": float(np.median(ratios)) if len(ratios) else float("nan"),
            "min": float(ratios.min()) if len(ratios) else float("nan"),
            "max": float(ratios.max()) if len(ratios) else float("nan"),
            "short": [(k + 1, r["short"], max(r["errors"])) for k, r in enumerate(rows)
                      if not r["met"]]}


def cli_seconds(repeats: int = 3) -> dict:
    """``derive simulate`` on the built-in scene as a user runs it (a new process each
    time), with its static plots and without them: each a Spread of ``repeats + 2``
    samples after a warm-up, of the process's CPU time (user and system)."""
    helptext = subprocess.run([sys.executable, "-m", "derive", "simulate", "--help"],
                              capture_output=True, text=True).stdout
    static = ["--no-animation"] if "--no-animation" in helptext else []
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, extra in (("with static plots", static), ("no plots", ["--no-plots"])):
            cmd = [sys.executable, "-m", "derive", "simulate", "-q", "-o",
                   os.path.join(tmp, "out"), *extra]
            out[label] = sampled(lambda c=cmd: subprocess.run(c, check=True,
                                                              capture_output=True),
                                 repeats + 2, clock=children_cpu)
    return out


def first_build() -> dict:
    """Seconds to build one model's library on a machine with an empty cache."""
    with tempfile.TemporaryDirectory() as tmp:
        code = ("import time; from derive.runtime.build import library; "
                "t = time.perf_counter(); library('general'); "
                "print(time.perf_counter() - t)")
        env = {**os.environ, "DERIVE_CACHE": tmp}
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, check=True).stdout
    return {"general_s": float(out.split()[-1])}


def run(scene=None, progress=lambda m: None, repeats: int = 5, quick: bool = False) -> dict:
    """The scene (a file or a dict; default: the built-in scene and an offset
    ellipsoid) through every route; unless ``quick``, the CLI, ``simulate_many`` and a
    first build too."""
    if isinstance(scene, (str, os.PathLike)):
        from ..scene import load_scene
        scene = load_scene(scene).doc            # SceneError: bad input (exit 2)
    docs = [scene] if scene is not None else [builtin_doc(), ellipsoid_doc()]
    for d in docs:
        d.setdefault("name", "scene")
        d.setdefault("run", {}).setdefault("duration", 5.0)
    scenes = [scene_rows(d, progress, repeats) for d in docs]
    for d, sc in zip(docs, scenes):
        if "plane" in d and "body" in d:
            sc["any_numbers"] = any_numbers(d, progress, repeats,
                                            n=4 if quick else VARIANTS)
    extra = {}
    if not quick:
        progress("the CLI on the built-in scene")
        extra["cli"] = cli_seconds()
        extra["batch"] = [batch.measure(d, sc["any_numbers"], variation, progress)
                          for d, sc in zip(docs, scenes) if "any_numbers" in sc]
        progress("a first build with an empty cache")
        extra["first_build"] = first_build()
    return {"target": TARGET, "scenes": scenes, **extra}


# ---- the targets (issues 10 and 31) -----------------------------------------------------
def _scene_targets(sc: dict) -> list:
    """derive.simulate end to end against SciPy: the law seen before, a new law."""
    by = {r["route"]: _spread(r) for r in sc["rows"]}
    scipy = by.get("scipy DOP853", Spread.of([]))
    return [judge(f"derive.simulate end to end, {label}, faster than SciPy", scipy.over(by[key]),
                  AT_LEAST, GOALS[goal], ".0f")
            for label, key, goal in (("law seen before", "derive.simulate (law seen)", "seen"),
                                     ("new law", "derive.simulate (new law)", "unseen"))]


def any_numbers_line(any_: dict) -> str:
    """derive.simulate with every number changed, one call at a time, against SciPy: a
    figure, no longer a target (issue 31 retired it: the per-call validation it needs
    stands; studies of such variants meet it in bulk, below)."""
    short = "".join(f"; variant {k}: {' and '.join(who)} short of the target at the "
                    f"tightest setting ({err:.1e}), left out" for k, who, err in any_["short"])
    return (f"derive.simulate end to end, the law seen and every other number changed (M, m, "
            f"e, height, spin; {any_['met']} of {len(any_['variants'])} variants at equal error "
            f"within the 1e-9 target): median {any_['median']:.0f}x SciPy on the same variant "
            f"({any_['min']:.0f}-{any_['max']:.0f}x; one call at a time: reported, the goal of "
            f"1000x is the study's){short}")


def _cli_target(c: dict):
    return judge(f"CLI on the built-in scene with static plots, CPU time (without: "
                 f"{c['no plots'].median:.2f} s)", c["with static plots"], AT_MOST,
                 GOALS["cli_s"], ".2f", " s")


def targets(out: dict) -> list:
    found = [t for sc in out["scenes"] for t in _scene_targets(sc)]
    if "cli" in out:
        found.append(_cli_target(out["cli"]))
    for b in out.get("batch", []):
        found += batch.targets(b)
    return found


def passed(out: dict) -> bool:
    return all(t.ok for t in targets(out))


def report(out: dict) -> str:
    lines = []
    for sc in out["scenes"]:
        rows = sc["rows"]
        agree = sc["reference_agreement"]
        lines.append(f"scene {sc['scene']} ({sc['duration']:g} s), max state error target "
                     f"{out['target']:g}; reference vs SciPy at 1e-13: state {agree[0]:.1e}, "
                     f"impact times {agree[1]:.1e}")
        lines.append(f"  {'route':<28}{'setting':>9}{'time [ms]':>12}{'quartiles [ms]':>20}"
                     f"{'state err':>11}{'impact err':>12}{'evals':>9}")
        for r in rows:
            setting = f"{r['setting']:g}" if r["setting"] is not None else "not met"
            ev = f"{r['evaluations']:>9d}" if isinstance(r["evaluations"], (int, np.integer)) \
                else f"{'':>9}"
            sp = _spread(r)
            quart = f"{1e3 * sp.lo:.4g}-{1e3 * sp.hi:.4g}" if sp.n > 1 else ""
            lines.append(f"  {r['route']:<28}{setting:>9}{1e3 * r['seconds']:>12.4g}"
                         f"{quart:>20}{r['error']:>11.1e}{r['impact_error']:>12.1e}{ev}")
        by = {r["route"]: r["seconds"] for r in rows}
        scipy = by.get("scipy DOP853", np.nan)
        c_run = next(v for k, v in by.items() if k.startswith("runtime C"))
        lines += [f"  {t}" for t in _scene_targets(sc)]
        if sc.get("any_numbers"):
            lines.append(f"  {any_numbers_line(sc['any_numbers'])}")
        lines.append(f"  the C run alone: {scipy / c_run:.0f}x SciPy; end to end costs "
                     f"{by['derive.simulate (law seen)'] / c_run:.2f}x the C run")
    if "cli" in out:
        lines.append(str(_cli_target(out["cli"])))
    for b in out.get("batch", []):
        lines += batch.report_lines(b)
    if "first_build" in out:
        lines.append(f"first call on a fresh machine: the general model's library builds in "
                     f"{out['first_build']['general_s']:.1f} s (once; every later process "
                     "loads it from the cache)")
    lines.append(SPREAD_NOTE)
    return "\n".join(lines)
