"""A new user's trial (README only, capsule robots: branch trial, scratch/NOTES.md): what
they found, each pinned by the way they met it, through ``derive.cli.main`` as the shell
runs it.  Bad input: one line naming the field and the rule, exit 2, no traceback,
nothing written.
"""
from pathlib import Path

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
