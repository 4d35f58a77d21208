"""Parameter studies: simulate_many against one simulate per variant, serial against
processes (bit for bit), refusals naming the variant and the field, and the CLI's
--set and --sweep."""
from __future__ import annotations

import copy
import json
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


def test_the_quick_path_of_a_variant_equals_the_full_one():
    """A variant changing only the initial position and velocity, e or g reuses the base
    scene's validation; on random variants (and models) it equals the full path."""
    from derive.runtime.batch import _quick_variant, _VariantDoc
    from derive.runtime.driver import prepare
    from derive.scene import build_scene, parse_scene
    from derive.scene.overrides import apply_to_values
    from derive.scene.schema import SCENE
    rng = np.random.default_rng(7)
    docs = [builtin_doc()]
    flat = builtin_doc()
    flat["initial"]["omega"] = [0.0, 0.0, 0.0]
    flat["point"]["law"] = ["0.0", "0.0", "0.1*sin(2*t)"]
    flat["run"]["outputs"] = ["impacts"]
    docs.append(flat)                               # translational
    names = ["initial.com[0]", "initial.com[2]", "initial.com_velocity[1]",
             "initial.com_velocity[2]", "plane.restitution", "run.g"]
    checked = refused = 0
    for doc in docs:
        base_v, base_given = SCENE.read(doc)
        base = prepare(build_scene(dict(base_v), set(base_given), {}, "base scene"))
        for _ in range(150):
            picked = rng.choice(names, size=rng.integers(1, 4), replace=False)
            over = {n: float(rng.uniform(0.2, 2.0) if n.startswith("initial.com[")
                             else rng.uniform(0.0, 1.0) if n == "plane.restitution"
                             else rng.uniform(-1.0, 1.0) if "velocity" in n
                             else rng.uniform(1.0, 20.0)) for n in picked}
            v, given = dict(base_v), set(base_given)
            for n, value in over.items():
                apply_to_values(v, given, n, value)
            touched = {f"[{n.split('.')[0]}].{n.split('.')[1].split('[')[0]}" for n in over}
            try:
                full = prepare(build_scene(v, given, {}, "variant"))
            except SceneError as exc:
                with pytest.raises(SceneError, match=exc.where.replace("[", r"\[")):
                    _quick_variant(base, v, touched, "variant", _VariantDoc(doc, over))
                refused += 1
                continue
            quick = _quick_variant(base, v, touched, "variant", _VariantDoc(doc, over))
            assert quick.kind == full.kind and quick.scene == full.scene
            # its dict is the base's with the overrides: it gives the same scene again
            assert parse_scene(quick.scene.doc, "variant") == full.scene
            assert np.array_equal(quick.start.q0, full.start.q0)
            assert np.array_equal(quick.options, full.options)
            assert np.array_equal(quick.parameters, full.parameters)
            checked += 1
    assert checked > 200 and refused > 10      # S started below the plane
    v, given = dict(base_v), set(base_given)
    apply_to_values(v, given, "body.mass", 2.0)
    assert _quick_variant(base, v, {"[body].mass"}, "variant", _VariantDoc(doc, {})) is None


def test_a_bad_variant_is_named():
    doc = builtin_doc()
    with pytest.raises(BatchError) as info:
        derive.simulate_many(doc, [{"body.mass": 1.0}, {"body.mass": -2.0}], workers=1)
    assert "variant 1" in str(info.value) and "[body].mass" in str(info.value)
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
    from derive.runtime.batch import parse_sweep
    with pytest.raises(BatchError) as info:
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
