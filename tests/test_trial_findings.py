"""New users' trials (README only: capsule robots, branch trial, scratch/NOTES.md; a
hopping robot, branch trial2, scratch/FINDINGS.md): what they found, each pinned by the
way they met it, through ``derive.cli.main`` as the shell runs it.  Bad input: one line
naming the field and the rule, exit 2, no traceback, nothing written.
"""
import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

from derive import shapes
from derive.cli import main


def _refused(capsys, argv, out=None) -> str:
    """The one line of a refusal (exit 2, nothing written to ``out``)."""
    try:
        rc = main(argv)
    except SystemExit as exc:          # argparse's errors
        rc = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "Traceback" not in err[0], (rc, err)
    assert out is None or not Path(out).exists()
    return err[0]


# ---- derive scene new: a template that derive scene check takes ------------------------------
@pytest.mark.parametrize("shape", [*shapes.SHAPE_NAMES, shapes.NONE])
def test_every_shapes_template_passes_check(tmp_path, capsys, shape):
    """Every --shape printed a template that check refused: [plane].pressure (read by the
    base model only) was written uncommented on a scene in flight."""
    assert main(["scene", "new", "--shape", shape]) == 0
    text = capsys.readouterr().out
    path = tmp_path / "new.toml"
    path.write_text(text)
    assert main(["scene", "check", str(path)]) == 0, capsys.readouterr().err
    assert "valid; model general" in capsys.readouterr().out
    # the keys only the base model reads are there, commented out with their rule
    for key in ("static_friction", "pressure"):
        line = next(ln for ln in text.splitlines() if f" {key} = " in f" {ln}")
        assert line.startswith(f"# {key} = ") and "refused on the other models" in line


def test_a_template_runs(tmp_path, capsys):
    path = tmp_path / "new.toml"
    assert main(["scene", "new", "--shape", "box"]) == 0
    path.write_text(capsys.readouterr().out)
    out = tmp_path / "out"
    assert main(["simulate", str(path), "-o", str(out), "-q", "--no-plots",
                 "--set", "run.duration=0.5"]) == 0, capsys.readouterr().err
    assert (out / "trajectory.csv").exists()


# ---- --sweep of one field twice ------------------------------------------------------------------
BOX = """name = "my box capsule"
[body]
mass = 0.8
inertia = [0.000667, 0.001740, 0.001927]
shape = "box"
half_extents = [0.075, 0.04, 0.03]
[point]
mass = 0.3
law = ["0.03*(sin(15*t) + 0.5*sin(30*t))", "0", "0.01"]
[plane]
friction = 0.25
static_friction = 0.3
[initial]
on_plane = true
carrier_velocity = [0.0, 0.0, 0.0]
[run]
duration = 0.05
"""


@pytest.fixture
def box(tmp_path) -> Path:
    path = tmp_path / "box.toml"
    path.write_text(BOX)
    return path


@pytest.mark.parametrize("first, second", [
    ("plane.friction=0.1,0.2", "plane.friction=0.15,0.25"),
    ("point.law[0]=0.03*sin(W*t) for W=1:3:3", "point.law[0]=0.03*sin(W*t) for W=4:6:3"),
])
def test_a_field_swept_twice_is_refused(box, tmp_path, capsys, first, second):
    """The second --sweep of a field had replaced the first, silently, exit 0."""
    out = tmp_path / "out"
    line = _refused(capsys, ["simulate", str(box), "-o", str(out), "-q", "--sweep", first,
                             "--sweep", second], out)
    assert line.startswith("derive simulate: --sweep: ") and "is swept twice" in line


@pytest.mark.parametrize("flags, says", [
    (["--set", "body.mass=1", "--set", "body.mass=2"], "--set: body.mass: is set twice"),
    (["--set", "plane.friction=0.2", "--sweep", "plane.friction=0.1,0.3"],
     "--sweep: plane.friction: is also given by --set plane.friction"),
])
def test_a_field_set_twice_or_set_and_swept_is_refused(box, tmp_path, capsys, flags, says):
    """The last --set of a field won silently (as a second --sweep had), and a --sweep of a
    field --set also gives overrode it: each refused, naming the field."""
    out = tmp_path / "out"
    line = _refused(capsys, ["simulate", str(box), "-o", str(out), "-q", *flags], out)
    assert line.startswith(f"derive simulate: {says}"), line


