"""Tabulated laws over random tables rather than chosen ones (the knot-ending steps of
``crt_law_next_knot`` and the spline's evaluation in C).

* In free flight: random tables (6 to 160 knots, equally spaced or not, ``periodic``,
  ``rest`` or ``free`` ends, smooth curves with noise on the samples) under every method
  at the default tolerance (1e-10): the final state within steps x rtol of a run by
  another method at 1e-14, every step's error within the tolerance and accumulated (over
  600 such scenes the error reached at most 0.51 of that, 2.8e-8 with 1850 steps).
* On the plane: the random bouncing scenes of ``derive verify robustness`` with their
  formula law replaced by its samples on random knots (a ``free`` table over the run):
  every property of :func:`derive.verify.judges.judge_run` (done at the end time, no
  penetration, A orthonormal, |K| constant within each flight).
"""
from __future__ import annotations

import numpy as np
import pytest

from derive.verify.generators import random_scene, with_rk4_step
from derive.verify.judges import judge_run
from derive.runtime.driver import simulate
from derive.scene import parse_scene

METHODS = ("lie", "lie5", "lie8", "dop853", "dopri5")


def _knots(rng, n: int, t0: float, span: float) -> np.ndarray:
    if rng.random() < 0.5:
        return np.linspace(t0, t0 + span, n)
    gaps = rng.uniform(0.2, 1.0, n - 1)
    ts = t0 + np.r_[0.0, np.cumsum(gaps)] * span / gaps.sum()
    ts[-1] = t0 + span
    return ts


def random_table_flight(rng) -> dict:
    n = int(rng.integers(6, 160))
    span = float(rng.uniform(0.3, 4.0))
    ts = _knots(rng, n, 0.0, span)
    ends = str(rng.choice(["periodic", "rest", "free"]))
    k, ph, amp = rng.integers(1, 4, 3), rng.uniform(0, 6.3, 3), rng.uniform(0.02, 0.2, 3)
    xyz = amp * np.sin(2 * np.pi * np.outer(ts / span, k) + ph) + rng.normal(0, 3e-3, (n, 3))
    if ends == "periodic":
        xyz[-1] = xyz[0]
    duration = span * (rng.uniform(1.5, 3.0) if ends == "periodic" else rng.uniform(0.5, 1.0))
    J = np.sort(rng.uniform(0.05, 0.2, 3))
    J[2] = min(J[2], J[0] + J[1] - 1e-3)
    return {"name": "random-table",
            "body": {"mass": float(rng.uniform(0.5, 2.0)), "inertia": J.tolist(),
                     "shape": "none"},
            "point": {"mass": float(rng.uniform(0.05, 0.8)),
                      "samples": np.column_stack([ts, xyz]).tolist(), "ends": ends},
            "initial": {"omega": rng.uniform(-2.0, 2.0, 3).tolist()},
            "run": {"duration": float(duration), "g": 0.0,
                    "method": str(rng.choice(METHODS))}}


@pytest.mark.parametrize("block", range(2))
def test_random_tables_keep_the_tolerance_in_flight(block):
    rng = np.random.default_rng(7100 + block)
    bad = []
    for k in range(100):
        doc = random_table_flight(rng)
        run = simulate(doc)
        method = doc["run"]["method"]
        doc["run"].update(method="lie8" if method.startswith("dop") else "dop853",
                          rtol=1e-14, atol=1e-16)
        ref = simulate(doc)
        err = float(np.max(np.abs(run.q[-1] - ref.q[-1])))
        if run.status != "done" or ref.status != "done" \
                or not err <= run.stats["steps"] * run.scene.rtol:
            bad.append(f"#{k} {method} {doc['point']['ends']} "
                       f"{len(doc['point']['samples'])} knots: {run.status}, error {err:.2e}")
    assert not bad, "\n".join(bad)


def as_table(doc: dict, rng) -> dict:
    """The scene with its formula law replaced by samples of it on random knots (5 to 40
    per second, even or uneven), a ``free`` table over the whole run."""
    scene = parse_scene(doc, "random")
    n = int(np.clip(scene.duration * rng.uniform(5, 40), 8, 3000))
    ts = _knots(rng, n, scene.t0, scene.duration)
    xyz = scene.law.jets(ts)[[0, 3, 6]].T
    doc = dict(doc, point={"mass": doc["point"]["mass"],
                           "samples": np.column_stack([ts, xyz]).tolist(), "ends": "free"})
    return doc


@pytest.mark.parametrize("block", range(2))
def test_random_bouncing_scenes_with_tables_hold_every_property(block):
    bad = []
    for k in range(40):
        rng = np.random.default_rng(9900 + 40 * block + k)
        doc = as_table(with_rk4_step(random_scene(rng, 12.0), rng), rng)
        size = max(doc["body"].get("semi_axes", [doc["body"].get("radius", 0.0)]))
        result = simulate(doc)
        verdict, detail = judge_run(result, size)
        if verdict != "ok":
            bad.append(f"#{40 * block + k} {doc['run']['method']}: {verdict} {detail}")
    assert not bad, "\n".join(bad)
