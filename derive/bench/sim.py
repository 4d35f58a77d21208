"""``derive bench sim``: time to simulate a scene (default: the built-in one, 5 s, all
impacts) to a max state error of 1e-9, against two peer routes, in one run.

The routes are those of :mod:`derive.bench.routes`: the runtime (every method, setting
swept, the loosest one that meets the target timed), SciPy ``solve_ivp`` DOP853 with the
NumPy RHS and terminal events restarted at each impact, and CasADi ``cvodes`` run
segment by segment with event search.  Error: the max over a common output grid (every
0.05 s) of the state error in the ``general`` layout against a reference at tolerance
1e-14 (itself checked against SciPy at 1e-13), and the max error of the impact times.
Time: the minimum over repetitions after a warm-up; compile and specialisation are
one-off costs reported by ``derive simulate``.
"""
from __future__ import annotations

import copy

import numpy as np

from ..runtime.scene import DEFAULT_SCENE
from .routes import Casadi, Runtime, Scipy, errors

TARGET = 1e-9


def run(scene_doc: dict | None = None, progress=lambda m: None, repeats: int = 7,
        target: float = TARGET) -> dict:
    if scene_doc is None:
        import tomllib
        scene_doc = tomllib.loads(DEFAULT_SCENE)
    doc = copy.deepcopy(scene_doc)
    progress("reference: DOP853 at 1e-14, checked against SciPy at 1e-13")
    ref = Runtime(doc, "dop853", 1e-14).result()
    agreement = errors(Scipy(doc, "DOP853", 1e-13).result(), ref)
    candidates = [
        (lambda s: Runtime(doc, "lie", s), [1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13]),
        (lambda s: Runtime(doc, "dop853", s), [1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]),
        (lambda s: Runtime(doc, "dopri5", s), [1e-8, 1e-9, 1e-10, 1e-11, 1e-12]),
        (lambda s: Runtime(doc, "rk4", s), [4e-3, 2e-3, 1e-3, 5e-4]),
        (lambda s: Scipy(doc, "DOP853", s), [1e-9, 1e-10, 1e-11, 1e-12, 1e-13]),
        (lambda s: Casadi(doc, s), [1e-11, 1e-12, 1e-13, 1e-14]),
    ]
    rows = []
    for make, settings in candidates:
        for setting in settings:
            route = make(setting)
            progress(f"{route.label} at {setting:g}")
            result = route.result()
            err, ierr = errors(result, ref)
            if err <= target and ierr <= target:
                reps = repeats if route.label.startswith("runtime") else max(1, repeats // 2)
                rows.append({"route": route.label, "setting": setting,
                             "seconds": route.timed(reps), "error": err,
                             "impact_error": ierr, "impacts": len(result.impacts),
                             "evaluations": result.evaluations})
                break
        else:
            rows.append({"route": route.label, "setting": None, "seconds": np.nan,
                         "error": err, "impact_error": ierr, "impacts": len(result.impacts),
                         "evaluations": result.evaluations})
    return {"scene": doc.get("name", "scene"), "duration": doc.get("run", {}).get("duration", 5.0),
            "target": target, "reference_agreement": agreement, "rows": rows}


def report(out: dict) -> str:
    rows = out["rows"]
    ours = [r for r in rows if r["route"].startswith("runtime") and np.isfinite(r["seconds"])]
    best = min(ours, key=lambda r: r["seconds"]) if ours else None
    agree = out["reference_agreement"]
    lines = [f"scene {out['scene']} ({out['duration']:g} s), target max state error "
             f"{out['target']:g}; reference vs SciPy at 1e-13: state {agree[0]:.1e}, "
             f"impact times {agree[1]:.1e}",
             f"{'route':<20}{'setting':>9}{'time [ms]':>11}{'state err':>11}"
             f"{'impact err':>12}{'impacts':>9}{'evals':>9}{'x best':>9}"]
    for r in rows:
        ratio = r["seconds"] / best["seconds"] if best and np.isfinite(r["seconds"]) else np.nan
        setting = f"{r['setting']:g}" if r["setting"] is not None else "not met"
        lines.append(f"{r['route']:<20}{setting:>9}{1e3 * r['seconds']:>11.3f}"
                     f"{r['error']:>11.1e}{r['impact_error']:>12.1e}{r['impacts']:>9d}"
                     f"{r['evaluations']:>9d}{ratio:>9.1f}")
    if best:
        for peer, goal in (("scipy DOP853", 1000), ("casadi cvodes", 20)):
            r = next((x for x in rows if x["route"] == peer), None)
            if r is not None and np.isfinite(r["seconds"]):
                lines.append(f"speed-up of {best['route']} over {peer}: "
                             f"{r['seconds'] / best['seconds']:.0f}x (target >= {goal}x)")
    return "\n".join(lines)
