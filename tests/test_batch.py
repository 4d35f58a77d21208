"""Parameter studies: simulate_many against one simulate per variant, serial against
processes (bit for bit), refusals naming the variant and the field, and the CLI's
--set and --sweep."""
from __future__ import annotations

import copy
import json
import re
import subprocess
import sys

import numpy as np
import pytest

import derive
from derive.runtime.batch import BatchError, expand
from derive.scene import SceneError, builtin_doc


def _variant(doc: dict, **changes) -> dict:
    d = copy.deepcopy(doc)
    for name, value in changes.items():
        table, key = name.split("__")
        d[table][key] = value
    return d


def test_each_variant_equals_its_own_simulate():
    doc = builtin_doc()
    grid = {"body.mass": [0.8, 1.3], "plane.restitution": [0.3, 0.9]}
    batch = derive.simulate_many(doc, grid, workers=1, keep="result")
    assert len(batch.rows) == 4 and [set(v) for v in batch.variants] == [set(grid)] * 4
    for overrides, res in zip(batch.variants, batch.results):
        alone = derive.simulate(_variant(doc, body__mass=overrides["body.mass"],
                                         plane__restitution=overrides["plane.restitution"]))
        assert np.array_equal(res.q, alone.q) and np.array_equal(res.impacts, alone.impacts)


def _same(x, y) -> bool:
    return x == y or (isinstance(x, float) and np.isnan(x) and np.isnan(y))


def test_serial_threads_processes_and_whole_results_agree_bit_for_bit():
    """The summary rows a batch fills in C (serial, threads, processes) equal the rows read
    from each variant's whole Result, column by column (run_ms aside)."""
    doc = builtin_doc()
    variants = [{"initial.com[2]": 1.0 + 0.05 * k, "initial.omega[2]": 0.5 * k}
                for k in range(12)] + [{"plane.restitution": 0.0}]
    a = derive.simulate_many(doc, variants, workers=1)
    b = derive.simulate_many(doc, variants, workers=2)
    c = derive.simulate_many(doc, variants, workers=2, executor="processes")
    r = derive.simulate_many(doc, variants, workers=1, keep="result")
    assert (a.executor, b.executor, c.executor) == ("serial", "threads", "processes")
    assert a.rows[-1]["contacts"] == 1 and np.isfinite(a.rows[-1]["first_contact_t"])
    for other in (b, c, r):
        for ra, rb in zip(a.rows, other.rows):
            assert all(_same(ra[k], rb[k]) for k in ra if k != "run_ms"), (ra, rb)


def test_a_bad_variant_is_named():
    doc = builtin_doc()
    with pytest.raises(BatchError) as info:
        derive.simulate_many(doc, [{"body.mass": 1.0}, {"body.mass": -2.0}], workers=1)
    assert "variant 2:" in str(info.value) and "[body].mass" in str(info.value)  # from 1
    out = derive.simulate_many(doc, [{"body.mass": 1.0}, {"body.mass": -2.0}], workers=1,
                               strict=False)
    assert out.rows[0]["status"] == "done" and "[body].mass" in out.rows[1]["error"]
    with pytest.raises(SceneError, match="not a scene field"):
        derive.simulate_many(doc, [{"body.colour": 1.0}])


def test_grid_is_the_cartesian_product():
    v = expand({"a.b": [1, 2], "c.d": [3, 4, 5]})
    assert len(v) == 6 and v[0] == {"a.b": 1, "c.d": 3} and v[-1] == {"a.b": 2, "c.d": 5}


def test_cli_set_equals_the_edited_scene(tmp_path):
    out = tmp_path / "o"
    subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", "--no-plots", "-o",
                    str(out), "--set", "body.mass=1.3", "--set", "initial.com[2]=2.0"],
                   check=True, capture_output=True)
    rows = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    alone = derive.simulate(_variant(builtin_doc(), body__mass=1.3,
                                     initial__com=[0.0, 0.0, 2.0]))
    assert np.allclose(rows[-1, 1:19], alone.q[-1], rtol=0, atol=1e-12)


