"""derive verify mutants: its reader of C, its catalogue and one run end to end.

* the reader (derive/verify/csites.py) on C written here: which comparisons it finds,
  their types, the loop headers it leaves, the terms of a sum, the tolerances;
* the catalogue read from the templates: the mutant of issue 36 (a stick accepted up to
  1.05 mu_f N) is in it, each mutant changes its site and nothing else, the C of a sample
  of them compiles under the project's warnings, and every entry of
  derive/verify/equivalent_mutants.toml names a mutant that exists, with its reason;
* the command: that mutant killed and a harmless one surviving, its kill rate printed and
  its exit status 1, each built in a scratch copy, the worktree untouched.
"""
from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from derive.cbuild import WARNINGS, compiler
from derive.paths import GENERATED, ROOT, TEMPLATES
from derive.verify import csites as cs
from derive.verify import mutants as mu

C = """
typedef struct { double lo, *hi; int n; } box;
#define TOL 1e-9   /* a tolerance */
static double f(const box *b, double x, int k)
{
  int i;
  double acc = 0.0;
  for (i = 0; i < b->n; ++i) acc += x;      /* a loop: not a site */
  if (x <= 2.0 * b->lo + TOL && k == 3) return acc - x + 1.0;
  if (acc > 0.0 && x <= 0.0) return -1.0;
  return b->hi[0] < x ? 1.0 : 0.5;
}
"""


def test_the_reader_finds_the_comparisons_their_types_and_the_tolerances():
    src = cs.parse("x.c", C)
    names = cs.names([src])
    found = {(c.text, c.kind, c.zero) for c in cs.comparisons(src, names)}
    assert found == {("x <= 2.0 * b->lo + TOL", "double", ""), ("k == 3", "int", ""),
                     ("acc > 0.0", "double", "right"), ("x <= 0.0", "double", "right"),
                     ("b->hi[0] < x", "double", "")}
    (c,) = [c for c in cs.comparisons(src, names) if c.text.startswith("x <= 2.0")]
    assert [src.span_text(a, b) for a, b in cs.terms(src, *c.right)] == ["2.0 * b->lo", "TOL"]
    assert [(lit.text, lit.function) for lit in cs.literals(src)
            if lit.value <= 1e-2 and lit.value > 0] == [("1e-9", "#define TOL")]
    assert [(f, src.span_text(a, b)) for f, a, b in cs.returns_of(src)][0] == \
        ("f", "acc - x + 1.0")


@pytest.fixture(scope="module")
def catalogue():
    return mu.catalogue()


def test_the_catalogue_holds_the_issues_mutant_and_each_changes_its_site(catalogue):
    keys = {m.key for m in catalogue}
    assert ("crt_rough_at_rest: bound: rt <= s->prm[CRT_P_friction] * R[2] -> "
            "rt <= 1.05 * (s->prm[CRT_P_friction] * R[2])") in keys
    assert len(keys) == len(catalogue)                  # each named once
    kinds = {m.kind for m in catalogue}
    assert kinds == set(mu.KINDS)
    texts = {}
    for m in catalogue:
        if (m.part, m.file) not in texts:
            texts[(m.part, m.file)] = (TEMPLATES / m.part / m.file).read_text(encoding="utf-8")
        text = texts[(m.part, m.file)]
        new = m.apply(text)
        assert new != text
        start = min(e[0] for e in m.edits)
        assert new[:start] == text[:start]              # nothing before the site moved
        assert text.count("\n") == new.count("\n") or "\n" in m.before


def test_a_sample_of_mutants_compiles_under_the_projects_warnings(catalogue, tmp_path):
    """The first mutant of each kind in the files that decide the rough plane's modes and
    impacts, in the rough model (the harness compiles each one the same way before
    testing it)."""
    src = GENERATED / "runtime"
    rough = ("crt_rough.h", "crt_rough_modes.h", "crt_rough_api.h", "crt_dk.h", "crt_events.h")
    for kind in mu.KINDS:
        m = next(m for m in catalogue if m.kind == kind and m.file in rough)
        folder = tmp_path / kind
        folder.mkdir()
        for p in src.iterdir():
            (folder / p.name).write_bytes(p.read_bytes())
        (folder / m.file).write_text(m.apply((src / m.file).read_text(encoding="utf-8")),
                                     encoding="utf-8")
        proc = subprocess.run([compiler(), *WARNINGS, "-fsyntax-only", "-I", str(folder),
                               str(folder / "model_rough.c")], capture_output=True, text=True)
        assert proc.returncode == 0, (m.key, proc.stderr[-800:])


def test_every_recorded_equivalent_names_a_mutant_with_its_reason(catalogue):
    keys = {m.key for m in catalogue}
    for key, reason in mu.equivalents().items():
        assert key in keys, f"equivalent_mutants.toml names no mutant: {key}"
        assert len(reason.split()) >= 5, f"say why {key} is equivalent"


def test_the_command_kills_the_issues_mutant_reports_a_survivor_and_fails():
    """``derive verify mutants`` against the boundary test of a slip that stops outside the
    cone: the stick accepted up to 1.05 mu_f N is killed by it; a flip in crt_eval_impact
    (an evaluation for Python that no run calls) survives, so the command prints it, its
    kill rate (1 of 2) and exits 1.  Neither touches the worktree."""
    before = {p.name: p.read_bytes() for p in (GENERATED / "runtime").iterdir()}
    test = ("tests/test_friction_boundaries.py::test_a_stopping_slip_sticks_inside_the_cone_"
            "and_slides_on_outside_it[0.008279626483585467-reversal-band1]")
    proc = subprocess.run(
        [sys.executable, "-m", "derive", "verify", "mutants", "--workers", "1", "--test", test,
         "--match", "rt <= 1.05 * (s->prm[CRT_P_friction] * R[2])",
         "--match", "crt_eval_impact: flip: status != CRT_OK -> status == CRT_OK"],
        capture_output=True, text=True, cwd=ROOT)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 1, out[-2000:]
    killed = [ln for ln in out.splitlines() if re.search(r"\] killed \w+ ", ln)]
    assert len(killed) == 1 and "crt_rough_at_rest" in killed[0] and "reversal" in killed[0]
    assert "crt_rough.h: killed 1" in out and "crt_rough_api.h: survived 1" in out
    assert re.search(r"survived \w+ runtime/crt_rough_api.h:\d+ crt_eval_impact flip", out)
    assert "kill rate 1/2 = 50.0%" in out and "FAIL" in out
    assert {p.name: p.read_bytes() for p in (GENERATED / "runtime").iterdir()} == before


