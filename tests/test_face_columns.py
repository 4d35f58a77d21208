"""A base run's law period read without SymPy, and a face sweep's slips, sticks and
reversals columns: the period against common_period of the laws' SymPy forms and the
examples' closed forms; ``summary()`` of a base run in a fresh interpreter with no SymPy
imported; sweep.csv's counts against each variant's own ``derive.simulate``."""
from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import pytest

import derive
from derive.runtime import base_report, report
from derive.scene import builtin_doc
from derive.scene.law import compile_law
from derive.scene.law.period import NotPeriodic, common_period, program_period
from derive.scene.parse import load_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "derive" / "scene" / "examples"


@pytest.mark.parametrize("name, w", [("capsule-crawler", 12.0), ("bardin-panev", 20.0)])
def test_the_examples_law_periods_are_what_sympy_gave(name, w):
    """2 pi/12 and 2 pi/20 (the examples' own comments), bit for bit common_period's of
    the laws as SymPy expressions (what law_period read before)."""
    scene = load_scene(EXAMPLES / f"{name}.toml")
    exprs = [e for body in scene.points for e in body.law.sympy()]
    T = base_report.law_period(scene)
    assert T == common_period(exprs)
    assert math.isclose(T, 2 * math.pi / w, rel_tol=1e-15)


@pytest.mark.parametrize("law", [
    ("sin(t)", "cos(1.5*t)", "0"), ("sin(3*t+1)*cos(2*t)", "1/(2+sin(t))", "exp(cos(4*t))"),
    ("sin(2*(t+1))", "cos(t/3)", "0"), ("sin(t)^2", "sqrt(1+0.5*cos(t))", "sin(-2*t)"),
    ("t - t + sin(t)", "0", "0"), ("cos(0.1*t + 0.2*t)", "sin(0.3*t)", "0"),
    ("sin(t/(1+0*t))", "0", "0"), ("asin(0.5*sin(2*t))", "log(2+sin(5*t))", "1"),
    ("sin(t)", "sin(sqrt(2)*t)", "0"), ("t", "0", "0"), ("sin(t) + t", "0", "0"),
    ("t*sin(t)", "0", "0"), ("sin(t*t)", "0", "0"), ("2^t", "0", "0"), ("tan(3*t)", "1/t", "0"),
    ("1", "2", "3"), ("0*t", "0", "0")])
def test_a_programs_period_is_common_periods_of_its_sympy_form(law):
    """The same period, or the same refusal (constant or not), both ways."""
    p = compile_law(law)
    got = []
    for fn, arg in ((common_period, p.sympy()), (program_period, [p])):
        try:
            got.append(fn(arg))
        except NotPeriodic as exc:
            got.append(("not periodic", exc.constant))
    assert got[0] == got[1], (law, got)


def test_the_summary_of_a_base_run_does_not_import_sympy():
    code = ("import sys, derive\nfrom derive.runtime import report\n"
            f"res = derive.simulate({str(EXAMPLES / 'capsule-crawler.toml')!r})\n"
            "s = report.summary(res)\n"
            "print(s['travel']['period'], s['travel']['whole_periods'], "
            "'sympy' in sys.modules)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    period, whole, sympy_loaded = proc.stdout.split()
    assert sympy_loaded == "False"
    assert float(period) == 2 * math.pi / 12 and whole == "10"


def test_a_face_sweep_has_each_variants_slips_sticks_and_reversals(tmp_path):
    """Two frictions of the capsule (0.05 reverses, 0.3 rests): sweep.csv's counts are
    each variant's own run's, as its summary counts its events; empty for a flight run."""
    src = EXAMPLES / "capsule-crawler.toml"
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", str(src), "-q",
                           "-o", str(tmp_path / "s"), "--sweep", "plane.friction=0.05,0.3",
                           "--plot", "sticks"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "s" / "sweep.png").stat().st_size > 0      # the counts can be drawn
    with open(tmp_path / "s" / "sweep.csv", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["plane_friction"] for r in rows] == ["0.05", "0.3"]
    text = src.read_text()
    seen = []
    for r in rows:
        doc = text.replace("friction = 0.3 ", f"friction = {r['plane_friction']} ")
        assert doc.count(f"friction = {r['plane_friction']} ") == 1
        (tmp_path / "v.toml").write_text(doc)
        contact = report.summary(derive.simulate(tmp_path / "v.toml"))["contact"]
        got = {k: int(r[k]) for k in ("slips", "sticks", "reversals")}
        assert got == {k: contact[k] for k in got}, (r["plane_friction"], got, contact)
        seen.append(got)
    assert seen[0]["reversals"] > 0 and seen[1]["reversals"] == 0 and seen[1]["sticks"] > 0
    flight = derive.simulate_many(builtin_doc(), [{"body.mass": 1.0}], workers=1)
    assert flight.rows[0]["model"] != "base" and flight.column("slips").mask.all()
    flight.to_csv(tmp_path / "f.csv")
    with open(tmp_path / "f.csv", encoding="utf-8") as fh:
        row = next(csv.DictReader(fh))
    assert (row["slips"], row["sticks"], row["reversals"]) == ("", "", "")
