"""``derive bench sim``'s parameter study: what ``simulate_many`` costs a user, end to
end (from the dict of overrides to the columns read), against the C run of the same
variants, against SciPy at equal error, and on two workers against one (issue 31).

A study of :data:`VARIANTS` variants of a scene, each with every number a study varies
changed (M, m, e, the drop height, the spin: :func:`derive.bench.sim.variation`), runs
at the tolerance where the runtime meets the bench's 1e-9 error target on every variant
that ``any_numbers`` measured against SciPy (the tightest of their loosest settings).
Measured in interleaved rounds (a burst of load on the shared machine hits every route
alike), each route once per round, by the CPU time of the thread, and by the wall clock
for two workers against one:

* the study on one worker (``workers=1``) -- per variant, what a core pays;
* the C run alone: ``crt_run_many`` of the same variants' inputs, built beforehand by
  ``derive.runtime.driver.prepare`` one variant at a time, in one call (no Python);
* the study on two workers (threads);
* the C run alone split over two threads: the machine's ceiling for two workers now.

And against SciPy at equal error: the variants both routes reach (``any_numbers``:
SciPy at its own loosest setting that meets the target, each its own median time), run
as a study of them repeated to :data:`VARIANTS` runs.
"""
from __future__ import annotations

import copy
import threading
import time

import numpy as np

from ..runtime.build import library
from ..runtime.driver import Session, prepare
from ..scene import overrides
from .routes import Runtime, errors
from .timing import AT_LEAST, AT_MOST, Judged, Spread, interleaved, judge, ratios

VARIANTS = 1008
ROUNDS = 9
GOALS = {"c": 1.3, "scipy": 1000.0, "workers": 1.6}


def _at(doc: dict, setting: float) -> dict:
    d = copy.deepcopy(doc)
    d.setdefault("run", {}).update(method="lie", rtol=setting, atol=setting * 1e-2)
    return d


def _applied(doc: dict, changes: dict) -> dict:
    d = copy.deepcopy(doc)
    for name, value in changes.items():
        overrides.apply_to_doc(d, name, value)
    return d


def _c_inputs(doc: dict, variants: list) -> tuple:
    """The runs' inputs, each variant prepared alone (the per-scene path), stacked."""
    preps = [prepare(_applied(doc, v)) for v in variants]
    kinds = {p.kind for p in preps}
    if len(kinds) != 1:
        raise RuntimeError(f"the study's variants take several models ({sorted(kinds)})")
    arrays = (np.array([p.scene.t0 for p in preps]),
              np.array([p.scene.t0 + p.scene.duration for p in preps]),
              np.array([p.start.q0 for p in preps]), np.array([p.options for p in preps]),
              np.array([p.parameters for p in preps]))
    return preps[0].kind, preps[0].scene.law, arrays


