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
