"""``derive bench base``: what a body resting on its face costs (issue 33's Performance).

* **Per simulated second**: the C run of derive/scene/examples/capsule-crawler.toml (the
  base model: stick and slip over the box's face, twenty periods) against the smooth
  flight model's run of the same body and law in free flight (the general model, the
  same tolerances), interleaved rounds, paired samples: CPU time per simulated second
  and their ratio.  Target (the issue's): the base model costs no more per simulated
  second than the flight model, ratio <= 1.
* **A study of friction and frequency**: ``simulate_many`` of the same capsule over a
  grid of mu (= mu_s, 0.1..0.5) and the law's frequency W (8..16 rad/s), each variant
  twenty periods of W = 12: the wall time of the whole study on every core (validation,
  the model's choice, the runs, the summaries), and the C calls' time summed over the
  threads.  Target (the issue's): 10^4 variants in under 10 s; a smaller grid
  (``--grid``) is timed as it is and its time per variant scaled to 10^4, said so.
"""
from __future__ import annotations

import math
import time
import tomllib
from pathlib import Path

import numpy as np

from ..commands import Target
from .timing import (AT_MOST, SPREAD_NOTE, PreparedRun, Spread, interleaved, judge,
                     ratios)

EXAMPLE = Path(__file__).parents[1] / "scene" / "examples" / "capsule-crawler.toml"
PERIODS = 20
W0 = 12.0
STUDY_LIMIT = 10.0            # seconds for 10^4 variants
RATIO_LIMIT = 1.0             # the base model against the flight model, per simulated second


def scene(flight: bool = False) -> dict:
    """The capsule crawler over twenty periods (one [point] table, so that a study can set
    its law); ``flight``: the same body and law in free flight (no plane)."""
    doc = tomllib.loads(EXAMPLE.read_text())
    doc["point"] = doc["point"][0]
    doc["run"]["duration"] = PERIODS * 2 * math.pi / W0
    if flight:
        doc.pop("plane")
        doc["initial"] = {"com": [0.0, 0.0, 1.0]}
        doc["run"]["model"] = "general"
    return doc


def per_second(samples: int) -> dict:
    base, flight = PreparedRun(scene()), PreparedRun(scene(flight=True))
    got = interleaved({"base": base, "flight": flight}, samples, block=3)
    T = base.prep.scene.duration
    return {"base": Spread.of(got["base"]).scaled(1.0 / T),
            "flight": Spread.of(got["flight"]).scaled(1.0 / T),
            "ratio": ratios(got["base"], got["flight"]),
            "models": (base.prep.kind, flight.prep.kind),
            "evaluations": (base.raw.stats["rhs_evaluations"],
                            flight.raw.stats["rhs_evaluations"]),
            "statuses": (base.raw.status, flight.raw.status), "duration": T}


def study(grid: int, workers: int | None) -> dict:
    """The friction x frequency study of grid x grid variants: its wall time, the C's."""
    from ..runtime.batch import simulate_many
    doc = scene()
    mus = np.linspace(0.1, 0.5, grid)
    Ws = np.linspace(8.0, 16.0, grid)
    variants = [{"plane.friction": float(mu), "plane.static_friction": float(mu),
                 "point.law[0]": f"0.05*(sin({W:.9g}*t) + 0.4*sin({2 * W:.9g}*t))"}
                for W in Ws for mu in mus]
    start = time.perf_counter()
    batch = simulate_many(doc, variants, workers=workers)
    wall = time.perf_counter() - start
    statuses = batch.column("status")
    return {"n": len(variants), "wall_s": wall,
            "c_s": float(np.nansum(np.asarray(batch.column("run_ms"), dtype=float))) / 1e3,
            "models": sorted(set(batch.column("model"))),
            "done": int(np.sum(statuses == "done")),
            "speed_range": (float(np.nanmin(batch.column("distance"))),
                            float(np.nanmax(batch.column("distance"))))}


def run(repeats: int = 7, grid: int = 100, workers: int | None = None,
        progress=lambda m: None) -> dict:
    progress("the base model against the flight model, interleaved")
    out = {"per_second": per_second(repeats)}
    progress(f"the study of {grid} x {grid} variants")
    out["study"] = study(grid, workers)
    return out


def targets(out: dict) -> list[Target]:
    ps, st = out["per_second"], out["study"]
    per_1e4 = st["wall_s"] / st["n"] * 1e4
    what = ("10^4 variants" if st["n"] == 10_000 else
            f"{st['n']} variants' time scaled to 10^4")
    return [judge("the base model's C run per simulated second against the flight model's",
                  ps["ratio"], AT_MOST, RATIO_LIMIT),
            Target(f"a friction x frequency study, {what}: {per_1e4:.1f} s (target <= "
                   f"{STUDY_LIMIT:g} s)", per_1e4 <= STUDY_LIMIT)]


def report(out: dict) -> str:
    ps, st = out["per_second"], out["study"]
    lines = [f"the capsule crawler, {PERIODS} periods ({ps['duration']:.3f} s): model "
             f"{ps['models'][0]} ({ps['statuses'][0]}, {ps['evaluations'][0]} RHS "
             f"evaluations) {ps['base'].scaled(1e3).text('.3f')} ms CPU per simulated "
             f"second; the same body and law in free flight, model {ps['models'][1]} "
             f"({ps['statuses'][1]}, {ps['evaluations'][1]} RHS evaluations) "
             f"{ps['flight'].scaled(1e3).text('.3f')} ms; ratio {ps['ratio'].text('.2f', 'x')}",
             f"study of friction x frequency, {st['n']} variants (models "
             f"{', '.join(st['models'])}; {st['done']} done): {st['wall_s']:.2f} s wall, "
             f"{1e3 * st['wall_s'] / st['n']:.2f} ms a variant; the C calls "
             f"{1e3 * st['c_s'] / st['n']:.2f} ms a variant summed over the threads (the "
             f"rest: validating each variant's law and scene, the choice, the travel); net "
             f"displacement over "
             f"{PERIODS} periods {st['speed_range'][0]:.3g} to {st['speed_range'][1]:.3g} m",
             SPREAD_NOTE]
    lines += [f"goal: {t}" for t in targets(out)]
    return "\n".join(lines)


def passed(out: dict) -> bool:
    return all(t.ok for t in targets(out))
