"""Stability charts: the sweep against Euler's closed form on its a = 0 edge, identical
results from every executor (serial, local processes, a local Dask cluster), the files
written, and the command line's handling of bad input."""
from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from derive.stability import chart, sweep
from derive.stability.families import FamilyError

X = sweep.Axis("a", 0.0, 0.6, 7)
Y = sweep.Axis("J_z", 0.04, 0.2, 9)
FIXED = {"omega": 2.0, "W": 3.0, "J_x": 0.1, "J_y": 0.12}


@pytest.fixture(scope="module")
def serial():
    return sweep.run("C4.1", X, Y, FIXED, workers=1, progress=False)


def test_edge_a_zero_is_euler(serial):
    """At a = 0 the body is rigid: unstable iff J_z is the intermediate moment, with
    max |rho| = exp(T omega sqrt((J_y - J_z)(J_z - J_x)/(J_x J_y))), T = 2 pi/W."""
    Jx, Jy, w, T = 0.1, 0.12, 2.0, 2 * math.pi / 3.0
    for j, Jz in enumerate(Y.values):
        s = (Jy - Jz) * (Jz - Jx) / (Jx * Jy)
        want = math.exp(T * w * math.sqrt(s)) if s > 0 else 1.0
        assert serial.max_modulus[j, 0] == pytest.approx(want, abs=1e-9)


def test_executors_agree_bit_for_bit(serial):
    procs = sweep.run("C4.1", X, Y, FIXED, workers=2, progress=False)
    assert procs.executor == "processes"
    for name in ("max_modulus", "jordan", "drift"):
        assert np.array_equal(getattr(serial, name), getattr(procs, name), equal_nan=True)


def test_dask_local_cluster_agrees_bit_for_bit(serial):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        dask = sweep.run("C4.1", X, Y, FIXED, scheduler=cluster.scheduler_address,
                         progress=False)
    assert dask.executor == "dask" and dask.workers == 2
    for name in ("max_modulus", "jordan", "drift"):
        assert np.array_equal(getattr(serial, name), getattr(dask, name), equal_nan=True)


def test_files(serial, tmp_path):
    paths = chart.write(serial, tmp_path)
    csv_path, json_path, png = paths
    rows = list(csv.DictReader(open(csv_path, encoding="utf-8")))
    assert len(rows) == X.n * Y.n
    summary = json.loads(json_path.read_text())
    verdicts = [r["verdict"] for r in rows]
    assert summary["counts"]["unstable"] == verdicts.count("unstable") > 0
    assert summary["counts"]["stable_linear"] == verdicts.count("linearly stable") > 0
    assert summary["fixed"]["J_y"] == 0.12 and "a" not in summary["fixed"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bodies_that_cannot_exist_are_masked():
    sw = sweep.run("C4.1", sweep.Axis("J_z", 0.01, 0.29, 5), sweep.Axis("a", 0.0, 0.1, 2),
                   {"J_x": 0.1, "J_y": 0.12}, workers=1, progress=False)
    # J_z = 0.29 > J_x + J_y and J_z = 0.01 < J_y - J_x: no body, NaN, counted
    assert np.isnan(sw.max_modulus[:, 0]).all() and np.isnan(sw.max_modulus[:, -1]).all()
    assert chart.counts(sw)["no_body"] == 4


@pytest.mark.parametrize("text,message", [
    ("a0:1:3", "must be name=lo:hi:n"), ("q=0:1:3", "not a parameter"),
    ("a=1:0:3", "lo < hi"), ("a=0:1:1", r"n must be in \[2, 2000\]"),
    ("a=0:x:3", "must be numbers")])
def test_bad_axes(text, message):
    with pytest.raises(FamilyError, match=message):
        sweep.parse_axis(text, "C4.1", "--x")


@pytest.mark.parametrize("text,message", [
    ("e=0:1:5", r"e must be in \(0, 1\) over the whole axis"),
    ("e=0.5:1:5", r"e must be in \(0, 1\)"), ("Gamma=0:2:5", "Gamma must be > 0"),
    ("n=1:3:3", "n is an integer")])
def test_a_bounce_axis_stays_in_its_parameters_domain(text, message):
    """e = 0 or 1 are not members of the bounce family (it refuses them as --set): an axis
    reaching them is refused, not charted as 'no body' (found by a new-user trial)."""
    with pytest.raises(FamilyError, match=message):
        sweep.parse_axis(text, "bounce", "--x")
    assert sweep.parse_axis("e=0.1:0.9:5", "bounce", "--x").n == 5


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "derive", *args], capture_output=True,
                          text=True, timeout=600)


