"""Outputs of `derive simulate`: plain column names, the uniform grid, positions and the
energy (against the definition through finite differences of the positions), the energy
balance, and the symbols of `derive equations`."""
from __future__ import annotations

import copy

import numpy as np
import pytest

import derive
from derive.runtime.motion import energy_balance, motion
from derive.runtime.outputs import write_all
from derive.scene import DEFAULT_SCENE, builtin_doc


def scene(**changes):
    doc = copy.deepcopy(builtin_doc())
    for key, value in changes.items():
        table, field = key.split("__")
        doc.setdefault(table, {})[field] = value
    return doc


def test_tables_have_plain_names_and_a_uniform_grid(tmp_path):
    result = derive.simulate(scene(run__output_dt=0.01))
    write_all(result, tmp_path, plot=False)
    data = np.genfromtxt(tmp_path / "trajectory.csv", delimiter=",", names=True)
    header = (tmp_path / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert list(data.dtype.names) == header                      # NumPy keeps them
    for name in ("dX_C", "X_O", "Z_P", "E_carrier", "E_point", "E_potential", "E", "h"):
        assert name in header
    assert not any("'" in h for h in header)
    assert np.allclose(np.diff(data["t"]), 0.01, rtol=0, atol=1e-12)
    events = (tmp_path / "events.csv").read_text().splitlines()
    assert len(events) - 1 == 2 * len(result.impacts)
    assert events[1].startswith("impact,before,") and events[2].startswith("impact,after,")
    assert (tmp_path / "impacts.csv").read_text().splitlines()[0] == "t,I,v_n_minus,v_n_plus"


def test_energy_against_the_definition_by_finite_differences():
    """1/2 M |V_O|^2 + 1/2 (omega, J_O omega) and 1/2 m |V_P|^2 with V_O, V_P from central
    differences of O and P, computed here from X_C, A and the law (E1.8a)."""
    dt = 1e-4
    doc = scene(run__output_dt=dt, run__duration=0.5, initial__com_velocity=[0.3, 0.2, 2.0])
    doc.pop("plane")                                     # free flight
    result = derive.simulate(doc)
    s = result.scene
    mo = motion(result)
    q = result.general
    A = q[:, 9:18].reshape(-1, 3, 3)
    r = s.law.jets(result.t)[[0, 3, 6]].T
    Ar = np.einsum("nij,nj->ni", A, r)
    r_O = q[:, 0:3] - s.m / (s.m + s.M) * Ar
    r_P = r_O + Ar
    V_O = (r_O[2:] - r_O[:-2]) / (2 * dt)
    V_P = (r_P[2:] - r_P[:-2]) / (2 * dt)
    w = q[1:-1, 6:9]
    T_carrier = 0.5 * s.M * np.sum(V_O ** 2, axis=1) + 0.5 * np.sum(w * np.array(s.J) * w,
                                                                    axis=1)
    T_point = 0.5 * s.m * np.sum(V_P ** 2, axis=1)
    assert np.allclose(mo.T_carrier[1:-1], T_carrier, rtol=1e-6, atol=1e-9)
    assert np.allclose(mo.T_point[1:-1], T_point, rtol=1e-6, atol=1e-9)
    assert np.allclose(mo.r_O, r_O) and np.allclose(mo.r_P, r_P)
    assert np.allclose(mo.U, (s.m + s.M) * s.g * q[:, 2])


@pytest.mark.parametrize("plane", [False, True])
def test_energy_is_conserved_with_the_point_at_rest(plane):
    """A point at rest in the body: a rigid body; free flight and e = 1 conserve E."""
    doc = scene(point__law=["0.1", "0.05", "-0.02"], plane__restitution=1.0)
    if not plane:
        doc.pop("plane")
    result = derive.simulate(doc)
    mo = motion(result)
    E = mo.E
    assert np.max(np.abs(E - E[0])) < 1e-8 * E[0]
    bal = energy_balance(result, mo)
    assert abs(bal["at_impacts"]) < 1e-10 and bal["drive_work_in_flight"] == 0.0
    assert abs(bal["residual"]) < 1e-8 * E[0]
    assert (len(result.impacts) > 0) == plane


def test_energy_balance_closes_with_a_moving_point():
    """With the point driven, E changes by the drive's work (its power from E1.7 solved
    with NumPy) and at impacts by I (v_n- + v_n+)/2 plus the drive's impulsive work;
    e = 1 does not conserve E then."""
    for e in (0.9, 1.0):
        result = derive.simulate(scene(plane__restitution=e, run__output_dt=0.002))
        bal = energy_balance(result, motion(result))
        assert abs(bal["at_impacts"] - bal["restitution_at_impacts"]
                   - bal["drive_work_at_impacts"]) < 1e-9
        assert abs(bal["residual"]) < 1e-8 * abs(bal["start"])
        if e == 1.0:
            assert abs(bal["restitution_at_impacts"]) < 1e-10
            assert abs(bal["drive_work_at_impacts"]) > 1e-3


def test_energy_balance_closes_on_the_built_in_scene_whatever_its_rows():
    """The balance is the run's, not its rows': on the solver's steps (a tenth of a second
    apart), on a coarse grid and on a fine one it closes to the same 1e-12 (the rows are
    resampled for the quadrature; the steps and events are the run's own)."""
    residuals = []
    for dt in (0.0, 0.25, 0.05, 0.001):
        result = derive.simulate(scene(run__output_dt=dt))
        bal = energy_balance(result, motion(result))
        residuals.append(bal["residual"] / bal["start"])
        assert bal["quadrature_rows"] >= 32 * result.scene.duration / \
            result.scene.law_summary.time_scale
    assert max(map(abs, residuals)) < 1e-12, residuals


def test_energy_balance_closes_on_random_bouncing_scenes():
    """Property over seeded random bouncing scenes (spheres and offset ellipsoids, spins,
    e in [0, 1], accumulating impacts and resting contact, three methods, the general and
    the vertical model, rows on the solver's steps or a coarse grid): the balance closes
    to the run's tolerance.  (Before the rows were resampled for the quadrature, its
    residual reached 2e-3 of the energy on such scenes: the quadrature's error.)"""
    from derive.verify.generators import random_scene
    rng = np.random.default_rng(20261122)
    worst = 0.0
    for k in range(60):
        doc = random_scene(rng, max_duration=3.0,
                           method=str(rng.choice(["lie", "dop853", "dopri5"])))
        if k % 3 == 1:
            doc["run"]["outputs"] = ["omega", "impacts"]      # the vertical model if it can
        if k % 3 == 2:
            doc["run"]["output_dt"] = float(rng.uniform(0.02, 0.3))
        result = derive.simulate(doc)
        bal = energy_balance(result, motion(result))
        scale = max(abs(bal["start"]), abs(bal["end"]), abs(bal["drive_work_in_flight"])
                    + abs(bal["drive_work_in_contact"]) + abs(bal["at_impacts"]))
        rel = abs(bal["residual"]) / scale
        worst = max(worst, rel / (doc["run"]["rtol"] + 1e-10))
        assert rel < 3 * doc["run"]["rtol"] + 1e-10, (k, doc, bal)
    assert worst > 1e-3        # the bound is not vacuous: residuals scale with the tolerance


def test_energy_balance_of_a_run_that_starts_with_an_impact():
    """A hopper that starts on the plane with its point moving down: an impact at t0, so
    the first rows share one instant.  The balance is finite, closes, and NumPy warns of
    nothing (the command printed a RuntimeWarning and a NaN residual; found by a new-user
    trial)."""
    import warnings
    doc = {"name": "hopper e=0",
           "body": {"mass": 1.0, "inertia": [0.05, 0.05, 0.06], "shape": "sphere",
                    "radius": 0.3},
           "point": {"mass": 1.0, "law": ["0.01*sin(2*t)", "0", "0.1*sin(15*t)"]},
           "plane": {"restitution": 0.0},
           "initial": {"com": [0, 0, 0.30], "omega": [0, 0, 0.5]},
           "run": {"duration": 3.0}}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = derive.simulate(doc)
        assert result.events[0]["t"] == result.scene.t0
        bal = energy_balance(result, motion(result))
    assert abs(bal["residual"]) < 1e-9 * abs(bal["start"])


def test_an_interrupted_write_leaves_whole_files(tmp_path, monkeypatch):
    """Ctrl-C while the outputs are written (here: after the tables, before the summary)
    leaves the files of the earlier run whole and no half-written table or staging
    folder; a finished write replaces them."""
    import derive.runtime.outputs as outputs
    write_all(derive.simulate(scene()), tmp_path, plot=False)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    longer = derive.simulate(scene(run__duration=6.0))

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    with monkeypatch.context() as m:
        m.setattr(outputs, "summary", interrupted)
        with pytest.raises(KeyboardInterrupt):
            write_all(longer, tmp_path, plot=False)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    written = write_all(longer, tmp_path, plot=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(before)
    assert all(p.parent == tmp_path for p in written)
    assert (tmp_path / "trajectory.csv").read_bytes() != before["trajectory.csv"]


def test_a_terminated_command_leaves_whole_files(tmp_path):
    """`derive simulate` killed by SIGTERM (a job scheduler, `timeout`) while it works:
    exit 143, "terminated", the earlier run's files whole, no staging folder left."""
    import signal
    import subprocess
    import sys
    import time
    out = tmp_path / "out"
    write_all(derive.simulate(scene()), out, plot=False)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    long = tmp_path / "long.toml"
    text = DEFAULT_SCENE.replace("duration = 5.0", "duration = 30000.0")
    assert text != DEFAULT_SCENE
    long.write_text(text)
    proc = subprocess.Popen([sys.executable, "-m", "derive", "simulate", str(long), "-o",
                             str(out), "--no-plots"], stderr=subprocess.PIPE, text=True)
    assert "simulating" in proc.stderr.readline()               # the run has begun
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    err = proc.stderr.read()
    assert proc.wait(timeout=60) == 143, err
    assert "terminated" in err and "Traceback" not in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_every_printed_symbol_of_the_equations_is_defined():
    from derive.equations import BUILDERS, compact, derived, render_text, undefined_symbols
    for eid in BUILDERS:
        entry = derived(eid)
        assert undefined_symbols(entry) == [], eid
        short = compact(entry)                       # raises if it differs from entry
        assert undefined_symbols(short) == [], eid
        text = render_text(entry)
        assert "Derivative(" not in text and "(t)" not in text, eid


def test_outputs_of_a_run_with_resting_contact(tmp_path):
    """A spinning ball that lands, rests and lifts off: the outputs are written (the
    energy balance evaluates the contact equations on a session of the run's own), and
    the drive's work in contact is the same by the general and the vertical model.
    (Regression: every such run of `derive simulate` ended in an AttributeError.)"""
    doc = {"name": "contact-spin",
           "body": {"mass": 1.0, "inertia": [0.1, 0.12, 0.14], "shape": "sphere",
                    "radius": 0.5},
           "point": {"mass": 0.2, "law": ["0.05*sin(7*t)", "0", "0.3*sin(20*t)"]},
           "plane": {"restitution": 0.3},
           "initial": {"com": [0.0, 0.0, 0.7], "omega": [0.3, 0.0, 0.5]},
           "run": {"duration": 1.0, "output_dt": 0.002}}
    work = {}
    for model, outputs in (("general", ["pose", "impacts"]), ("vertical", ["omega", "impacts"])):
        d = copy.deepcopy(doc)
        d["run"].update(model=model, outputs=outputs)
        result = derive.simulate(d)
        assert any(e["kind"] == "contact" for e in result.events)
        assert any(e["kind"] == "lift_off" for e in result.events)
        write_all(result, tmp_path / model, plot=False)
        bal = energy_balance(result, motion(result))
        work[model] = bal["drive_work_in_contact"]
        assert work[model] is not None and abs(work[model]) > 0.1
        assert abs(bal["residual"]) < 1e-9 * abs(bal["start"])
        assert (tmp_path / model / "summary.json").is_file()
    assert abs(work["general"] - work["vertical"]) < 1e-9


def test_a_base_run_writes_the_impacts_header_of_its_rough_plane(tmp_path):
    """Every run writes impacts.csv: a base run (no impacts: its face stays on the plane)
    its header alone, with the columns of the rough plane it stands on, which a flight on
    that plane writes (a base run's hand-over, here the built-in ball given friction); it
    had written the smooth plane's four."""
    from pathlib import Path
    example = Path(__file__).parents[1] / "derive" / "scene" / "examples"
    base = derive.simulate(str(example / "capsule-crawler.toml"))
    rough = derive.simulate(scene(plane__friction=0.3, run__duration=1.0))
    assert (base.model, rough.model) == ("base", "rough") and len(rough.impacts) > 0
    for name, result in (("base", base), ("rough", rough)):
        write_all(result, tmp_path / name, plot=False)
    lines = (tmp_path / "base" / "impacts.csv").read_text().splitlines()
    assert lines == (tmp_path / "rough" / "impacts.csv").read_text().splitlines()[:1]
    assert lines[0].startswith("t,I,v_n_minus,v_n_plus,P_X,P_Y,")
    data = np.genfromtxt(tmp_path / "base" / "impacts.csv", delimiter=",", names=True)
    assert data.size == 0 and list(data.dtype.names) == lines[0].split(",")


def test_a_write_removes_what_an_earlier_run_left(tmp_path):
    """The folder holds one run: plots or a CSV table of an earlier run that this write
    did not replace are removed (a new-user trial found an npz summary beside CSV tables
    and plots of another scene); files that are not outputs are kept."""
    (tmp_path / "notes.txt").write_text("mine")
    write_all(derive.simulate(scene()), tmp_path, plot=False)
    assert (tmp_path / "trajectory.csv").is_file()
    write_all(derive.simulate(scene(run__duration=1.0)), tmp_path, plot=False, fmt="npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "run.npz",
                                                          "summary.json"]


@pytest.mark.parametrize("uniform", [True, False])
def test_energy_balance_of_a_tabulated_law(uniform):
    """A table's acceleration has a kink at every knot, and so has the drive's power: on
    equally spaced knots the balance's rows land on the knots and the quadrature stops
    there (1e-12 of the energy); on uneven knots rows four times closer bound the
    rule across a kink (3e-7 measured: the balance is coarser there).  It was 1.1e-7
    and 1.7e-6 relative on a new-user trial's table and planned scenes."""
    from cases import table_flight
    period = 2 * np.pi / 3
    u = np.linspace(0.0, 1.0, 41)
    ts = period * (u if uniform else u + 0.3 * u * (1 - u) * np.sin(7 * u))
    result = derive.simulate(table_flight(ts, 2.5 * period))
    bal = energy_balance(result, motion(result))
    assert abs(bal["drive_work_in_flight"]) > 1e-4
    assert abs(bal["residual"]) < (1e-12 if uniform else 1e-6) * abs(bal["start"]), bal


def test_csv_reads_back_bit_for_bit_across_chunks(tmp_path, monkeypatch):
    """Rows written in chunks (memory bounded on long runs), text columns first, read back
    by the csv module to the same doubles; progress reaches 1."""
    import csv

    from derive.runtime import outputs
    monkeypatch.setattr(outputs, "CSV_CHUNK", 7)
    rng = np.random.default_rng(5)
    rows = rng.standard_normal((50, 4)) * 10.0 ** rng.integers(-300, 300, (50, 4))
    rows[3, 1], rows[4, 2] = 0.0, -0.0
    text = {"event": [f"e{k}" for k in range(50)], "side": ["before", "after"] * 25}
    told = []
    path = tmp_path / "t.csv"
    outputs.write_csv(path, ["a", "b", "c", "d"], rows, text, progress=told.append)
    with open(path, newline="") as fh:
        back = list(csv.reader(fh))
    assert back[0] == ["event", "side", "a", "b", "c", "d"]
    assert [tuple(r[:2]) for r in back[1:]] == list(zip(*text.values()))
    got = np.array([[float(x) for x in r[2:]] for r in back[1:]])
    assert np.array_equal(got.view(np.uint64), rows.view(np.uint64))   # signs of zero too
    assert told[-1] == 1.0 and len(told) == 8 and told == sorted(told)
    pick = np.flatnonzero(rng.random(50) < 0.6)                # rows chosen without a copy
    outputs.write_csv(tmp_path / "a.csv", ["a", "b", "c", "d"], rows, select=pick)
    outputs.write_csv(tmp_path / "b.csv", ["a", "b", "c", "d"], rows[pick])
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_drawn_rows_keep_every_extreme_of_every_time_column():
    """Over random series (spikes, NaN, constants) the rows chosen for a picture hold, in
    each time column, the series' lowest and highest value and the column's first and
    last row; a short run keeps all its rows."""
    from derive.runtime.drawing import drawn_rows
    rng = np.random.default_rng(11)
    for trial in range(40):
        n = int(rng.integers(50, 60_000))
        t = np.sort(rng.uniform(0.0, rng.uniform(1e-3, 1e3), n))
        t[: int(rng.integers(0, 5))] = t[0]                    # rows of one instant
        ys = [rng.standard_normal(n).cumsum(), np.full(n, 2.0),
              np.sin(rng.uniform(1, 1e4) * t)]
        ys[0][rng.integers(0, n, 3)] += rng.standard_normal(3) * 1e3       # spikes
        ys[2][rng.integers(0, n, 2)] = np.nan
        bins = int(rng.integers(5, 400))
        idx = drawn_rows(t, *ys, bins=bins)
        assert np.all(np.diff(idx) > 0) and idx[0] == 0 and idx[-1] == n - 1
        if n <= 4 * bins:
            assert len(idx) == n
            continue
        assert len(idx) <= bins * (2 + 2 * len(ys))
        edges = np.searchsorted(t, np.linspace(t[0], t[-1], bins + 1)[1:-1])
        for lo, hi in zip(np.r_[0, edges], np.r_[edges, n]):
            if hi <= lo:
                continue
            chosen = idx[(idx >= lo) & (idx < hi)]
            assert lo in chosen and hi - 1 in chosen
            for y in ys:
                seg = y[lo:hi]
                if np.all(np.isnan(seg)):
                    continue
                assert np.nanmin(seg) == np.nanmin(y[chosen])
                assert np.nanmax(seg) == np.nanmax(y[chosen])


def test_pictures_of_a_run_with_many_rows(tmp_path, monkeypatch):
    """A fast law on a fine grid (3 10^5 rows): every curve of the pictures is drawn from
    a few thousand rows (matplotlib's renderer overflowed on millions, after minutes of
    drawing); the pictures are written."""
    from matplotlib.axes import Axes
    doc = builtin_doc()
    doc["point"]["law"] = ["0.1*sin(2000*t)", "0.1", "0.05*cos(2*t)"]
    doc["run"].update(duration=1.0, output_dt=3e-6)
    result = derive.simulate(doc)
    assert result.status == "done" and len(result.t) > 300_000
    longest = [0]
    plot = Axes.plot

    def counted(self, *args, **kw):
        lines = plot(self, *args, **kw)
        longest[0] = max([longest[0], *(len(ln.get_xdata()) for ln in lines)])
        return lines
    monkeypatch.setattr(Axes, "plot", counted)
    written = write_all(result, tmp_path, plot=True, animation=True, fmt="npz")
    assert {p.name for p in written} >= {"overview.png", "motion.gif"}
    assert 0 < longest[0] <= 2000 * (2 + 2 * 6)       # six series in one column of time at most


@pytest.mark.parametrize("duration", [10.0, 60.0])
def test_the_times_written_beside_the_bodies_overlap_nothing(tmp_path, monkeypatch,
                                                             duration):
    """In the 3-D panel of overview.png each body drawn has its time written beside it;
    a time's box (as matplotlib's renderer lays it out) overlaps no other time and no
    other body (in a 10 s run of the built-in scene 't = 10.00 s' was written over the
    body at 3.23 s; at 60 s the times overlapped one another)."""
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure
    from matplotlib.transforms import Bbox
    saved, save = [], Figure.savefig

    def keep(self, *args, **kwargs):
        saved.append(self)
        return save(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", keep)
    doc = builtin_doc()
    doc["run"]["duration"] = duration
    write_all(derive.simulate(doc), tmp_path, plot=True, animation=False)
    fig = saved[0]
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    times = [t for t in ax.texts if t.get_text().startswith("t = ")]
    boxes = [t.get_window_extent(renderer) for t in times]
    outlines = next(c for c in ax.collections if isinstance(c, PolyCollection)
                    and len(c.get_paths()) == len(times) and c.get_alpha() == 0.45)
    bodies = [Bbox.from_extents(*ax.transData.transform(p.vertices).min(axis=0),
                                *ax.transData.transform(p.vertices).max(axis=0))
              for p in outlines.get_paths()]
    assert len(times) >= 3, [t.get_text() for t in times]
    for k, box in enumerate(boxes):
        for m in range(len(boxes)):
            if m != k:
                assert not box.overlaps(boxes[m]), (times[k].get_text(), times[m].get_text())
                assert not box.overlaps(bodies[m]), (times[k].get_text(), m)


def robot_flight_time(tmp_path) -> float:
    """The spherical robot's time in flight (before its first contact), from its events:
    0, put on the floor at rest (it had fallen a few ns by round-off and hit it)."""
    from importlib import resources
    robot = derive.simulate(str(resources.files("derive.scene") / "examples"
                                / "spherical-robot.toml"))
    return next(ev["t"] for ev in robot.events if ev["kind"] == "contact") - robot.t[0]


def test_no_scale_text_sits_on_a_title_and_no_panel_is_left_empty(tmp_path, monkeypatch):
    """The spherical robot's overview.png: the height of S (1e-11 m) had its scale written
    above the axes, over the title; the scale now sits in the axis label.  Its |K| panel
    (E1.9 holds in flight, and the robot never flies) drew empty log axes; it now says
    why it is empty."""
    from importlib import resources

    from matplotlib.figure import Figure
    saved, save = [], Figure.savefig

    def keep(self, *args, **kwargs):
        saved.append(self)
        return save(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", keep)
    robot = str(resources.files("derive.scene") / "examples" / "spherical-robot.toml")
    write_all(derive.simulate(robot), tmp_path, plot=True, animation=False)
    fig = saved[0]
    renderer = fig.canvas.get_renderer()
    labels = []
    for ax in fig.axes:
        offset = ax.yaxis.get_offset_text()
        if offset.get_visible() and offset.get_text():
            assert not offset.get_window_extent(renderer).overlaps(
                ax.title.get_window_extent(renderer)), (ax.get_title(), offset.get_text())
        labels.append(ax.get_ylabel())
    assert any("(ticks x 1e-11)" in label for label in labels), labels
    # put on the floor at rest it begins in contact, no impact (its 1e-5 N s impulses
    # were a start's round-off fall: tests/test_trial_findings.py); the panel says so
    impulses = next(ax for ax in fig.axes if ax.get_title().startswith("impulses"))
    assert [t.get_text() for t in impulses.texts] == ["no impacts"]
    drift = next(ax for ax in fig.axes if "(E1.9)" in ax.get_title())
    assert robot_flight_time(tmp_path) == 0.0           # in contact from t0
    assert [t.get_text() for t in drift.texts] == ["E1.9 holds in flight; this run never flies"]


def test_json_outputs_are_strict_json():
    """summary.json, plan.json, control.json, sweep.json, ...: one writer, strict JSON (a
    trial found `"continuity_with_exact_flow": NaN` in plan.json, which JSON parsers other
    than Python's refuse): NaN and infinities are null, NumPy values plain."""
    import json as std_json

    from derive import json_text
    text = json_text.dumps({"a": float("nan"), "b": [1.0, float("inf"), np.float64(2.5)],
                            "c": np.array([[1.0, np.nan]]), "d": (np.int64(3), True),
                            "e": {"f": -float("inf")}})
    def refuse(token):
        raise ValueError(token)
    assert std_json.loads(text, parse_constant=refuse) == {
        "a": None, "b": [1.0, None, 2.5], "c": [[1.0, None]], "d": [3, True],
        "e": {"f": None}}
    assert text.endswith("}\n")


def test_events_csv_has_every_event_of_the_api_with_its_modes(tmp_path):
    """A second trial found the hopper's events.csv without its 5 contact events (each
    begins at an impact, and the runtime records one pair of rows for both), and the
    impact's `after` row in sticking while Result.events says flight.  Now: two rows per
    event of Result.events, in its order, the kinds alike; on the rough plane an after
    row's mode is the event's, a before row's the previous event's; mode and stage are
    written as integer codes."""
    import csv
    from importlib import resources

    from derive import abi
    hopper = derive.simulate(str(resources.files("derive.scene") / "examples" / "hopper.toml"))
    write_all(hopper, tmp_path, plot=False)
    rows = list(csv.DictReader(open(tmp_path / "events.csv", encoding="utf-8")))
    assert len(rows) == 2 * len(hopper.events)
    assert [r["event"] for r in rows[::2]] == [ev["kind"] for ev in hopper.events]
    assert [r["side"] for r in rows[:2]] == ["before", "after"]
    assert sum(ev["kind"] == "contact" for ev in hopper.events) == 5
    for k, ev in enumerate(hopper.events):
        assert float(rows[2 * k]["t"]) == float(rows[2 * k + 1]["t"]) == ev["t"]
        assert rows[2 * k + 1]["mode"] == str(abi.index(abi.MODES, ev["mode"]))
        if k:
            assert rows[2 * k]["mode"] == str(abi.index(abi.MODES, hopper.events[k - 1]["mode"]))
    stages = [line.rsplit(",", 1)[1] for line in
              (tmp_path / "impacts.csv").read_text().splitlines()[1:]]
    assert stages and set(stages) <= {"0", "1", "2"}
    # the smooth plane: a contact that begins at an impact has its rows too
    doc = builtin_doc()
    doc["plane"]["restitution"] = 0.0
    smooth = derive.simulate(doc)
    write_all(smooth, tmp_path / "smooth", plot=False)
    rows = list(csv.DictReader(open(tmp_path / "smooth" / "events.csv", encoding="utf-8")))
    assert [r["event"] for r in rows[::2]] == [ev["kind"] for ev in smooth.events]
    assert "contact" in [ev["kind"] for ev in smooth.events]


def _overview_figure(source, tmp_path, monkeypatch):
    from matplotlib.figure import Figure
    saved, save = [], Figure.savefig

    def keep(self, *args, **kwargs):
        saved.append(self)
        return save(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", keep)
    write_all(derive.simulate(source), tmp_path, plot=True, animation=False)
    return saved[0]


def test_the_drift_panel_draws_an_exact_zero_at_round_off_not_as_a_spike(tmp_path,
                                                                         monkeypatch):
    """The built-in scene's |K| drift is exactly 0 at some steps' ends: a floor of 1e-17
    on the log axis drew each as a spike six decades down, breaking the curve (a new
    user's trial, issue 34).  Now an exact 0 sits at half an ulp of 1, the round-off of
    the relative difference, drawn and labelled; the axis spans the data, with ticks."""
    fig = _overview_figure(builtin_doc(), tmp_path, monkeypatch)
    drift = next(ax for ax in fig.axes if "(E1.9)" in ax.get_title())
    floor = np.finfo(float).eps / 2
    curves = [ln.get_ydata() for ln in drift.get_lines() if ln.get_color() == "C0"]
    assert curves and min(float(np.nanmin(y)) for y in curves) == floor   # (NaN: between flights)
    lo, hi = drift.get_ylim()
    assert floor / 2 < lo < floor and hi < 1e-13            # round-off, not a spike
    assert any("round-off" in t.get_text() for t in drift.texts)
    ticks = [v for v in drift.get_yticks() if lo <= v <= hi]
    assert len(ticks) >= 2


def test_a_body_dwarfed_by_its_path_is_also_drawn_enlarged(tmp_path, monkeypatch):
    """The spherical robot rolls 3.3 m with a radius of 0.2 m: its 3-D panel drew it tiny
    (issue 34); an inset now draws the last body drawn at its own scale.  The bouncing
    ball's panel, where the body is large, has none."""
    from importlib import resources
    robot = str(resources.files("derive.scene") / "examples" / "spherical-robot.toml")
    fig = _overview_figure(robot, tmp_path / "robot", monkeypatch)
    insets = fig.axes[0].child_axes
    assert len(insets) == 1 and "enlarged" in insets[0].get_title()
    (x0, x1), (y0, y1) = insets[0].get_xlim(), insets[0].get_ylim()
    assert abs((x1 - x0) - 2.8 * 0.2) < 0.05 and abs((y1 - y0) - (x1 - x0)) < 1e-12
    fig = _overview_figure(builtin_doc(), tmp_path / "ball", monkeypatch)
    assert not fig.axes[0].child_axes
