"""``derive bench`` and ``derive verify``: each command declared once, one parser each, and
an exit status that says what the report says.

For every command, a run whose verdict is forced one way and then the other: exit 0 and
only PASS printed, or exit 1 and FAIL printed.  The measuring parts are stubbed or run at
their smallest (a canned timing table, a peer made faster, one scene, a compiled law
that computes another law, a scene capped at ten steps); the verdict logic is the
commands' own.  And the command table (derive/docs/commands.md) names exactly the declared
commands, with options they have.
"""
from __future__ import annotations

import copy
import re
from pathlib import Path

import numpy as np
import pytest

from derive.bench import COMMANDS as BENCHES
from derive.cli import build_parser, main
from derive.verify import COMMANDS as CHECKS

ROOT = Path(__file__).resolve().parents[1]


def _verdict(argv, capsys) -> tuple[int, str]:
    """Exit status and stdout of ``derive *argv``; the status must match the marks."""
    status = main(argv)
    out = capsys.readouterr().out
    fails = re.findall(r"\bFAIL\b", out)
    passes = re.findall(r"\bPASS\b", out)
    assert status in (0, 1), out
    assert bool(fails) == (status == 1), out
    assert passes or fails, f"no verdict printed:\n{out}"
    return status, out


# ---- the registry ------------------------------------------------------------------------
def _subcommands(parser, name):
    sub = next(a for a in parser._actions if a.dest == "command").choices[name]
    return next(a for a in sub._actions if a.dest == name).choices


def test_the_parser_is_built_from_the_declarations():
    parser = build_parser()
    for group, commands in (("bench", BENCHES), ("verify", CHECKS)):
        parsers = _subcommands(parser, group)
        assert list(parsers) == [c.name for c in commands]
        for c in commands:
            for role in ("run", "report", "passed"):
                assert callable(c.function(role)), (c.name, role)
            options = {s for a in parsers[c.name]._actions for s in a.option_strings}
            declared = {f for a in c.arguments for f in a.flags} | {"-h", "--help"}
            assert options == declared, c.name