class _CAlone:
    """crt_run_many of prepared inputs on ``threads`` threads, each its own session."""

    def __init__(self, kind: str, law, arrays: tuple, threads: int):
        self.slices = [slice(k, None, threads) for k in range(threads)]
        self.sessions = [Session(library(kind)) for _ in range(threads)]
        for s in self.sessions:
            s.set_law(law)
        self.arrays = arrays

    def _one(self, k: int) -> None:
        self.sessions[k].run_many(*(a[self.slices[k]] for a in self.arrays))

    def __call__(self) -> None:
        if len(self.sessions) == 1:
            self._one(0)
            return
        threads = [threading.Thread(target=self._one, args=(k,))
                   for k in range(len(self.sessions))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()


def study_setting(any_: dict) -> float | None:
    """The runtime's setting for the study: the tightest of the loosest settings at which
    it met the target on the variants both routes reached (None: none did)."""
    met = [r["settings"][0] for r in any_["variants"] if r["met"]]
    return min(met) if met else None


def measure(doc: dict, any_: dict, variation, progress, rounds: int = ROUNDS) -> dict:
    """The study of ``doc`` (``variation(doc, rng)``: one variant's overrides) against the
    C run alone, SciPy at equal error and two workers."""
    import derive
    setting = study_setting(any_)
    if setting is None:
        return {"scene": doc.get("name", "scene"), "skipped": "no variant reached the "
                "error target on both routes"}
    base = _at(doc, setting)
    rng = np.random.default_rng(31)
    variants = [variation(doc, rng) for _ in range(VARIANTS)]
    progress(f"{base['name']}: simulate_many of {VARIANTS} variants at {setting:g}")
    start = time.perf_counter()
    derive.simulate_many(base, variants, workers=1)
    first = time.perf_counter() - start
    kind, law, arrays = _c_inputs(base, variants)
    c1, c2 = _CAlone(kind, law, arrays, 1), _CAlone(kind, law, arrays, 2)
    one, two = (lambda: derive.simulate_many(base, variants, workers=1),
                lambda: derive.simulate_many(base, variants, workers=2))
    got = interleaved({"study_1": one, "c_1": c1, "study_1_wall": one, "study_2": two,
                       "c_1_wall": c1, "c_2": c2}, rounds,
                      wall=("study_1_wall", "study_2", "c_1_wall", "c_2"))
    out = {"scene": base["name"], "variants": VARIANTS, "setting": setting, "model": kind,
           "first_call_s": first,
           "study_1": Spread.of(got["study_1"]).scaled(1.0 / VARIANTS),
           "c_1": Spread.of(got["c_1"]).scaled(1.0 / VARIANTS),
           "study_2": Spread.of(got["study_2"]).scaled(1.0 / VARIANTS),
           "over_c": ratios(got["study_1"], got["c_1"]),
           "workers": ratios(got["study_1_wall"], got["study_2"]),
           "ceiling": ratios(got["c_1_wall"], got["c_2"])}
    out.update(_against_scipy(doc, base, any_, setting, progress))
    return out


def _against_scipy(doc: dict, base: dict, any_: dict, setting: float, progress,
                   rounds: int = 5) -> dict:
    """The variants both routes reached, checked at the study's setting (each must still
    meet the target there): a study of them repeated to VARIANTS runs on one worker
    against SciPy on each of them once (at its own loosest setting that meets the
    target), in interleaved rounds; per variant, the ratio of the means."""
    import derive
    met = [r for r in any_["variants"] if r["met"]]
    kept = []
    for r in met:
        err, ierr = errors(Runtime(_applied(base, r["overrides"]), "lie", setting).result(),
                           r["reference"])
        if err <= any_["target"] and ierr <= any_["target"]:
            kept.append(r)
    if not kept:
        return {"scipy_skipped": f"no variant met the target at {setting:g}"}
    copies = max(1, VARIANTS // len(kept))
    variants = [r["overrides"] for r in kept for _ in range(copies)]
    progress(f"{base['name']}: the {len(kept)} variants SciPy reached, {copies} times each, "
             f"against SciPy")

    def scipy():
        for r in kept:
            r["scipy_route"].result()
    got = interleaved({"study": lambda: derive.simulate_many(base, variants, workers=1),
                       "scipy": scipy}, rounds)
    study = np.asarray(got["study"]) / len(variants)
    peer = np.asarray(got["scipy"]) / len(kept)
    return {"scipy_variants": len(kept), "scipy_of": len(met), "copies": copies,
            "scipy_s": Spread.of(peer), "study_met": Spread.of(study),
            "over_scipy": ratios(peer, study)}


def _undecided(t: Judged, ceiling: Spread, margin: float) -> Judged:
    """Two workers against one cannot be judged when the machine gives the C alone less
    than the target on two threads (another process holds the second core)."""
    if t.ok or not ceiling.hi < margin:
        return t
    return Judged(t.what + f" [undecided: the C alone on two threads reached only "
                           f"{ceiling.text('.2f', 'x')} now, another process holds the second "
                           f"core]", True, True)


def _python_share(b: dict) -> float:
    """The share of the study's time on one worker spent outside the C (its Python)."""
    return max(0.0, 1.0 - 1.0 / b["over_c"].median)


def _amdahl(b: dict) -> float:
    """Two workers against one if all the Python were serial and the C split evenly."""
    x = _python_share(b)
    return 1.0 / (x + (1.0 - x) / 2.0)


def targets(b: dict) -> list:
    if "skipped" in b:
        return []
    name = b["scene"]
    out = [judge(f"{name}: simulate_many per variant on one worker, over the C run alone "
                 f"(crt_run_many of the same inputs)", b["over_c"], AT_MOST, GOALS["c"]),
           _undecided(judge(f"{name}: simulate_many on two workers, over one", b["workers"],
                            AT_LEAST, GOALS["workers"]), b["ceiling"], GOALS["workers"])]
    if "over_scipy" in b:
        out.insert(1, judge(
            f"{name}: simulate_many per variant per core against SciPy DOP853 at equal error "
            f"({b['scipy_variants']} of the {b['scipy_of']} variants both reach, "
            f"{b['copies']} runs each)", b["over_scipy"], AT_LEAST, GOALS["scipy"], ".0f"))
    return out


def report_lines(b: dict) -> list:
    if "skipped" in b:
        return [f"simulate_many on {b['scene']}: not measured ({b['skipped']})"]
    lines = [f"simulate_many of {b['variants']} variants of {b['scene']} (M, m, e, height and "
             f"spin each varied; the {b['model']} model, lie at {b['setting']:g}, where every "
             f"variant both routes reached meets the target), {ROUNDS} interleaved rounds:",
             f"  per variant: {1e3 * b['study_1'].median:.4f} ms on one worker (CPU), "
             f"{1e3 * b['study_2'].median:.4f} ms on two (wall); the C run alone "
             f"{1e3 * b['c_1'].median:.4f} ms (the first call of the process: "
             f"{b['first_call_s']:.3f} s for all)",
             f"  the C alone on two threads against one: {b['ceiling'].text('.2f', 'x')} "
             "(the machine's ceiling for two workers now); the study's Python around the C, "
             f"{100 * _python_share(b):.0f}% of its time on one worker, holds the GIL: on two "
             f"free cores it bounds two workers to {_amdahl(b):.2f}x one (Amdahl)"]
    if "over_scipy" in b:
        lines.append(f"  the variants SciPy reached: {1e3 * b['study_met'].median:.4f} ms per "
                     f"variant in the study, SciPy {1e3 * b['scipy_s'].median:.1f} ms")
    elif "scipy_skipped" in b:
        lines.append(f"  against SciPy: not measured ({b['scipy_skipped']})")
    return lines + [f"  {t}" for t in targets(b)]
