"""``derive bench robustness``: thousands of random valid scenes through the runtime, and
random malformed ones through the scene parser.

Physical scenes (:func:`random_scene`): spheres and ellipsoids with offset centres, M and
m (m > M included), inertia near-symmetric and strongly asymmetric, laws of 1-3 harmonics
up to 30% of the body's size and 15 rad/s, spins up to 20 rad/s, restitution in
{0, 0.1, 0.5, 0.9, 1} or random, durations up to 60 s, every method.  Each run is judged
by :func:`judge`: status ``done`` with the end time reached, the lowest height of S
above -1e-9 of the body's size, no NaN, A orthonormal, and |K| constant within each
flight (E1.9); for the Lie-group methods (``lie``, ``lie5``) both to round-off (1e-12)
in flight, whatever the tolerance.  The goal: no falls, no run past 10x the median
cost, no silent wrong status.  ``tests/test_contact_properties.py`` runs a seeded subset in CI.
"""
from __future__ import annotations

import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..runtime.motion import contact_intervals, phases

METHODS = ("lie", "lie5", "lie8", "dopri5", "dop853", "rk4")
LIE = ("lie", "lie5", "lie8")
ROUNDING = 1e-12          # the Lie methods: orthonormality and |K| in flight at round-off
RESTITUTIONS = (0.0, 0.1, 0.5, 0.9, 1.0)


def _harmonics(rng, amp: float, max_w: float = 15.0) -> str:
    terms = []
    for _ in range(int(rng.integers(1, 4))):
        a = rng.uniform(-amp, amp) / 2
        w = rng.uniform(0.5, max_w)
        ph = rng.uniform(0, 2 * math.pi)
        terms.append(f"{a:.6g}*sin({w:.6g}*t + {ph:.6g})")
    return " + ".join(terms)