def test_cli_sweep_writes_one_row_per_variant(tmp_path):
    out = tmp_path / "s"
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", "-o", str(out),
                           "--sweep", "plane.restitution=0.2:0.8:4", "--sweep",
                           "body.mass=1,2"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    lines = (out / "sweep.csv").read_text().splitlines()
    assert len(lines) == 1 + 8
    # the axes as typed (they had been sorted: body_mass first)
    assert lines[0].startswith("variant,plane_restitution,body_mass,error,"), lines[0]
    assert [ln.split(",")[0] for ln in lines[1:]] == [str(k) for k in range(1, 9)]
    info = json.loads((out / "sweep.json").read_text())
    assert info["variants"] == 8 and info["statuses"] == {"done": 8}
    assert (out / "sweep.png").is_file()
    bad = subprocess.run([sys.executable, "-m", "derive", "simulate", "--sweep",
                          "plane.restitution=0.2:x:4", "-o", str(tmp_path / "b")],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "--sweep" in bad.stderr and "Traceback" not in bad.stderr
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize("args, field", [
    (["--set", "initial.com[x]=1"], "[initial].com[x]"),
    (["--set", "initial.com[]=1"], "[initial].com[]"),
    (["--set", "initial.com[1.5]=1"], "[initial].com[1.5]"),
    (["--set", "initial.com[0][0]=1"], "[initial].com[0][0]"),
    (["--set", "plane.restitution=1.0000001"], "1.0000001"),
    (["-o", "{file}"], "is a file"),
    (["-o", "{file}/sub"], "is not a folder"),
    (["-o", "/proc/derive-out"], "/proc"),   # writable to root by its bits, yet not
])
def test_cli_refuses_bad_overrides_and_output_folders_cleanly(tmp_path, args, field):
    """Each refused with exit 2, one message naming the field (the value as given, not
    rounded to the bound it breaks), no traceback, nothing written; the output folder
    is checked before the run.  (Found by a new-user trial: tracebacks, exit 1, and
    'must be in [0, 1] (got 1)'.)"""
    afile = tmp_path / "afile"
    afile.write_text("mine\n")
    args = [a.format(file=afile) for a in args]
    if "-o" not in args:
        args += ["-o", str(tmp_path / "out")]
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", "--no-plots",
                           *args], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert field in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]
    assert afile.read_text() == "mine\n"


@pytest.mark.parametrize("sweep, where", [("initial.com[7]=1,2", "[initial].com[7]"),
                                         ("name=1,2", "name")])
def test_a_sweep_no_variant_of_which_can_run_is_a_usage_error(tmp_path, sweep, where):
    """An override that is never valid refuses the sweep like an unknown field: exit 2,
    one line naming it, nothing written (it had written a table of refusals, exit 1)."""
    out = tmp_path / "s"
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", "--sweep", sweep,
                           "-o", str(out)], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert where in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize("spec, rule", [
    ("0.1:0.9:0", "n of lo:hi:n"), ("0.1:0.9:1.5", "n of lo:hi:n"),
    ("0.1:0.9:100001", "n of lo:hi:n"), ("0.1:0.9:" + "9" * 5000, "n of lo:hi:n"),
    ("0.1:0.9", "three parts"), ("0.1:0.9:3:4", "three parts"),
    ("a:0.9:3", "lo and hi"), ("0.1:nan:3", "finite"), ("", "separated by commas"),
    ("0.1,x", "separated by commas")])
def test_a_bad_sweep_range_says_which_part_is_wrong(spec, rule):
    """Each part of lo:hi:n is named (a bad n had been reported as 'values must be
    numbers', and 5000 digits ended in a traceback)."""
    from derive.scene.overrides import parse_sweep
    with pytest.raises(SceneError) as info:
        parse_sweep(f"plane.restitution={spec}")
    assert info.value.where == "--sweep" and rule in info.value.rule, str(info.value)
    assert parse_sweep("plane.restitution=0.1:0.9:3")[1] == pytest.approx([0.1, 0.5, 0.9])