# ---- --set of a law's entry to a number --------------------------------------------------------
def test_a_number_set_where_the_field_is_a_formula_is_that_formula(box, tmp_path, capsys):
    """--set 'point.law[2]=0.05' was refused (must be a string): a law entry is a formula,
    and a number is one; the run is the one of the quoted '"0.05"', byte for byte."""
    def run(*settings) -> bytes:
        out = tmp_path / f"out{len(list(tmp_path.iterdir()))}"
        argv = ["simulate", str(box), "-o", str(out), "-q", "--no-plots"]
        for setting in settings:
            argv += ["--set", setting]
        assert main(argv) == 0, capsys.readouterr().err
        return (out / "trajectory.csv").read_bytes()

    assert run("point.law[2]=0.05") == run('point.law[2]="0.05"')
    assert run("point.law=[0.01, 0, 0.05]") == run('point.law=["0.01", "0", "0.05"]')
    # elsewhere a string is still not a number, nor a boolean a formula
    for setting, says in (('body.mass="1"', "[body].mass: must be a number, not a string"),
                          ("point.law[2]=true", "[point].law[2]: must be a string")):
        line = _refused(capsys, ["simulate", str(box), "-o", str(tmp_path / "x"), "-q",
                                 "--set", setting], tmp_path / "x")
        assert says in line


# ---- derive export of a base scene with the hand-over's keys ----------------------------------
@pytest.mark.parametrize("table, key", [("plane", "restitution = 0.5"),
                                        ("plane", 'restitution_model = "poisson"'),
                                        ("run", "zeno_dt = 1e-6")])
def test_export_refuses_the_keys_only_the_handover_reads(tmp_path, capsys, table, key):
    """A base scene with [plane].restitution exported a program that stops at lift_off where
    derive simulate goes on (the flight, the flat landing): accepted and ignored."""
    path = tmp_path / "lift.toml"
    path.write_text(BOX.replace(f"[{table}]\n", f"[{table}]\n{key}\n"))
    out = tmp_path / "c"
    line = _refused(capsys, ["export", str(path), "-o", str(out)], out)
    field = f"[{table}].{key.split(' =')[0]}"
    assert line.startswith(f"derive export: {field}: ") and "no hand-over" in line
    # the plain base scene, and the same key on a scene of another model, are exported
    path.write_text(BOX)
    assert main(["export", str(path), "-o", str(out)]) == 0
    flight = BOX.replace("on_plane = true", "on_plane = false\ncom = [0, 0, 0.5]").replace(
        "static_friction = 0.3", "restitution = 0.5")
    if "restitution =" not in key:
        flight = flight.replace(f"[{table}]\n", f"[{table}]\n{key}\n")
    path.write_text(flight)
    assert main(["export", str(path), "-o", str(tmp_path / "c2")]) == 0, \
        capsys.readouterr().err


# ---- argparse's errors: one line naming the option and the rule --------------------------------
@pytest.mark.parametrize("argv, line", [
    (["simulate", "--format", "xml"],
     "derive simulate: --format: must be one of csv, npz (got 'xml')"),
    (["simulate", "--bogus", "--other=1"], "derive simulate: --bogus, --other: are not "
     "options of derive simulate (derive simulate -h: its options)"),
    (["export", "box.toml"],
     "derive export: -o/--output: is required (derive export -h: its arguments)"),
    (["simulate", "--workers", "two"], "derive simulate: --workers: must be a whole number "
     "(got 'two')"),
])
def test_the_parsers_errors_are_one_line(capsys, argv, line):
    """They were argparse's usage and error, 2-6 lines."""
    assert _refused(capsys, argv) == line


# ---- derive stability of a scene it cannot answer ------------------------------------------------
def test_stability_of_a_rough_scene_says_what_it_answers(box, capsys):
    """It said "[run].model: 'vertical' cannot answer this scene" of a box on its face: the
    user never asked for 'vertical'."""
    line = _refused(capsys, ["stability", str(box), "-q"])
    assert line.startswith("derive stability: [plane].friction: ") and "'vertical'" not in line
    assert "smooth plane (friction = 0)" in line and "friction 0.25 (model base)" in line


# ---- a cylinder on its side: the cause first -----------------------------------------------------
def test_a_cylinder_on_its_side_is_refused_by_its_attitude_first(tmp_path, capsys):
    """The user's cylinder on its side (hostile/x_cyl_side.toml) led with
    "[plane].restitution: is required"; the field that puts it on a line comes first, and
    what to do."""
    text = BOX.replace('shape = "box"\nhalf_extents = [0.075, 0.04, 0.03]',
                       'shape = "cylinder"\nradius = 0.03\nhalf_length = 0.075').replace(
        "on_plane = true", "on_plane = true\nquaternion = [0.7071067811865476, "
                           "0.7071067811865476, 0, 0]")
    path = tmp_path / "side.toml"
    path.write_text(text)
    out = tmp_path / "out"
    line = _refused(capsys, ["simulate", str(path), "-o", str(out), "-q"], out)
    # (no model runs it, with or without [plane].restitution: tests/test_flat_starts.py)
    assert line.startswith("derive simulate: [initial].quaternion: puts a cylinder on the "
                           "plane on its side (a line), the vertical [0, 1, 0] (body axes)")
    assert "stand it on an end (the base model) or use a box" in line


