"""``derive verify robustness``: thousands of random valid bouncing scenes through the
runtime.

Scenes from :func:`derive.verify.generators.random_scene` (RK4 given a step that
resolves fast spins); each run is judged by :func:`derive.verify.judges.judge_run`:
status ``done`` with the end time reached, the lowest height of S above -1e-9 of the
body's size, no NaN, A orthonormal, and |K| constant within each flight (E1.9); for the
Lie-group methods (``lie``, ``lie5``, ``lie8``) both to round-off (1e-12) in flight,
whatever the tolerance.  The goal: no falls, no wrong status or invariant, no valid scene
refused, no run past 10x the median cost per simulated second.
``tests/test_contact_properties.py`` runs a seeded subset in CI.
"""
from __future__ import annotations

import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..commands import Target
from .generators import random_scene, with_rk4_step
from .judges import judge_run


@dataclass
class Outcome:
    """One scene's run (``verdict`` from :func:`judge_run`, or ``refused``)."""
    index: int
    verdict: str              # ok, fell, status, nan, orthonormality, integral, refused
    status: str
    seconds: float
    min_height: float
    size: float
    duration: float = 1.0
    detail: str = ""


def run_one(args) -> Outcome:
    """Scene ``index`` from the generator seeded with ``seed``: parsed, run and judged."""
    index, seed, max_duration = args
    from ..runtime.driver import simulate
    from ..scene import SceneError, parse_scene
    rng = np.random.default_rng(seed)
    doc = with_rk4_step(random_scene(rng, max_duration), rng)
    size = max(doc["body"].get("semi_axes", [doc["body"].get("radius", 0.0)]))
    start = time.perf_counter()
    try:
        scene = parse_scene(doc, "random")
    except SceneError as exc:
        return Outcome(index, "refused", "", 0.0, math.nan, size, doc["run"]["duration"],
                       str(exc))
    result = simulate(scene)
    seconds = time.perf_counter() - start
    verdict, detail = judge_run(result, size)
    import collections
    kinds = collections.Counter(e["kind"] for e in result.events)
    detail = detail or (f"{doc['run']['method']}, {kinds.get('impact', 0)} impacts, "
                        f"{kinds.get('contact', 0)} contacts, {result.stats['steps']} steps")
    return Outcome(index, verdict, result.status, seconds, result.min_height, size,
                   scene.duration, detail)


def run(n: int = 10_000, seed: int = 11, max_duration: float = 60.0,
        workers: int | None = None, progress=None) -> list[Outcome]:
    """n random scenes (scene k from the seed ``seed * 1000003 + k``), ``workers``
    forked processes at once (default: every core)."""
    tasks = [(k, seed * 1_000_003 + k, max_duration) for k in range(n)]
    workers = workers or os.cpu_count() or 1
    from ..runtime.build import library
    library("general")                  # built (or loaded) once, before the workers fork
    out = []
    if workers == 1:
        for task in tasks:
            out.append(run_one(task))
            if progress and len(out) % 100 == 0:
                progress(f"{len(out)}/{n}")
        return out
    import multiprocessing
    ctx = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(workers, mp_context=ctx) as pool:
        for o in pool.map(run_one, tasks, chunksize=8):
            out.append(o)
            if progress and len(out) % 500 == 0:
                progress(f"{len(out)}/{n}")
    return out


def _cost(outcomes: list[Outcome]) -> tuple[list[Outcome], float, list[Outcome]]:
    """(the runs, their median seconds per simulated second, the runs past 10x it):
    durations differ by 60x, so the cost is per simulated second."""
    ran = [o for o in outcomes if o.verdict != "refused"]
    med = float(np.median([o.seconds / o.duration for o in ran])) if ran else 0.0
    return ran, med, [o for o in ran if o.seconds / o.duration > 10 * med]


def targets(outcomes: list[Outcome]) -> list[Target]:
    from collections import Counter
    counts = Counter(o.verdict for o in outcomes)
    wrong = sum(v for k, v in counts.items() if k not in ("ok", "refused", "fell"))
    slow = _cost(outcomes)[2]
    return [Target(f"0 falls ({counts['fell']})", counts["fell"] == 0),
            Target(f"0 wrong statuses or invariants ({wrong})", wrong == 0),
            Target(f"0 valid scenes refused ({counts['refused']})", counts["refused"] == 0),
            Target(f"0 runs past 10x the median cost ({len(slow)})", not slow)]


def passed(outcomes: list[Outcome]) -> bool:
    return all(t.ok for t in targets(outcomes))


def report(outcomes: list[Outcome]) -> str:
    from collections import Counter
    counts = Counter(o.verdict for o in outcomes)
    ran, med, slow = _cost(outcomes)
    times = np.array([o.seconds for o in ran]) if ran else np.zeros(1)
    lines = [f"{len(outcomes)} random bouncing scenes: " +
             ", ".join(f"{k} {v}" for k, v in sorted(counts.items())),
             f"time per scene: median {1e3 * np.median(times):.1f} ms, max "
             f"{1e3 * times.max():.1f} ms; per simulated second: median {1e3 * med:.2f} ms, "
             f"{len(slow)} past 10x the median"]
    bad = [o for o in outcomes if o.verdict != "ok"]
    for o in bad[:20]:
        lines.append(f"  #{o.index} {o.verdict}: {o.detail}")
    for o in sorted(ran, key=lambda o: -o.seconds / o.duration)[:5]:
        lines.append(f"  slowest #{o.index}: {1e3 * o.seconds:.1f} ms for {o.duration:.3g} s "
                     f"({o.status}; {o.detail or 'ok'})")
    lines.append("goal: " + "; ".join(str(t) for t in targets(outcomes)))
    return "\n".join(lines)