@pytest.mark.parametrize("override", ["initial.com[" + "9" * 5000 + "]=1",
                                      "body.mass=" + "9" * 5000])
def test_overrides_with_5000_digits_are_one_line_errors(override):
    """Python refuses to read integers of more than 4300 digits with a ValueError of its
    own: an --set index or value that long had ended in a traceback."""
    from derive.scene import overrides, parse_scene
    doc = builtin_doc()
    with pytest.raises(SceneError) as info:
        name, value = overrides.parse_assignment(override)
        overrides.apply_to_doc(doc, name, value)
        parse_scene(doc)
    assert len(str(info.value)) < 300, str(info.value)


def test_a_scene_seeds_a_study_as_it_was_parsed():
    """simulate_many(scene) studies the Scene it is given: not the caller's dict as edited
    since, and not a Scene changed after parsing (refused, naming the field); a Scene from
    a study's results seeds another study."""
    import dataclasses
    doc = builtin_doc()
    doc["run"]["duration"] = 1.0
    res = derive.simulate(doc)
    doc["initial"]["com"][2] = 3.0                 # edited after the call
    doc["plane"]["restitution"] = 0.2
    rows = derive.simulate_many(res.scene, [{"run.g": 9.81}], workers=1).rows
    again = derive.simulate_many(copy.deepcopy(res.scene.doc), [{"run.g": 9.81}],
                                 workers=1).rows
    keys = [k for k in rows[0] if k != "run_ms"]
    assert all(_same(rows[0][k], again[0][k]) for k in keys) and res.scene.com[2] == 1.5
    assert rows[0]["Z_C_end"] < 1.5                # from 1.5, not the 3.0 edited since
    with pytest.raises(BatchError, match=r"scene: is a Scene whose e is not"):
        derive.simulate_many(dataclasses.replace(res.scene, e=0.5), [{"run.g": 9.81}])
    study = derive.simulate_many(res.scene, [{"initial.com[2]": 2.0}, {"body.mass": 2.0}],
                                 workers=1, keep="result")
    for r in study.results:
        assert r.scene.doc["initial"]["com"][2] in (1.5, 2.0)
        derive.simulate_many(r.scene, [{"run.g": 9.0}], workers=1)
    assert study.results[1].scene.doc["body"]["mass"] == 2.0


def test_one_string_of_a_list_is_overridden_like_a_vector_entry():
    """point.law[0] and run.outputs[1] set one string of the list (the CLI's --set did);
    the list is then checked whole."""
    doc = builtin_doc()
    doc["run"]["duration"] = 0.5
    b = derive.simulate_many(doc, [{"point.law[0]": "0.1*sin(t)"},
                                   {"run.outputs[1]": "omega"}], workers=1, keep="result")
    assert b.results[0].scene.law_text == ("0.1*sin(t)", "0.1", "0.05*cos(2*t)")
    assert b.results[1].scene.outputs == ("pose", "omega")
    with pytest.raises(BatchError, match=r"\[point\].law\[0\]"):
        derive.simulate_many(doc, [{"point.law[0]": "import os"}], workers=1)
    with pytest.raises(BatchError, match=r"\[point\].law\[3\]: has no entry 3"):
        derive.simulate_many(doc, [{"point.law[3]": "t"}], workers=1)