# ---- the second trial (a hopping robot): keys accepted and ignored ---------------------------
FLIGHT = """name = "in flight"
[body]
mass = 1.0
inertia = [0.10, 0.12, 0.14]
shape = "sphere"
radius = 0.5
[point]
mass = 0.2
law = ["0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"]
[initial]
com = [0.0, 0.0, 1.5]
omega = [0.5, -0.3, 1.0]
[run]
duration = 1.0
"""


def _scene(tmp_path, text: str, name: str = "s.toml") -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("run, says", [
    ('step = 0.001', "[run].step: is read by method rk4 only, and this run's method is lie"),
    ('step = 0.01\nmethod = "dopri5"', "[run].step: is read by method rk4 only, and this "
                                       "run's method is dopri5"),
    ('keep_orthonormal = true', "[run].keep_orthonormal: method lie keeps a flight's "
                                "attitude on the rotations itself, and this run has no "
                                "contact phase"),
    ('keep_orthonormal = true\nmethod = "dopri5"\noutputs = ["omega"]',
     "[run].keep_orthonormal: model attitude has no attitude matrix"),
])
def test_a_run_key_its_method_or_model_never_reads_is_refused(tmp_path, capsys, run, says):
    """--set run.step=0.001 with lie or dopri5 ran the same steps (only rk4 reads it);
    keep_orthonormal = true with lie in flight changed nothing (the Lie step stays on the
    rotations; only a contact phase's classical step projects)."""
    path = _scene(tmp_path, FLIGHT + run + "\n")
    assert says in _refused(capsys, ["scene", "check", path])


@pytest.mark.parametrize("run", ['step = 0.001\nmethod = "rk4"',
                                 'keep_orthonormal = true\nmethod = "dop853"',
                                 'keep_orthonormal = false'])
def test_the_run_keys_their_readers_take(tmp_path, capsys, run):
    assert main(["scene", "check", _scene(tmp_path, FLIGHT + run + "\n")]) == 0, \
        capsys.readouterr().err


def test_keep_orthonormal_with_lie_acts_in_a_contact_phase():
    """With a Lie method the projection acts where DOP853 or DOPRI5 stands in: a rough
    ball's rolling contact, whose attitude it changes (in round-off), not the flights'."""
    import derive
    from derive import layout
    doc = tomllib.loads(ROUGH)
    doc["run"]["duration"] = 0.15
    runs = []
    for keep in (False, True):
        doc["run"]["keep_orthonormal"] = keep
        runs.append(derive.simulate(copy.deepcopy(doc)))
    a, b = (r.model_q for r in runs)
    assert runs[0].stats["contacts"] >= 1 and a.shape == b.shape
    assert runs[1].model == "rough" and not np.array_equal(a, b)
    k = layout.of("rough").index("a11")
    A = b[-1, k:k + 9].reshape(3, 3)
    assert np.abs(A @ A.T - np.eye(3)).max() < 1e-14


def test_stability_is_refused_where_derive_stability_cannot_read_it(tmp_path, capsys):
    """A [stability] table in a scene of 2 points and a rotor ran silently in derive
    simulate, though derive stability refuses such scenes: refused by every command; in
    a scene of one point derive scene check says which command reads it."""
    two = FLIGHT.replace("[point]\n", "[[point]]\n") + "[[point]]\nmass = 0.1\nlaw = " \
        '["0", "0.02", "0.04*sin(7*t)"]\n[stability]\nlong_periods = 3\n'
    line = _refused(capsys, ["scene", "check", _scene(tmp_path, two)])
    assert line.startswith("derive scene: [stability]: is read by `derive stability` only")
    assert "2 points" in line
    out = tmp_path / "out"
    assert "[stability]" in _refused(capsys, ["simulate", _scene(tmp_path, two), "-o",
                                              str(out)], out)
    one = FLIGHT + "[stability]\nlong_periods = 3\n"
    assert main(["scene", "check", _scene(tmp_path, one)]) == 0
    said = capsys.readouterr().out
    assert "[stability]: read by `derive stability` only" in said
    assert main(["scene", "check", _scene(tmp_path, FLIGHT)]) == 0
    assert "[stability]" not in capsys.readouterr().out


ROUGH = """name = "rough hopper"
[body]
mass = 1.0
inertia = [0.016, 0.016, 0.016]
shape = "sphere"
radius = 0.15
[point]
mass = 0.4
law = ["0.02*sin(6*t)", "0", "0.05*sin(30*t)"]
[plane]
restitution = 0.3
friction = 0.6
[initial]
on_plane = true
carrier_velocity = [0.0, 0.0, 0.0]
[run]
duration = 0.6
"""