def test_cli_chart_and_errors(tmp_path):
    out = tmp_path / "chart"
    proc = _cli("chart", "stability", "--family", "C4.2", "--x", "a=0:0.3:4", "--y",
                "J_z=0.08:0.16:5", "--set", "x0=0.05", "-o", str(out), "-q", "--workers", "1")
    assert proc.returncode == 0, proc.stderr
    assert "20 points" in proc.stdout
    assert (out / "stability-C4_2-a-J_z.png").is_file()
    for args, message in [(("--x", "a=0:1"), "--x: range must be lo:hi:n"),
                          (("--set", "nope=1"), "nope: is not a parameter"),
                          (("--set", "J_x=-1"), "J_x: must be > 0"),
                          (("--family", "C9"), "family: 'C9' is not one of"),
                          (("--x", "a=0:1:3", "--set", "a=1"), "'a' is swept"),
                          (("--workers", "0"), "--workers: must be >= 1")]:
        proc = _cli("chart", "stability", "-o", str(tmp_path / "bad"), "-q", *args)
        assert proc.returncode == 2, (args, proc.stderr)
        assert message in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "bad").exists()


def test_cli_stability_scene_file_and_errors(tmp_path):
    scene = tmp_path / "c41.toml"
    scene.write_text('name = "axial"\n[body]\nmass = 1.0\ninertia = [0.1, 0.1, 0.14]\n'
                     'shape = "none"\n[point]\nmass = 0.2\nlaw = ["0", "0", "0.2*sin(3*t)"]\n'
                     '[initial]\nomega = [0.0, 0.0, 2.0]\n[stability]\nlong_periods = 20\n')
    proc = _cli("stability", str(scene), "--json")
    assert proc.returncode == 0, proc.stderr

    def refuse(name):                    # strict JSON: no NaN or Infinity
        raise ValueError(f"{name} in derive stability --json")
    result = json.loads(proc.stdout, parse_constant=refuse)
    assert result["blocks"]["omega, n"]["verdict"].startswith("linearly stable")
    assert len(result["long_runs"]) == 3 and all(c["ok"] for c in result["checks"].values())
    assert "family" not in result
    proc = _cli("stability", "--family", "C4.2", "--set", "J_y=0.14", "--set", "J_z=0.12",
                "-q")
    assert "parameters: J_x=0.1, J_y=0.14, J_z=0.12" in proc.stdout     # what it ran
    scene.write_text(scene.read_text().replace("long_periods = 20", "long_periods = -1"))
    proc = _cli("stability", str(scene))
    assert proc.returncode == 2
    assert "[stability].long_periods: must be >= 0" in proc.stderr
    scene.write_text(scene.read_text().replace("long_periods = -1", "")
                     .replace("[0.0, 0.0, 2.0]", "[0.3, 0.0, 2.0]"))
    proc = _cli("stability", str(scene))
    assert proc.returncode == 2 and "[initial]: the motion is not periodic" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_bounce_chart_agrees_with_the_table_closed_forms():
    """The periodic bouncing of reference [5] on one precompiled library: no orbit below
    the existence threshold Gamma_1 = (1 - e) pi/(1 + e), linearly stable between it and
    the period doubling Gamma_pd (the vertical multipliers |rho| = e < 1, spin and tilt
    neutral), unstable beyond (closed forms of derive/stability/bouncing.py)."""
    from derive.stability import sweep
    from derive.stability.bouncing import existence_threshold, period_doubling_threshold
    x = sweep.parse_axis("e=0.2:0.8:4", "bounce", "--x")
    y = sweep.parse_axis("Gamma=0.5:3:9", "bounce", "--y")
    sw = sweep.run("bounce", x, y, workers=1, progress=False)
    checked = 0
    for j, G in enumerate(y.values):
        for i, e in enumerate(x.values):
            rho = sw.max_modulus[j, i]
            g1, gpd = existence_threshold(e), period_doubling_threshold(e)
            if G < g1:
                assert np.isnan(rho), (e, G)
            elif G < 0.95 * gpd:
                assert rho <= 1 + 1e-6, (e, G, rho)
                checked += 1
            elif G > 1.05 * gpd:
                assert rho > 1 + 1e-3, (e, G, rho)
                checked += 1
    assert checked >= 15


def test_the_bounce_chart_calls_its_grey_points_no_orbit(tmp_path):
    """A trial read "no body" in the bounce chart's CSV and summary for points below the
    existence threshold, where the figure said "no orbit"."""
    import csv

    from derive.stability import chart
    sw = sweep.run("bounce", sweep.parse_axis("e=0.2:0.8:3", "bounce", "--x"),
                   sweep.parse_axis("Gamma=0.5:2:3", "bounce", "--y"), workers=1,
                   progress=False)
    paths = chart.write(sw, tmp_path, plot=False)
    verdicts = [r["verdict"] for r in csv.DictReader(open(paths[0], encoding="utf-8"))]
    assert "no orbit" in verdicts and "no body" not in verdicts