def test_an_attitude_override_replaces_the_base_scenes_other_attitude(tmp_path):
    """The built-in scene gives a quaternion; --set initial.matrix=... (or a variant's
    matrix) replaces it instead of being refused as 'either quaternion or matrix'."""
    rot = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", "--no-plots",
                           "--set", f"initial.matrix={json.dumps(rot)}", "-o",
                           str(tmp_path / "o")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    doc = builtin_doc()
    doc["run"]["duration"] = 0.5
    b = derive.simulate_many(doc, [{"initial.matrix": rot}, {"initial.quaternion":
                                                              [0.0, 0.0, 0.0, 1.0]}],
                             workers=1, keep="result")
    assert np.array_equal(b.results[0].scene.A0, np.array(rot))
    assert "quaternion" not in b.results[0].scene.doc["initial"]
    assert np.allclose(b.results[1].scene.A0, np.diag([-1.0, -1.0, 1.0]))


# ---- sweeps: the grid typed, missing values, the summary line, a Dask cluster ------------
def test_a_sweep_range_is_the_decimal_grid_typed():
    """lo:hi:n runs the decimal values lo + k (hi - lo)/(n - 1), each as the float nearest
    to it, checked against exact rational arithmetic (0.1:0.9:17 had run and written
    0.30000000000000004, np.linspace's value)."""
    from fractions import Fraction

    from derive.scene.overrides import parse_sweep
    rng = np.random.default_rng(11)
    cases = [("0.1", "0.9", 17), ("0", "1", 3), ("-2.5", "7.25", 40), ("1e-3", "2e-3", 11),
             ("0.9", "0.1", 9), ("0.3", "0.3", 4), ("2", "5", 1), ("0", "1", 7)]
    for _ in range(400):
        d = int(rng.integers(0, 5))
        lo, hi = (f"{v:.{d}f}" for v in rng.uniform(-20, 20, 2))
        cases.append((lo, hi, int(rng.integers(1, 80))))
    for lo, hi, n in cases:
        a, b = Fraction(lo), Fraction(hi)
        want = [float(a + (b - a) * k / (n - 1)) for k in range(n)] if n > 1 else [float(a)]
        assert parse_sweep(f"body.mass={lo}:{hi}:{n}")[1] == want, (lo, hi, n)
    assert parse_sweep("plane.restitution=0.1:0.9:17")[1][4] == 0.3


def test_missing_values_of_a_partly_refused_study_are_missing(tmp_path):
    """A refused row has no status, counts or times, and a row that ran no error: missing,
    not the string 'nan', and the counts stay integers (column: masked arrays for numbers,
    object arrays with None for text; to_csv: empty cells), against one simulate."""
    import csv

    from derive.runtime.batch import SUMMARY_COLUMNS
    doc = builtin_doc()
    out = derive.simulate_many(doc, [{"body.mass": 1.3}, {"body.mass": -2.0}], workers=1,
                               strict=False)
    alone = derive.simulate(_variant(doc, body__mass=1.3))
    status, error = out.column("status"), out.column("error")
    assert status.dtype == object and status.tolist() == [alone.status, None]
    assert error.dtype == object and error[0] is None and "[body].mass" in error[1]
    assert out.column("model").tolist() == [alone.model, None]
    for name in ("impacts", "contacts", "lift_offs", "steps", "rhs_evaluations"):
        col = out.column(name)
        assert isinstance(col, np.ma.MaskedArray) and col.dtype.kind == "i", (name, col)
        assert col.mask.tolist() == [False, True] and col[0] == alone.stats[name]
    for name in ("t_end", "min_height", "first_contact_t", "Z_C_end", "run_ms"):
        col = out.column(name)
        assert isinstance(col, np.ma.MaskedArray) and col.dtype == float
        assert col.mask.tolist() == [False, True], name
    assert out.column("t_end")[0] == alone.t[-1]
    assert out.column("min_height")[0] == alone.min_height
    assert out.column("body.mass").tolist() == [1.3, -2.0]
    full = derive.simulate_many(doc, {"body.mass": [1.0, 2.0]}, workers=1)
    assert full.column("steps").dtype.kind == "i" and not full.column("steps").mask.any()
    with pytest.raises(BatchError, match="status"):
        out.column("impact")
    out.to_csv(tmp_path / "b.csv")
    header, ran, refused = list(csv.reader(open(tmp_path / "b.csv", encoding="utf-8")))
    assert ran[header.index("error")] == "" and refused[header.index("error")] != ""
    assert ran[header.index("impacts")] == str(alone.stats["impacts"])
    assert all(refused[header.index(c)] == "" for c in SUMMARY_COLUMNS)