@pytest.mark.parametrize("argv", [
    ["bench", "law", "--cases", "3"],             # an option of another command
    ["verify", "failures", "--seed", "1"],
    ["bench", "fuzz"],                            # moved to derive verify
    ["bench", "robustness"],
    ["verify", "robustness", "-n", "0"],          # out of range
    ["verify", "fuzz", "--workers", "0"],
    ["bench", "precision", "--scenes", "nowhere"],
])
def test_one_parser_per_command(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert "Traceback" not in capsys.readouterr().err


def test_readme_command_table_is_the_registry():
    """Every ``derive bench``/``derive verify`` line of the command table (the reference
    page derive/docs/commands.md) names a declared command and only options it has; every
    declared command is there."""
    text = (ROOT / "derive" / "docs" / "commands.md").read_text(encoding="utf-8")
    table = text.split("# Command line", 1)[1].split("```", 2)[1]
    parser = build_parser()
    seen = set()
    for group, commands in (("bench", BENCHES), ("verify", CHECKS)):
        parsers = _subcommands(parser, group)
        for name, rest in re.findall(rf"^derive {group} (\w+)(.*)$", table, re.M):
            assert name in parsers, f"commands.md: derive {group} {name} is not a command"
            options = {s for a in parsers[name]._actions for s in a.option_strings}
            for flag in re.findall(r"\[(-{1,2}[\w-]+)", rest):
                assert flag in options, f"commands.md: derive {group} {name} has no {flag}"
            seen.add((group, name))
        assert {(group, c.name) for c in commands} <= seen, group
    assert "derive bench fuzz" not in text and "derive bench robustness" not in text
    assert "derive bench failures" not in text


# ---- bench rhs: a canned timing table, the hand-written peer fast or slow ----------------
def _rhs_report(hand_latency_ns: float):
    from derive.bench import rhs
    from derive.emit.linalg import DEFAULT_SOLVER
    rows = [rhs.Row("general_flight_rhs", 300, 400, 50.0, 60.0, 5e3, 9e3, 30.0, 40.0),
            rhs.Row("vertical_flight_rhs", 100, 150, 20.0, 25.0, 4e3, 8e3, 12.0, 15.0),
            rhs.Row("moments_flight_rhs", 400, 500, 65.0, 70.0, 6e3, 1e4, 39.0, 45.0)]
    variants = [rhs.Variant(f, solver, 300, 320, "mul 3", 10.0, 5.0, 50.0, 30.0, 2.0, 1.0)
                for f in ("general_flight_rhs", "lie_stage")
                for solver in (rhs.PREVIOUS, DEFAULT_SOLVER)]
    peers = {form: (55.0, hand_latency_ns, 500) for form in rhs.HAND_FORMS}
    peers.update({rhs.FLOOR: (5.0, 5.0, 18), rhs.BOUND: (20.0, 20.0, 0)})
    machine = {"add": 1.0, "mul": 1.2, "div": 4.0, "sqrt_add": 6.0, "issue": 0.3}
    return rhs.Report(rows, variants, peers, machine, ("-O2",))


@pytest.mark.parametrize("hand_latency_ns, status", [(50.0, 0), (25.0, 1)])
def test_bench_rhs_exit_status(hand_latency_ns, status, monkeypatch, capsys):
    """The emitted RHS (30 ns in the latency loop) against the strongest hand-written peer:
    slower (50 ns) passes, faster (25 ns) fails and exits 1."""
    from derive.bench import rhs
    monkeypatch.setattr(rhs, "run", lambda cflags, progress, python: _rhs_report(
        hand_latency_ns))
    got, out = _verdict(["bench", "rhs"], capsys)
    assert got == status
    assert ("FAIL" in out) == (status == 1)
    assert "ops 400/300 = 1.33, throughput 65.0/50.0 ns = 1.30, latency 39.0/30.0 ns = 1.30" \
        in out


# ---- bench sim: canned routes, SciPy fast or slow ------------------------------------------
def _sim_rows(scipy_s: float):
    def rows(doc, progress, repeats):
        return {"scene": doc["name"], "duration": 5.0, "reference_agreement": (1e-12, 1e-13),
                "rows": [{"route": r, "setting": 1e-9, "seconds": s, "error": 5e-10,
                          "impact_error": 1e-11, "evaluations": 100}
                         for r, s in (("runtime C (lie)", 9e-5), ("derive.simulate (law seen)",
                                                                  1.4e-4),
                                      ("derive.simulate (new law)", 1e-3),
                                      ("scipy DOP853", scipy_s), ("casadi cvodes", 0.05))]}
    return rows


@pytest.mark.parametrize("scipy_s, status", [(0.165, 0), (0.1, 1)])
def test_bench_sim_exit_status(scipy_s, status, monkeypatch, capsys):
    from derive.bench import sim
    monkeypatch.setattr(sim, "scene_rows", _sim_rows(scipy_s))
    monkeypatch.setattr(sim, "any_numbers", lambda doc, progress, repeats, n: {
        "variants": [{}] * n, "median": scipy_s / 1.6e-4, "min": scipy_s / 2e-4,
        "max": scipy_s / 1.5e-4, "met": n, "short": []})
    got, out = _verdict(["bench", "sim", "--quick"], capsys)
    assert got == status
    assert out.count("law seen before, faster than SciPy: 714x (target >= 1000x): FAIL") == \
        (2 if status else 0)


def test_bench_sim_refuses_a_bad_scene_in_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[body]\nmass = -1\n")
    assert main(["bench", "sim", "--scene", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("derive bench: ") and "mass" in err[0]


# ---- bench law: one law for real; its compiled peer computing another law ------------------
@pytest.mark.parametrize("wrong_peer, status", [(False, 0), (True, 1)])
def test_bench_law_exit_status(wrong_peer, status, monkeypatch, capsys):
    from derive.bench import law
    monkeypatch.setattr(law, "LAWS", {"built-in": law.LAWS["built-in"]})
    if wrong_peer:
        straight = law.straight_line_c
        monkeypatch.setattr(law, "straight_line_c", lambda program: straight(program).replace(
            "  }\n}", "    u[9L * k] *= 1.01;\n  }\n}"))
    got, out = _verdict(["bench", "law", "--repeats", "1"], capsys)
    assert got == status
    assert ("interpreted and compiled agree to" in out
            and re.search(r"agree to .*: PASS", out) is not None) == (status == 0)


def test_law_payback_target():
    """A compiled law that repays its compile time within PAYBACK runs fails the target;
    one that never does (slower than the interpreter) passes."""
    from derive.bench import law
    row = {"law": "x", "agreement": 1e-16, "compile_ms": 60.0}
    assert not law.passed({"rows": [dict(row, saving_ms=1.0)]})        # 60 runs
    assert law.passed({"rows": [dict(row, saving_ms=0.01)]})           # 6000 runs
    assert law.passed({"rows": [dict(row, saving_ms=-0.01)]})          # never


# ---- bench precision: canned work-precision points, LIE faster or slower -------------------
def _points(lie_factor: float):
    from derive.bench.precision import Point

    def sweep(name, doc, ref, quick, repeats, progress):
        out = []
        for method, factor in (("runtime LIE", lie_factor), ("runtime DOP853", 1.0)):
            for k in range(9):
                tol = 10.0 ** (-4 - k)
                out.append(Point(name, method, tol, factor * 1e-4 * (1 + k), 0.5 * tol,
                                 0.0, 100 * (k + 1), "done"))
        return out
    return sweep


@pytest.mark.parametrize("lie_factor, periods, status", [(0.8, "20", 0), (1.25, "0", 1)])
def test_bench_precision_exit_status(lie_factor, periods, status, tmp_path, monkeypatch,
                                     capsys):
    from derive.bench import precision
    monkeypatch.setattr(precision, "sweep", _points(lie_factor))
    monkeypatch.setattr(precision, "_reference", lambda *a: None)
    monkeypatch.setattr(precision, "retime", lambda *a, **k: None)
    monkeypatch.setattr(precision, "chart", lambda *a: None)
    monkeypatch.setattr(precision, "long_chart", lambda *a: None)
    got, out = _verdict(["bench", "precision", "--quick", "--scenes", "planar E4.2",
                         "--periods", periods, "-o", str(tmp_path)], capsys)
    assert got == status
    line = next(x for x in out.splitlines() if x.strip().startswith("target (E4.2 at every"))
    assert "at most 1x" in line and line.endswith("FAIL" if status else "PASS"), line
    assert ("targets of LIE: |K| <= 1e-12: PASS" in out) == (periods != "0")
    assert f"charts and data in {tmp_path}" in out


# ---- verify failures: one hard scene, a method at its default or made loose ----------------
@pytest.mark.parametrize("rtol, status", [(1e-10, 0), (1e-3, 1)])
def test_verify_failures_exit_status(rtol, status, monkeypatch, capsys):
    from derive.bench.routes import Runtime
    from derive.verify import failures
    scenes = failures.scenes()
    monkeypatch.setattr(failures, "scenes", lambda: {
        "impacts accumulate, e = 0.5": scenes["impacts accumulate, e = 0.5"]})
    monkeypatch.setattr(failures, "methods", lambda: [
        ("runtime DOPRI5", lambda d: Runtime(d, "dopri5", rtol))])
    got, out = _verdict(["verify", "failures"], capsys)
    assert got == status
    assert (re.search(r"runtime DOPRI5 +correct", out) is not None) == (status == 0)


# ---- verify fuzz: a case refused as it must be, or one that must be refused and runs -------
def _fuzz_cases(must_refuse_the_valid_scene: bool):
    from derive.verify.generators import Case, base_scene
    bad = base_scene()
    bad["body"]["mass"] = -1.0
    cases = [Case(0, "explicit", "negative mass", bad, expect="refuse",
                  fields=("[body].mass",))]
    if must_refuse_the_valid_scene:
        cases.append(Case(1, "explicit", "a valid scene said to be hostile", base_scene(),
                          expect="refuse", fields=("name",)))
    return lambda n, seed: copy.deepcopy(cases)


@pytest.mark.parametrize("planted, status", [(False, 0), (True, 1)])
def test_verify_fuzz_exit_status(planted, status, monkeypatch, capsys):
    from derive.verify import fuzz
    monkeypatch.setattr(fuzz, "generate", _fuzz_cases(planted))
    got, out = _verdict(["verify", "fuzz", "--mode", "api", "-n", "2"], capsys)
    assert got == status
    assert ("BAD silent-accept #1" in out) == planted


# ---- verify robustness: two random scenes, or the same capped at ten steps ----------------
@pytest.mark.parametrize("capped, status", [(False, 0), (True, 1)])
def test_verify_robustness_exit_status(capped, status, monkeypatch, capsys):
    from derive.verify import robustness
    if capped:
        scene = robustness.random_scene

        def capped_scene(*args, **kwargs):
            doc = scene(*args, **kwargs)
            doc["run"]["max_steps"] = 10        # valid for both scenes, too few to end
            return doc
        monkeypatch.setattr(robustness, "random_scene", capped_scene)
    got, out = _verdict(["verify", "robustness", "-n", "2", "--workers", "1", "--duration",
                         "1", "--seed", "3", "--plane", "smooth"], capsys)
    assert got == status
    assert ("0 wrong statuses or invariants (2): FAIL" in out) == capped
    assert all(f"#{k} (smooth) status: ended with max_steps" in out
               for k in range(2)) == capped


def test_bench_sim_leaves_out_a_variant_short_of_the_target_and_names_it():
    """The 'any numbers' median counts only variants both routes reached at equal error;
    one that SciPy cannot reach is named, not averaged in (it ran at a looser error)."""
    from derive.bench import sim
    rows = [{"scipy_s": 0.065, "simulate_s": 0.065 / r, "ratio": r, "errors": (5e-10, 6e-10),
             "impact_errors": (1e-12, 1e-12), "met": True, "settings": (1e-9, 1e-10),
             "short": []} for r in (900.0, 1100.0, 1200.0)]
    rows.insert(1, {**rows[0], "ratio": 5000.0, "met": False, "short": ["SciPy"],
                    "errors": (5e-10, 3e-9)})
    ratios = np.array([r["ratio"] for r in rows if r["met"]])
    any_ = {"variants": rows, "met": 3, "median": float(np.median(ratios)),
            "min": 900.0, "max": 1200.0, "short": [(2, ["SciPy"], 3e-9)]}
    sc = {"rows": [{"route": "scipy DOP853", "seconds": 0.065},
                   {"route": "derive.simulate (law seen)", "seconds": 6e-5},
                   {"route": "derive.simulate (new law)", "seconds": 6e-4}],
          "any_numbers": any_}
    assert len(sim._scene_targets(sc)) == 2           # reported, no longer a target
    text = sim.any_numbers_line(any_)
    assert "3 of 4 variants" in text and "median 1100x" in text
    assert "variant 2: SciPy short of the target" in text


@pytest.mark.parametrize("argv, prog", [
    (["simulate", "--bogus"], "derive simulate"),
    (["bench", "sim", "--bogus"], "derive bench sim"),
    (["verify", "fuzz", "--bogus"], "derive verify fuzz"),
])
def test_an_unknown_option_is_reported_by_its_command(argv, prog, capsys):
    """An option a subcommand does not have is refused by that subcommand (not the top
    level's list of commands), in one line, exit 2."""
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err == f"{prog}: --bogus: is not an option of {prog} ({prog} -h: its options)\n"


def test_an_unknown_option_is_named_beside_a_missing_argument(capsys):
    """`derive plan --bogus` stopped at the missing TASK and never named --bogus."""
    with pytest.raises(SystemExit) as info:
        main(["plan", "--bogus"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err == ("derive plan: task: is required (derive plan -h: its arguments); --bogus: "
                   "is not an option of derive plan\n")


# ---- timings with their spread: a tie is not a failure -------------------------------------
def test_a_miss_within_the_spread_is_a_tie_and_beyond_it_a_failure():
    """derive.bench.timing judges a target on the median and the interquartile range:
    'stationary C4.2' at 1e-4 had read 0.011 against 0.011 ms and failed; samples of two
    routes as close as that tie, a route slower beyond its spread fails, one faster
    passes; the same for 'at least' targets and for paired ratios."""
    from derive.bench.timing import AT_LEAST, AT_MOST, Spread, judge, ratios, verdict
    ours = Spread.of([0.01100, 0.01104, 0.01109, 0.01112, 0.01120])
    peer = Spread.of([0.01095, 0.01101, 0.01106, 0.01115, 0.01118])
    assert ours.median > peer.median and verdict(ours.over(peer), AT_MOST, 1.0) == "TIE"
    slow = Spread.of([0.0130, 0.0131, 0.0132, 0.0133, 0.0134])
    assert verdict(slow.over(peer), AT_MOST, 1.0) == "FAIL"
    assert verdict(peer.over(slow), AT_MOST, 1.0) == "PASS"
    t = judge("x", Spread.of([1500.0, 1400.0, 980.0, 990.0, 995.0]), AT_LEAST, 1000.0)
    assert t.ok and t.mark == "TIE" and "target >= 1000x" in str(t) and str(t).endswith("TIE")
    t = judge("x", Spread.of([900.0, 950.0, 960.0, 970.0, 990.0]), AT_LEAST, 1000.0)
    assert not t.ok and t.mark == "FAIL"
    # paired samples: a common burst of load cancels in their ratio
    load = np.array([1.0, 3.0, 1.2, 5.0, 1.1])
    r = ratios(1.04 * load, load)
    assert r.median == pytest.approx(1.04) and r.hi - r.lo < 1e-12
    assert verdict(r, AT_MOST, 1.3) == "PASS" and verdict(r, AT_MOST, 1.0) == "FAIL"


def test_robustness_cost_counts_a_scene_shorter_than_a_second_as_one_second():
    """A scene's cost is a fixed part (~3 ms: the law proved and sampled) and a part per
    simulated second; a 0.2 s scene at twice the fixed part is not slow (per simulated
    second it was 10x the median: the rule before the floor), a run of 0.25 s or 3 s that
    runs away is."""
    from derive.verify import robustness as rb
    durations = np.linspace(0.2, 3.0, 99)
    ok = [rb.Outcome(k, "ok", "done", 0.003 + 0.0002 * d, 0.0, 0.1, float(d), plane="face")
          for k, d in enumerate(durations)]
    short = rb.Outcome(99, "ok", "done", 0.006, 0.0, 0.1, 0.2, plane="face")
    runaway = rb.Outcome(100, "ok", "done", 0.2, 0.0, 0.1, 0.25, plane="face")
    long_runaway = rb.Outcome(101, "ok", "done", 1.0, 0.0, 0.1, 3.0, plane="face")
    everything = ok + [short, runaway, long_runaway]
    slow = rb._cost(everything)[2]
    assert slow == [runaway, long_runaway]
    old = np.median([o.seconds / o.duration for o in everything])
    assert short.seconds / short.duration > 10 * old          # slow by the rule before


def test_robustness_retimes_a_run_past_10x_and_keeps_its_least_time():
    """A run past 10x its plane's median is timed again (robustness.retimed): one whose
    first time was a pause not its own (54 ms where it takes 3.6) is not slow after, one
    that runs away every time still is; the others are not run again."""
    from derive.verify import robustness as rb
    ok = [rb.Outcome(k, "ok", "done", 0.003, 0.0, 0.1, 1.0, plane="face") for k in range(50)]
    paused = rb.Outcome(50, "ok", "done", 0.054, 0.0, 0.1, 1.0, plane="face")
    runaway = rb.Outcome(51, "ok", "done", 0.5, 0.0, 0.1, 1.0, plane="face")
    tasks = [(k, 0, 3.0, "face") for k in range(52)]
    calls = []

    def again(task):
        calls.append(task[0])
        return rb.Outcome(task[0], "ok", "done", 0.0036 if task[0] == 50 else 0.45, 0.0,
                          0.1, 1.0, plane="face")
    out = rb.retimed(ok + [paused, runaway], tasks, run=again)
    assert sorted(set(calls)) == [50, 51] and len(calls) == 2 * rb.RETIMES
    assert out[50].seconds == 0.0036 and out[51].seconds == 0.45
    assert rb._cost(out)[2] == [out[51]]


# ---- derive emit's progress ---------------------------------------------------------------
def test_emit_tells_its_stages_on_stderr_and_nothing_with_quiet(tmp_path, capsys,
                                                               monkeypatch):
    """derive emit (half a minute) had printed nothing until its last line: each stage
    now has a line on stderr, the functions and models a bar (a plain line per tenth off
    a terminal); -q prints none of it.  The render is a stand-in that reports as the real
    one does (tests/test_wheel.py's emit checks the real counts)."""
    from derive.emit import driver

    def render_all(progress=None):
        if progress is not None:
            progress("deriving the functions", 0, 1, "")
            progress("deriving the functions", 1, 1, "2 functions")
            for k, name in enumerate(("f", "jac_f"), start=1):
                progress("the C functions", k, 2, name)
        return {"c/f.c": b"int f;\n"}
    monkeypatch.setattr(driver, "render_all", render_all)
    assert main(["emit", "-o", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "  emit: deriving the functions ..."
    assert [line.split("%")[0] for line in err[1:]] == ["  emit: the C functions:  50",
                                                        "  emit: the C functions: 100"]
    assert err[-1].endswith("2/2 jac_f")
    assert main(["emit", "-q", "-o", str(tmp_path / "b")]) == 0
    assert capsys.readouterr().err == ""
    assert (tmp_path / "b" / "c" / "f.c").read_bytes() == b"int f;\n"