def test_the_screen_is_the_journals_best_killers_among_a_mutants_own_tests(tmp_path):
    """``killers`` counts the tests a journal records as killing (crashes, timeouts and
    survivors are no test's); ``screen_of`` takes the most frequent of them that are among
    the mutant's tests (a file, a test id, a test's parameters), ties by name."""
    journal = tmp_path / "j.jsonl"
    rows = [("killed", "tests/test_a.py::test_x[1]")] * 3 + \
        [("killed", "tests/test_b.py::test_y")] * 2 + \
        [("killed", "tests/test_c.py::test_z")] * 5 + \
        [("killed", "crashed (signal 11)"), ("survived", ""), ("killed", "ran past 120 s")] + \
        [("equivalent", "tests/test_c.py::test_z")] * 9
    journal.write_text("\n".join(json.dumps({"status": s, "detail": d}) for s, d in rows)
                       + "\nnot json\n", encoding="utf-8")
    kills = mu.killers(journal)
    assert kills == {"tests/test_a.py::test_x[1]": 3, "tests/test_b.py::test_y": 2,
                     "tests/test_c.py::test_z": 5}
    chosen = ["tests/test_a.py::test_x", "tests/test_b.py"]
    assert mu.screen_of(chosen, kills, 6) == ["tests/test_a.py::test_x[1]",
                                              "tests/test_b.py::test_y"]
    assert mu.screen_of(chosen, kills, 1) == ["tests/test_a.py::test_x[1]"]
    assert mu.screen_of(["tests/test_c.py", "tests/test_b.py"], kills, 6) == [
        "tests/test_c.py::test_z", "tests/test_b.py::test_y"]
    assert mu.screen_of(["tests/test_d.py"], kills, 6) == []
    assert mu.killers(tmp_path / "none.jsonl") == {}


def test_a_run_past_its_time_is_timed_out_then_judged_by_its_run_alone(catalogue, tmp_path):
    """A test run past the limit is "timed out", not killed (on a loaded machine a
    survivor's tests ran long and were miscalled killed): ``retry`` judges it by a run
    alone with RETRY times the limit.  A fake test that passes at once survives its re-run
    (its first limit too short for pytest to start); one that sleeps is killed as a hang,
    said so in its detail and counted apart in the summary line."""
    sleepy, quick = tmp_path / "test_sleepy.py", tmp_path / "test_quick.py"
    sleepy.write_text("import time\n\ndef test_sleeps():\n    time.sleep(60)\n")
    quick.write_text("def test_passes():\n    pass\n")
    sc = mu.Scratch(tmp_path / "w")
    status, detail, secs = mu._pytest(sc, [str(sleepy)], 0.3)
    assert (status, detail) == ("timed out", "ran past 0.3 s") and secs < 30.0
    hung = mu.Outcome(catalogue[0], status, detail, secs)
    mu.retry(hung, lambda limit: mu._pytest(sc, [str(sleepy)], limit), 0.3)
    assert hung.status == "killed" and hung.timed_out
    assert hung.detail == f"a hang: ran past 0.3 s, and past {mu.RETRY * 0.3:.3g} s alone"
    slow = mu.Outcome(catalogue[1], "timed out", "ran past 0.01 s", 0.01)
    mu.retry(slow, lambda limit: mu._pytest(sc, [str(quick)], limit), 20.0)
    assert slow.status == "survived" and slow.timed_out and "timed out at 20 s" in slow.detail
    rep = mu.Report([hung, slow, mu.Outcome(catalogue[2], "killed", "tests/t.py::test_x")])
    out = mu.report(rep)
    assert "2 timed out and re-run alone: 1 killed as a hang (past the longer limit too), " \
        "1 survived;" in out and "kill rate 2/3" in out
    assert f"killed {catalogue[0].id} " in out and f"survived {catalogue[1].id} " in out


def test_a_run_ended_from_outside_is_no_verdict_a_crash_is_a_kill(tmp_path):
    """A test run ended by a signal from outside (kill's SIGTERM, ^C) had been logged
    "killed (crashed (signal 15))", so a journal skipped that mutant for ever: it is an
    error now (run again next time); a crash of the run itself (SIGABRT, as a mutated C's
    assert or a SIGSEGV ends it) stays a kill."""
    term, abort = tmp_path / "test_term.py", tmp_path / "test_abort.py"
    term.write_text("import os, signal\n\ndef test_t():\n"
                    "    os.kill(os.getpid(), signal.SIGTERM)\n")
    abort.write_text("import os\n\ndef test_a():\n    os.abort()\n")
    sc = mu.Scratch(tmp_path / "w")
    status, detail, _ = mu._pytest(sc, [str(term)], 60.0)
    assert status == "error" and detail.startswith("stopped from outside (signal 15)")
    status, detail, _ = mu._pytest(sc, [str(abort)], 60.0)
    assert (status, detail) == ("killed", "crashed (signal 6)")