def _no_nan(text: str) -> dict:
    def refuse(name):
        raise ValueError(f"{name} is not JSON")
    return json.loads(text, parse_constant=refuse)


def test_the_summary_of_a_partly_refused_sweep_says_what_ran(tmp_path):
    """'2 variants ... on serial (1 worker)' had counted the refused variant as run: the
    line says how many ran and where, and how many were refused; sweep.csv leaves the
    refused row's cells empty and sweep.json is strict JSON."""
    import csv
    out = tmp_path / "s"
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", "--no-plots",
                           "--sweep", "plane.restitution=0.5,1.5", "-o", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 1, proc.stderr
    first = proc.stdout.splitlines()[0]
    assert "1 ran" in first and "1 refused" in first and "worker" not in first, first
    header, ran, refused = list(csv.reader(open(out / "sweep.csv", encoding="utf-8")))
    assert ran[header.index("error")] == "" and ran[header.index("status")] == "done"
    assert refused[header.index("status")] == "" and refused[header.index("impacts")] == ""
    info = _no_nan((out / "sweep.json").read_text())
    assert info["statuses"] == {"done": 1, "refused": 1} and info["variants"] == 2


@pytest.mark.parametrize("args, rule", [
    (["--scheduler", "tcp://127.0.0.1:9"], "with --sweep"),
    (["--sweep", "plane.restitution=0.3,0.6", "--workers", "2", "--scheduler",
      "tcp://127.0.0.1:9"], "--workers"),
])
def test_a_scheduler_needs_a_sweep_and_no_workers(tmp_path, args, rule):
    """--scheduler runs a sweep on a Dask cluster: alone, or with --workers, it is refused
    in one line (exit 2, nothing written) before anything is tried."""
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", *args, "-o",
                           str(tmp_path / "o")], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert "--scheduler" in proc.stderr and rule in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


@pytest.mark.parametrize("args, rule", [
    (["--workers", "2"], "goes only with --sweep"),
    (["--sweep", "plane.restitution=0.3,0.6", "--workers", "0"], "must be >= 1 (got 0)"),
    (["--sweep", "plane.restitution=0.3,0.6", "--workers", "-3"], "must be >= 1 (got -3)"),
])
def test_workers_are_checked(tmp_path, args, rule):
    """--workers counts a sweep's local threads: without --sweep, or below 1, it is refused
    in one line (exit 2, nothing written)."""
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", *args, "-o",
                           str(tmp_path / "o")], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert "--workers" in proc.stderr and rule in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


@pytest.fixture(scope="module")
def dask_cluster():
    """A local Dask cluster of two single-threaded worker processes, with a scheduler
    plugin that counts the tasks that finished (the count the study reports is checked
    against the scheduler's own)."""
    distributed = pytest.importorskip("distributed")
    from distributed.diagnostics.plugin import SchedulerPlugin

    class Finished(SchedulerPlugin):
        def __init__(self):
            self.keys = set()

        def transition(self, key, start, finish, *args, **kwargs):
            if finish == "memory":
                self.keys.add(key)

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        plugin = Finished()
        cluster.scheduler.add_plugin(plugin)
        yield cluster, plugin


