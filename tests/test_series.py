"""The pictures of long runs (derive.runtime.series): a long series is drawn per pixel
column as its lowest and highest sample, and the overview draws the total energy's drift
in flight; both checked against the raw rows with NumPy."""
from __future__ import annotations

import numpy as np

import derive
from derive.runtime import series
from derive.runtime.events import event_rows, phases
from derive.runtime.motion import motion
from derive.runtime.report import summary


def test_the_envelope_holds_every_samples_lowest_and_highest_per_column():
    """Over random series (spikes, NaN, rows of one instant, columns with no row, a span
    wider than the rows) each column's band is NumPy's nanmin and nanmax of the raw
    samples whose time falls in it (the last column keeps its right end), NaN where the
    column has no finite sample; so every sample lies inside its column's band."""
    rng = np.random.default_rng(7)
    for trial in range(60):
        n = int(rng.integers(1, 20_000))
        t = np.sort(rng.uniform(0.0, rng.uniform(1e-3, 1e4), n))
        t[: int(rng.integers(0, 4))] = t[0]
        if trial % 3 == 0:                          # gaps: whole columns without a row
            t = np.sort(np.r_[t[: n // 3], t[n // 3:] + 5.0 * (t[-1] - t[0] + 1.0)])
        y = rng.standard_normal(n).cumsum()
        y[rng.integers(0, n, 3)] += rng.standard_normal(3) * 1e6
        y[rng.integers(0, n, 2)] = np.nan
        columns = int(rng.integers(1, 700))
        span = None if trial % 2 else (t[0] - rng.uniform(0, 3), t[-1] + rng.uniform(0, 3))
        edges, lo, hi = series.envelope(t, y, columns, span)
        t0, t1 = (t[0], t[-1]) if span is None else span
        assert len(edges) == columns + 1 and edges[0] == t0 and edges[-1] == t1
        for k in range(columns):
            inside = (t >= edges[k]) & ((t < edges[k + 1]) if k < columns - 1 else
                                        (t <= edges[k + 1]))
            seg = y[inside]
            if not np.isfinite(seg).any():
                assert np.isnan(lo[k]) and np.isnan(hi[k])
                continue
            assert lo[k] == np.nanmin(seg) and hi[k] == np.nanmax(seg)
        finite = np.isfinite(y)
        col = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, columns - 1)
        assert np.all(lo[col][finite] <= y[finite]) and np.all(y[finite] <= hi[col][finite])


def test_the_overview_of_a_long_run_draws_the_energys_drift_and_no_curve_per_flight(
        tmp_path, monkeypatch):
    """An elastic ellipsoid with the point at rest in it over 200 s (about 450 impacts):
    the energy is conserved in flight and at every impact, so the drift drawn under the
    energy's parts is, at each flight's end, E - E(0) less the jumps at the impacts
    (NumPy on the run's own rows: E = T + U), relative to E(0); its end is the summary's
    residual.  The |K| drift of all the flights is one series (a plot call per flight
    took 20 s for 21,834 impacts), and the energy's parts are bands of about one column
    per pixel, not thousands of rows."""
    from matplotlib.figure import Figure

    from derive.runtime.plots import overview
    doc = {"name": "long elastic",
           "body": {"mass": 1.0, "inertia": [0.05, 0.08, 0.1], "shape": "ellipsoid",
                    "semi_axes": [0.4, 0.3, 0.2]},
           "point": {"mass": 0.3, "law": ["0.1", "0.05", "0.03"]},
           "plane": {"restitution": 1.0},
           "initial": {"com": [0.0, 0.0, 1.0], "omega": [2.0, -1.0, 3.0],
                       "quaternion": [0.9, 0.3, 0.2, 0.1]},
           "run": {"duration": 200.0}}
    run = derive.simulate(doc)
    assert run.status == "done" and len(run.impacts) > 300
    # the drift from the rows: E at each flight's end, less E(0) and the impacts' jumps
    mo = motion(run)
    E = mo.T + mo.U
    jumps = np.zeros(len(E))
    for i, _ in event_rows(run):
        jumps[i + 1] += E[i + 1] - E[i]
    ends = [b - 1 for a, b, state in phases(run) if state == "flight" and b - a >= 2]
    expected = (E[ends] - E[0] - np.cumsum(jumps)[ends]) / abs(E[0])
    trace: list = []
    info = summary(run, mo, trace)
    t_d, drift = series.energy_drift(trace, float(E[0]), float(run.t[0]))
    assert np.allclose(t_d[1:], run.t[ends], rtol=0, atol=0)
    assert np.max(np.abs(drift[1:] - expected)) < 1e-14
    assert abs(drift[-1] - info["energy"]["residual"] / abs(E[0])) < 1e-15
    assert 1e-12 < abs(drift[-1]) < 1e-6      # a drift there is to draw: not round-off

    saved, save = [], Figure.savefig

    def keep(self, *args, **kwargs):
        saved.append(self)
        return save(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", keep)
    overview(run, mo, tmp_path / "overview.png", steps=run, energy_trace=trace)
    fig = saved[0]
    energy = next(ax for ax in fig.axes if ax.get_title().startswith("energy"))
    under = next(ax for ax in fig.axes if ax.get_ylabel() == "drift of E")
    black = [ln for ln in under.get_lines() if ln.get_color() == "k"]
    assert black and abs(np.asarray(black[-1].get_ydata())[-1] - drift[-1]) \
        <= 1e-3 * abs(drift[-1])             # (drawn per column: its last column's edge)
    width = energy.get_position().width * fig.get_figwidth() * 80
    assert len(energy.collections) >= 4                # a band per part (carrier, point,
    assert all(len(ln.get_xdata()) <= width + 2 for ln in energy.get_lines())  # U, E)
    lo, hi = energy.get_ylim()
    top = max(np.nanmax(ln.get_ydata()) for ln in energy.get_lines())
    assert hi - top > 0.03 * (hi - lo)                # the total off the frame's edge
    kdrift = next(ax for ax in fig.axes if "(E1.9)" in ax.get_title())
    assert len(kdrift.get_lines()) <= 4