def test_the_bounce_charts_legend_and_counts_sit_outside_the_cells(tmp_path, monkeypatch):
    """The legend and the counts' box had sat on the cells at e 0.7-0.9, Gamma 0.5 and
    on the top-left ones (a new user's trial): both are now one legend under the axes,
    whose box meets the chart's nowhere, and it says the counts the summary gives."""
    from matplotlib.figure import Figure

    from derive.stability import chart
    sw = sweep.run("bounce", sweep.parse_axis("e=0.2:0.8:3", "bounce", "--x"),
                   sweep.parse_axis("Gamma=0.5:2:3", "bounce", "--y"), workers=1,
                   progress=False)
    saved, save = [], Figure.savefig

    def keep(self, *args, **kwargs):
        saved.append(self)
        return save(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", keep)
    chart.write(sw, tmp_path)
    fig = saved[0]
    fig.canvas.draw()
    ax = next(a for a in fig.axes if a.get_xlabel() == "e")
    box = ax.get_window_extent()
    assert not ax.texts and ax.get_legend() is None
    (legend,) = fig.legends
    assert not legend.get_window_extent().overlaps(box)
    labels = [t.get_text() for t in legend.get_texts()]
    c = chart.counts(sw)
    assert f"linearly stable: {c['stable_linear']}" in labels
    assert any(text.endswith(f": {c['unstable']}") and text.startswith("unstable")
               for text in labels)
    assert {"existence (closed form)", "period doubling (closed form)"} <= set(labels)


def test_an_axis_is_the_decimal_grid_typed(tmp_path):
    """--x e=0.1:0.9:17 charts e = 0.3, not np.linspace's 0.30000000000000004, in the
    points run and in the CSV: each value the float nearest to lo + k (hi - lo)/(n - 1),
    checked against exact rational arithmetic (--sweep of derive simulate shares it)."""
    from fractions import Fraction
    for text, n in (("e=0.1:0.9:17", 17), ("Gamma=0.5:3.5:21", 21)):
        ax = sweep.parse_axis(text, "bounce", "--x")
        lo, hi = (Fraction(v) for v in text.split("=")[1].split(":")[:2])
        assert ax.values.tolist() == [float(lo + (hi - lo) * k / (n - 1)) for k in range(n)]
    e = sweep.parse_axis("e=0.1:0.9:17", "bounce", "--x")
    assert e.values[4] == 0.3
    points = sweep.tasks("bounce", e, sweep.parse_axis("Gamma=1:2:2", "bounce", "--y"),
                         {}, 1e-12)[0][3]
    assert [p["e"] for p in points][4] == 0.3
    a = sweep.parse_axis("a=0:0.7:8", "C4.1", "--x")
    sw = sweep.run("C4.1", a, Y, FIXED, workers=1, progress=False)
    rows = list(csv.DictReader(open(chart.write(sw, tmp_path, plot=False)[0],
                                    encoding="utf-8")))
    assert sorted({r["a"] for r in rows}, key=float) == [f"0.{k}" if k else "0.0"
                                                         for k in range(8)]


def test_the_unstable_outline_follows_the_cells():
    """The outline of the unstable region is drawn along the edges of its cells (a second
    trial saw a contour through the points cut across cells, take in six stable points
    and stay open at the chart's edges): every segment separates an unstable cell from a
    stable one or from the chart's edge, and it is closed (each corner is met an even
    number of times)."""
    from collections import Counter

    from derive.stability.chart import _cell_edges, _outline
    ex, ey = _cell_edges([0.0, 0.1, 0.2, 0.3]), _cell_edges([0.08, 0.1, 0.12, 0.14, 0.16])
    assert np.allclose(ex, [-0.05, 0.05, 0.15, 0.25, 0.35])
    rng = np.random.default_rng(3)
    for _ in range(200):
        mask = rng.random((5, 4)) < 0.4
        segs = _outline(mask, ex, ey)
        padded = np.pad(mask, 1)
        # perimeter: unstable cells' sides that face a stable cell or the edge
        sides = sum(int(not padded[j + 1 + dj, i + 1 + di])
                    for j, i in zip(*np.nonzero(mask))
                    for dj, di in ((0, 1), (0, -1), (1, 0), (-1, 0)))
        assert len(segs) == sides
        ends = Counter(p for seg in segs for p in seg)
        assert all(n % 2 == 0 for n in ends.values())