def test_a_cli_sweep_on_a_dask_cluster_equals_the_local_one(tmp_path, dask_cluster):
    """derive simulate --sweep ... --scheduler: the same sweep.csv as on local threads (the
    C time aside), in a few tasks of many variants each (a task costs Dask more than a
    run of the C); simulate_many(scheduler=...) likewise."""
    import csv
    cluster, finished = dask_cluster
    sweep = ["--sweep", "plane.restitution=0.1:0.9:17", "--sweep", "body.mass=0.5:2:30"]
    tables = {}
    for name, where in (("local", ["--workers", "2"]),
                        ("dask", ["--scheduler", cluster.scheduler_address])):
        finished.keys.clear()
        proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-q", "--no-plots",
                               *sweep, *where, "-o", str(tmp_path / name)],
                              capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        rows = list(csv.reader(open(tmp_path / name / "sweep.csv", encoding="utf-8")))
        ms = rows[0].index("run_ms")
        tables[name] = [r[:ms] + r[ms + 1:] for r in rows]
        info = _no_nan((tmp_path / name / "sweep.json").read_text())
        assert info["variants"] == 17 * 30 == len(rows) - 1
    assert tables["dask"] == tables["local"]
    assert info["executor"] == "dask" and info["workers"] == 2
    assert 1 <= info["tasks"] <= 2 * info["workers"] and info["tasks"] == len(finished.keys)
    # what readying the runtime library cost on the workers, said either way
    assert "Dask" in proc.stdout and ("worker's first task" in proc.stdout
                                      or "ready in under 0.01 s" in proc.stdout), proc.stdout

    doc = builtin_doc()
    grid = {"plane.restitution": [0.2, 0.5, 0.8], "initial.com[2]": list(np.linspace(1, 2, 40))}
    finished.keys.clear()
    remote = derive.simulate_many(doc, grid, scheduler=cluster.scheduler_address)
    here = derive.simulate_many(doc, grid, workers=2)
    assert remote.executor == "dask" and 1 <= remote.tasks <= 4 == 2 * remote.workers
    assert remote.tasks == len(finished.keys)
    for ra, rb in zip(here.rows, remote.rows):
        assert all(_same(ra[k], rb[k]) for k in ra if k != "run_ms"), (ra, rb)