def random_scene(rng: np.random.Generator, max_duration: float = 60.0,
                 method: str | None = None) -> dict:
    """A random valid bouncing scene (a dict of the schema)."""
    shape = "sphere" if rng.random() < 0.5 else "ellipsoid"
    size = rng.uniform(0.1, 1.0)
    if shape == "sphere":
        geom = {"radius": size}
    else:
        axes = size * rng.uniform(0.4, 1.0, 3)
        axes[rng.integers(3)] = size
        geom = {"semi_axes": [float(a) for a in axes]}
    center = (rng.uniform(-0.3, 0.3, 3) * size if rng.random() < 0.6 else np.zeros(3))
    M = rng.uniform(0.2, 5.0)
    m = M * (rng.uniform(0.05, 2.0) if rng.random() < 0.8 else rng.uniform(1.0, 4.0))
    if rng.random() < 0.3:                          # near-symmetric
        base = rng.uniform(0.05, 1.0) * M * size ** 2
        J = base * (1 + rng.uniform(-1e-3, 1e-3, 3))
    else:                                           # from a real mass distribution
        second = rng.uniform(0.02, 1.0, 3) * M * size ** 2
        J = np.array([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
    amp = 0.3 * size
    law = [_harmonics(rng, amp) if rng.random() < 0.8 else f"{rng.uniform(-amp, amp):.6g}"
           for _ in range(3)]
    e = float(rng.choice(RESTITUTIONS)) if rng.random() < 0.6 else float(rng.uniform(0, 1))
    spin = rng.normal(size=3)
    spin *= rng.uniform(0, 20) / max(np.linalg.norm(spin), 1e-12)
    quat = rng.normal(size=4)
    # start high enough: the lowest point of any attitude is within |center| + size of O
    z0 = float(np.linalg.norm(center) + size + 0.35 * size + rng.uniform(0.0, 2.0))
    return {
        "name": "random",
        "body": {"mass": float(M), "inertia": [float(j) for j in J], "shape": shape, **geom,
                 "center": [float(c) for c in center]},
        "point": {"mass": float(m), "law": law},
        "plane": {"restitution": e},
        "initial": {"com": [0.0, 0.0, z0],
                    "com_velocity": [float(v) for v in rng.normal(0, 1, 2)]
                    + [float(rng.normal(0, 2))],
                    "omega": [float(w) for w in spin], "quaternion": [float(x) for x in quat]},
        "run": {"duration": float(rng.uniform(1.0, max_duration)),
                "method": method or str(rng.choice(METHODS)),
                "rtol": float(10 ** rng.uniform(-11, -7)), "atol": 1e-12,
                "outputs": ["pose", "impacts"]},
    }


def _with_rk4_step(doc: dict, rng) -> dict:
    """RK4 has no error control: give it a step that resolves fast spins (a user of RK4
    chooses its step; the default is for slow scenes)."""
    if doc["run"]["method"] == "rk4":
        doc["run"]["step"] = float(rng.uniform(1e-3, 2e-3))
    return doc


@dataclass
class Outcome:
    index: int
    verdict: str              # ok, fell, status, nan, orthonormality, integral, refused
    status: str
    seconds: float
    min_height: float
    size: float
    duration: float = 1.0
    detail: str = ""


def judge(result, size: float) -> tuple[str, str]:
    """The verdict on one run: ``ok`` or what is wrong."""
    scene = result.scene
    if result.status != "done":
        return "status", f"ended with {result.status} at t = {result.t[-1]:.6g}"
    if abs(result.t[-1] - (scene.t0 + scene.duration)) > 1e-9 * max(1.0, scene.duration):
        return "status", f"says done but ended at t = {result.t[-1]:.9g}"
    if not np.all(np.isfinite(result.model_q)):
        return "nan", "non-finite state"
    if result.min_height < -1e-9 * size:
        return "fell", f"S reached {result.min_height:.3g} below the plane"
    h = result.height
    if h is not None and np.min(h) < -1e-9 * size:
        k = int(np.argmin(h))
        return "fell", f"a row has S at {h[k]:.3g} (t = {result.t[k]:.6g})"
    g = result.general
    lie = scene.method in LIE
    contact_rows = np.zeros(len(result.t), dtype=bool)
    for a, b in contact_intervals(result):
        contact_rows |= (result.t >= a) & (result.t <= b)
    if g is not None:
        A = g[:, 9:18].reshape(-1, 3, 3)
        dev = np.abs(np.einsum("nij,nkj->nik", A, A) - np.eye(3)).max(axis=(1, 2))
        # classical methods let A drift at the level of their tolerance per unit time
        # (RK4: of its step); the Lie-group methods keep it to round-off in flight (in
        # persistent contact the classical method of the same order runs)
        bound = 1e-9 + 1e4 * (scene.rtol if scene.method != "rk4" else 1e-8) \
            * max(1.0, scene.duration)
        err = float(dev[~contact_rows].max()) if lie and (~contact_rows).any() else float(dev.max())
        if lie and err > ROUNDING:
            return "orthonormality", f"A A^T - 1 reaches {err:.2e} in flight (Lie: round-off)"
        # RK4 has no error control: after impacts spin the body up, its fixed step no
        # longer resolves the rotation, and A's drift says so; not a fault of the runtime
        if scene.method != "rk4" and float(dev.max()) > bound:
            return "orthonormality", f"A A^T - 1 reaches {dev.max():.2e} (bound {bound:.1e})"
    # E1.9 within each flight: |K| constant between events (tolerance-dependent)
    K = result.momentum["K_norm"]
    worst = 0.0
    for a, b, _ in phases(result):
        if b - a > 2 and K[a] > 1e-9 and not contact_rows[a:b].any():
            worst = max(worst, float(np.max(np.abs(K[a:b] - K[a])) / K[a]))
    if worst > (ROUNDING if lie else 1e-4):
        return "integral", f"|K| drifts by {worst:.2e} within a flight"
    return "ok", ""


def run_one(args) -> Outcome:
    index, seed, max_duration = args
    from ..runtime.driver import simulate
    from ..scene import SceneError, parse_scene
    rng = np.random.default_rng(seed)
    doc = _with_rk4_step(random_scene(rng, max_duration), rng)
    size = max(doc["body"].get("semi_axes", [doc["body"].get("radius", 0.0)]))
    start = time.perf_counter()
    try:
        scene = parse_scene(doc, "random")
    except SceneError as exc:
        return Outcome(index, "refused", "", 0.0, math.nan, size, doc["run"]["duration"],
                       str(exc))
    result = simulate(scene)
    seconds = time.perf_counter() - start
    verdict, detail = judge(result, size)
    import collections
    kinds = collections.Counter(e["kind"] for e in result.events)
    detail = detail or (f"{doc['run']['method']}, {kinds.get('impact', 0)} impacts, "
                        f"{kinds.get('contact', 0)} contacts, {result.stats['steps']} steps")
    return Outcome(index, verdict, result.status, seconds, result.min_height, size,
                   scene.duration, detail)


def run(n: int = 10_000, seed: int = 11, max_duration: float = 60.0,
        workers: int | None = None, progress=None) -> list[Outcome]:
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


def report(outcomes: list[Outcome]) -> str:
    from collections import Counter
    counts = Counter(o.verdict for o in outcomes)
    ran = [o for o in outcomes if o.verdict != "refused"]
    times = np.array([o.seconds for o in ran]) if ran else np.zeros(1)
    # cost per simulated second: durations differ by 60x
    rates = np.array([o.seconds / o.duration for o in ran]) if ran else np.zeros(1)
    med = float(np.median(rates))
    slow = [o for o in ran if o.seconds / o.duration > 10 * med]
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
    falls = counts.get("fell", 0)
    wrong = sum(v for k, v in counts.items() if k not in ("ok", "refused"))
    lines.append(f"goal: 0 falls ({'PASS' if falls == 0 else 'FAIL'}), 0 wrong statuses or "
                 f"invariants ({'PASS' if wrong == 0 else 'FAIL'}), 0 runs past 10x the "
                 f"median ({'PASS' if not slow else 'FAIL'})")
    return "\n".join(lines)
