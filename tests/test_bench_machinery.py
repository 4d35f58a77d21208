"""The benchmarks' machinery (not their timings): charts, data and ratios are produced,
and the errors they report are measured against the exact references."""
from __future__ import annotations

import json

import numpy as np

from derive.bench import precision
from derive.bench.routes import Runtime, Scipy, errors


def test_precision_quick_run_writes_charts_and_data(tmp_path):
    summary = precision.run(tmp_path, quick=True, repeats=1, periods=20,
                            scenes=["vertical bounce C2.4"])
    assert (tmp_path / "precision_vertical.png").is_file()
    assert (tmp_path / "long_run.png").is_file()
    data = json.loads((tmp_path / "precision.json").read_text())
    methods = {p["method"] for p in data["points"]}
    assert {"runtime DOP853", "scipy DOP853", "casadi cvodes", "scipy Radau"} <= methods
    matched = summary["scenes"]["vertical bounce C2.4"]["matched"]
    assert matched[0]["level"] == 1e-4 and np.isfinite(matched[0]["runtime_best_s"])
    lines = (tmp_path / "precision.csv").read_text().splitlines()
    assert lines[0].startswith("scene,method,setting,seconds,error")
    # the long run's invariants: projection keeps A orthonormal to round-off
    drift = summary["long_run"]
    assert drift["runtime DOP853+orth"]["orthonormality_final"] < 1e-13


def test_errors_are_against_the_closed_form():
    doc, exact = precision.reference_scenes()["vertical bounce C2.4"]
    from derive.runtime.scene import parse_scene
    route = Runtime(doc, "dop853", 1e-12)
    states, impacts = exact(parse_scene(doc), route.grid)
    from derive.bench.routes import Run
    ref = Run(states, impacts, 0, "done")
    err, ierr = errors(route.result(), ref)
    assert err < 1e-11 and ierr < 1e-12
    # the measure sees a loose tolerance (the bounce itself is a parabola that every
    # method integrates exactly; the axisymmetric scene is not)
    doc, exact = precision.reference_scenes()["axisymmetric E3.14"]
    route = Scipy(doc, "RK45", 1e-4)
    ref = Run(exact(parse_scene(doc), route.grid)[0], np.array([]), 0, "done")
    loose, _ = errors(route.result(), ref)
    assert loose > 1e-8