def _drawn_figure(monkeypatch, draw):
    """The matplotlib Figure that ``draw()`` saves (drawn, so its labels are laid out)."""
    from matplotlib.figure import Figure
    saved, save = [], Figure.savefig

    def keep(self, *args, **kwargs):
        saved.append(self)
        return save(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", keep)
    draw()
    assert len(saved) == 1
    saved[0].canvas.draw()
    return saved[0]


def _ticks(axis, lo, hi):
    """(position, label) of the ticks of a matplotlib axis inside its limits."""
    return [(t.get_loc(), t.label1.get_text()) for t in axis.get_major_ticks()
            if lo - 1e-9 <= t.get_loc() <= hi + 1e-9 and t.label1.get_visible()]


@pytest.mark.parametrize("grid", [
    {"point.mass": [0.2, 0.5], "plane.restitution": [0.3, 0.6, 0.9]},
    {"body.mass": [0.5, 1.0, 4.0], "plane.restitution": [0.1, 0.15, 0.8, 0.9]},
    {"plane.restitution": [round(0.1 + 0.025 * k, 3) for k in range(33)],
     "body.mass": [1.0, 1.1]},
])
def test_a_sweep_map_has_a_cell_centred_on_each_value_swept(tmp_path, monkeypatch, grid):
    """sweep.png's map of two swept fields: one cell per variant, centred on a tick that
    says its value, coloured by that variant's impacts (two point masses had been drawn
    as cells from 0.05 to 0.65 with ticks at 0.1, ..., 0.6, none of them swept)."""
    from matplotlib.collections import QuadMesh

    from derive.runtime.sweep_plot import sweep_plot
    doc = builtin_doc()
    doc["run"]["duration"] = 2.0
    batch = derive.simulate_many(doc, grid, workers=1)
    fig = _drawn_figure(monkeypatch, lambda: sweep_plot(batch, grid, tmp_path))
    ax = next(a for a in fig.axes if any(isinstance(c, QuadMesh) for c in a.collections))
    mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
    corners = mesh.get_coordinates()                        # (ny + 1, nx + 1, 2)
    xs, ys = (list(v) for v in grid.values())
    assert corners.shape == (len(ys) + 1, len(xs) + 1, 2)
    centres_x = 0.5 * (corners[0, 1:, 0] + corners[0, :-1, 0])
    centres_y = 0.5 * (corners[1:, 0, 1] + corners[:-1, 0, 1])
    impacts = np.asarray(mesh.get_array()).reshape(len(ys), len(xs))
    for i, x in enumerate(xs):
        for j, y in enumerate(ys):
            k = i * len(ys) + j
            assert batch.variants[k] == dict(zip(grid, (x, y)))
            assert impacts[j, i] == batch.rows[k]["impacts"]
    for axis, centres, values, lim in ((ax.xaxis, centres_x, xs, ax.get_xlim()),
                                       (ax.yaxis, centres_y, ys, ax.get_ylim())):
        ticks = _ticks(axis, *sorted(lim))
        assert 2 <= len(ticks) <= 12 or len(ticks) == len(values), ticks
        if len(values) <= 12:
            assert len(ticks) == len(values)
        for loc, text in ticks:
            k = int(np.argmin(np.abs(centres - loc)))
            assert loc == pytest.approx(centres[k], abs=1e-9) and float(text) == values[k]


def test_a_one_field_sweep_plot_has_its_values_as_ticks(tmp_path, monkeypatch):
    """The curves of one swept field: ticks at the values swept when they are few."""
    from derive.runtime.sweep_plot import sweep_plot
    grid = {"point.mass": [0.2, 0.5, 1.5]}
    doc = builtin_doc()
    doc["run"]["duration"] = 2.0
    batch = derive.simulate_many(doc, grid, workers=1)
    fig = _drawn_figure(monkeypatch, lambda: sweep_plot(batch, grid, tmp_path))
    ax = fig.axes[0]
    assert [float(t) for _, t in _ticks(ax.xaxis, *ax.get_xlim())] == grid["point.mass"]
    # the legend under the axes: in them it had sat on the first points (a trial)
    (legend,) = fig.legends
    assert not legend.get_window_extent().overlaps(ax.get_window_extent())
    assert [t.get_text() for t in legend.get_texts()] == ["impacts", "first resting contact"]


def _robot_doc() -> dict:
    import tomllib
    from importlib import resources
    return tomllib.loads((resources.files("derive.scene") / "examples" / "spherical-robot.toml")
                         .read_text(encoding="utf-8"))


def test_a_study_says_where_c_ends_and_how_far_it_went():
    """sweep.csv had Z_C_end but no X_C_end, and sweep.png drew two flat lines against
    friction (a new user's trial, issue 34).  X_C_end, Y_C_end and distance (the net
    horizontal displacement of C) are columns: in bulk they equal each variant's own run
    (the rough model's state), and on the smooth plane C moves uniformly (nothing
    horizontal acts): X_C0 + X_C0' t, the closed form, through the vertical model."""
    import derive
    doc = _robot_doc()
    b = derive.simulate_many(doc, {"plane.friction": [0.02, 0.1, 0.5]})
    for k, f in enumerate((0.02, 0.1, 0.5)):
        d = _robot_doc()
        d["plane"]["friction"] = f
        r = derive.simulate(d)
        x, y = r.general[-1, 0], r.general[-1, 1]
        assert b.column("X_C_end")[k] == x and b.column("Y_C_end")[k] == y
        assert abs(b.column("distance")[k] - np.hypot(x, y)) < 1e-15
    assert b.column("distance")[0] < 0.9 * b.column("distance")[2]   # it slips at 0.02
    smooth = builtin_doc()
    smooth["initial"].update(com_velocity=[0.3, -0.2, 0.0], omega=[0.0, 0.0, 1.0])
    smooth["point"]["law"] = ["0", "0", "0.05*sin(3*t)"]
    smooth["body"]["inertia"] = [0.02, 0.02, 0.03]
    smooth["run"]["outputs"] = ["omega", "height", "impacts"]
    s = derive.simulate_many(smooth, {"plane.restitution": [0.5, 0.9]})
    assert set(s.column("model")) == {"vertical"}
    t = s.column("t_end")
    assert np.allclose(s.column("X_C_end"), 0.3 * t, rtol=0, atol=1e-15)
    assert np.allclose(s.column("distance"), np.hypot(0.3, 0.2) * t, rtol=0, atol=1e-15)


def test_summary_json_has_the_travel(tmp_path):
    import json
    import subprocess
    import sys
    from importlib import resources
    robot = str(resources.files("derive.scene") / "examples" / "spherical-robot.toml")
    out = subprocess.run([sys.executable, "-m", "derive", "simulate", robot, "-o",
                          str(tmp_path), "--no-plots"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    travel = json.loads((tmp_path / "summary.json").read_text())["travel"]
    assert 3.2 < travel["distance"] == travel["X_C_end"] < 3.4
    assert abs(travel["path_length"] - travel["distance"]) < 1e-9   # a straight roll
    # and the CLI says it in words, the same number
    said = re.search(r"C travelled (\S+) m horizontally \(from its start to X_C = (\S+),",
                     out.stdout)
    assert said, out.stdout
    assert float(said[1]) == float(f"{travel['distance']:.4g}")
    assert float(said[2]) == float(f"{travel['X_C_end']:.4g}")


def test_sweep_png_draws_the_column_named(tmp_path, monkeypatch):
    """--plot distance draws the distance against the swept values; an unknown column, or
    --plot without --sweep, is refused naming the option (exit 2)."""
    import subprocess
    import sys
    from importlib import resources
    robot = str(resources.files("derive.scene") / "examples" / "spherical-robot.toml")
    args = [sys.executable, "-m", "derive", "simulate", robot, "-q"]
    bad = subprocess.run(args + ["-o", str(tmp_path / "a"), "--plot", "distance"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "--plot: names the column" in bad.stderr
    bad = subprocess.run(args + ["-o", str(tmp_path / "b"), "--sweep",
                                 "plane.friction=0.1,0.5", "--plot", "speed"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "--plot: must be one of impacts" in bad.stderr
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
    from matplotlib.figure import Figure
    from derive.runtime.sweep_plot import sweep_plot
    saved = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: saved.append(self))
    import derive
    b = derive.simulate_many(_robot_doc(), {"plane.friction": [0.02, 0.5]})
    sweep_plot(b, {"plane.friction": [0.02, 0.5]}, tmp_path, "distance")
    ax = saved[0].axes[0]
    assert ax.get_ylabel().startswith("horizontal distance C travelled")
    assert np.array_equal(ax.get_lines()[0].get_ydata(), b.column("distance").filled(np.nan))


def test_a_study_of_a_pushed_or_controlled_scene_runs_each_loop():
    """A study of a scene with [disturbance] or [control] had run each variant open and
    unpushed (the tables accepted and ignored); each variant now runs as derive.simulate
    runs the scene: the push applied (Y_C_end off the axis), the loop closed."""
    import derive
    doc = _robot_doc()
    doc["disturbance"] = {"pushes": [{"time": 2.0, "impulse": [0.0, 0.5, 0.0]}]}
    b = derive.simulate_many(doc, {"plane.friction": [0.3, 0.5]})
    alone = derive.simulate(doc)                      # friction 0.5, pushed
    assert b.column("Y_C_end")[1] == alone.general[-1, 1] and abs(alone.general[-1, 1]) > 0.1
    with pytest.raises(BatchError, match="scheduler"):
        derive.simulate_many(doc, {"plane.friction": [0.3, 0.5]},
                             scheduler="tcp://127.0.0.1:1")