def test_a_rough_sweep_counts_its_slips_sticks_and_reversals(tmp_path):
    """sweep.csv of a rough-plane run had slips, sticks and reversals empty (base runs
    only), though derive simulate printed them: each row is the single run's summary."""
    import csv

    import derive
    from derive.runtime.study import FRICTION_COLUMNS, summary_row
    doc = tomllib.loads(ROUGH)
    variants = [{"plane.friction": mu} for mu in (0.3, 0.6)]
    batch = derive.simulate_many(doc, variants, workers=1)
    path = tmp_path / "sweep.csv"
    batch.to_csv(path)
    rows = list(csv.DictReader(path.open()))
    for v, row, written in zip(variants, batch.rows, rows):
        d = copy.deepcopy(doc)
        d["plane"]["friction"] = v["plane.friction"]
        run = derive.simulate(d)
        assert run.model == row["model"] == "rough"
        want = summary_row(run)
        for name in FRICTION_COLUMNS:
            assert row[name] == want[name] == run.stats[name] == int(written[name])
            assert not np.ma.is_masked(batch.column(name)[variants.index(v)])
    assert sum(int(r["slips"]) + int(r["sticks"]) for r in rows) > 0


# ---- the second trial's small ones -----------------------------------------------------------
def test_an_empty_file_is_told_what_a_scene_needs(tmp_path, capsys):
    line = _refused(capsys, ["scene", "check", _scene(tmp_path, "")])
    assert "needs at least [body] and a [point], a [[point]] or a [[rotor]]" in line


def test_a_binary_file_is_told_it_is_not_text(tmp_path, capsys):
    path = tmp_path / "junk.toml"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    assert "is not UTF-8 text (byte 0" in _refused(capsys, ["scene", "check", str(path)])


@pytest.mark.parametrize("sweep, says", [
    ("point[1].law[0]=0.06*sin(t) for W=1:2:3", "point[1].law[0]: W does not appear"),
    ("point[1].law[0]=0.06*sin(W*t) for t=1:2:3", "point[1].law[0]: a formula is swept as"),
])
def test_a_swept_elements_formula_is_named_as_typed(tmp_path, capsys, sweep, says):
    two = FLIGHT.replace("[point]\n", "[[point]]\n") + "[[point]]\nmass = 0.1\nlaw = " \
        '["0", "0.02", "0.04*sin(7*t)"]\n'
    out = tmp_path / "out"
    line = _refused(capsys, ["simulate", _scene(tmp_path, two), "-o", str(out),
                             "--sweep", sweep], out)
    assert says in line


ROLLING = """name = "rolling resistance check"
[body]
mass = 1.0
inertia = [0.015, 0.015, 0.015]
shape = "sphere"
radius = 0.15
[[rotor]]
axis = [0.0, 0.0, 1.0]
inertia = 0.001
law = "0"
[plane]
restitution = {e}
friction = {mu}
rolling_resistance = {mu_r}
[initial]
on_plane = true
carrier_velocity = [{v}, 0.0, 0.0]
omega = [0.0, {w}, 0.0]
[run]
duration = 1.0
"""


@pytest.mark.parametrize("e, mu, mu_r", [(0.0, 0.5, 0.002), (0.5, 0.0, 0.0)])
def test_a_start_on_the_plane_at_rest_is_a_contact_not_an_impact(e, mu, mu_r):
    """A ball put on the floor ([initial].on_plane) counted "1 impact, 1 contact phase":
    it fell by round-off for 0.6 us and hit the plane at g t.  Now it begins in contact
    at t0 and never impacts; it rolls as the closed form says, decelerated by rolling
    resistance at mu_r g / (R (1 + J / (M R^2))) (derive/docs/friction.md), or slides
    at its speed on the smooth plane."""
    import derive
    from derive import layout
    v, R, J, M, g = 1.0, 0.15, 0.015, 1.0, 9.81
    rolls = mu > 0
    doc = tomllib.loads(ROLLING.format(e=e, mu=mu, mu_r=mu_r, v=v, w=v / R if rolls else 0.0))
    run = derive.simulate(doc)
    assert run.status == "done"
    assert (run.stats["impacts"], run.stats["contacts"], run.stats["lift_offs"]) == (0, 1, 0)
    assert (run.events[0]["kind"], run.events[0]["t"]) == ("contact", 0.0)
    a = mu_r * g / (R * (1.0 + J / (M * R * R))) if rolls else 0.0
    t = run.t[-1]
    q = run.general
    X, Z = (q[:, layout.GENERAL.index(name)] for name in ("X_C", "Z_C"))
    assert X[-1] == pytest.approx(v * t - a * t * t / 2, rel=1e-9)
    assert np.ptp(Z) < 1e-12
