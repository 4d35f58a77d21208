"""A dynamicist's trial (trial3, scratch/FINDINGS.md 2, 3, 6, 7, 8): ``derive stability``
accepted [stability] keys and --set values it ignored, printed two ratios unnamed side by
side, and ``derive simulate --sweep`` wrote two columns of one name and counted variants
from 0 where elements count from 1.  Each case as the trial met it, through
``derive.cli.main``: a key acts or is refused (exit 2, one line naming it and the rule,
nothing written)."""
import csv
import tomllib
from pathlib import Path

import numpy as np
import pytest

from derive.cli import main
from derive.scene import load_scene

# the trial's scenes: a carrier bouncing on the plane (bl.toml, h19.toml) and C4.2's
# stationary rotation in free flight (c42i.toml)
BOUNCER = """name = "bouncer"
[body]
mass = 1.0
inertia = [0.1, 0.1, 0.15]
shape = "sphere"
radius = 0.5
[point]
mass = 0.25
law = ["0", "0", "0.07*sin(30*t)"]
[plane]
restitution = 0.5
[initial]
com = [0.0, 0.0, 0.6]
omega = [0.0, 0.0, 3.0]
[run]
duration = 20.0
[stability]
"""
ROTATION = """name = "C4.2 rotation"
[body]
mass = 1.0
inertia = [0.1, 0.12, 0.14]
shape = "none"
[point]
mass = 0.2
law = ["0.1", "-0.05", "0.15*cos(2*t) + 0.05*sin(2*t)"]
[initial]
omega = [0.0, 0.0, 2.0]
[run]
duration = 10.0
[stability]
"""


def _scene(tmp_path, text, name="s.toml") -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def _refused(capsys, argv, out=None) -> str:
    """The one line of a refusal (exit 2, nothing written to ``out``)."""
    rc = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "Traceback" not in err[0], (rc, err)
    assert out is None or not Path(out).exists()
    return err[0]


# ---- 2: every [stability] key acts or is refused ---------------------------------------------
@pytest.mark.parametrize("base, keys, extra, where, words", [
    # h19.toml: a period on the plane (it had been analysed at 2 pi/30 = 0.2094, rc 0)
    (BOUNCER, "period = 0.2\n", [], "[stability].period", "set impacts_every"),
    # c42i.toml: impacts_every in free flight (rc 0)
    (ROTATION, "long_periods = 0\nimpacts_every = 3\n", [], "[stability].impacts_every",
     "no impacts"),
    # perturbations with no perturbed run asked: sizes of nothing
    (BOUNCER, "perturbations = [1e-4]\n", [], "[stability].perturbations",
     "long_periods > 0"),
    (ROTATION, "long_periods = 20\nperturbations = [1e-4]\n", ["--long", "0"],
     "[stability].perturbations", "long_periods > 0"),
])
def test_a_stability_key_its_motion_does_not_read_is_refused(tmp_path, capsys, base, keys,
                                                             extra, where, words):
    line = _refused(capsys, ["stability", _scene(tmp_path, base + keys), "-q", *extra])
    assert line.startswith(f"derive stability: {where}: ") and words in line, line


def test_scene_check_says_what_derive_stability_would_refuse(tmp_path, capsys):
    """h19.toml passed derive scene check as if its period were read: check (valid: one
    scene serves every command) now names the key derive stability refuses."""
    assert main(["scene", "check", _scene(tmp_path, BOUNCER + "period = 0.2\n")]) == 0
    note = capsys.readouterr().out.splitlines()[-1]
    assert note.startswith("  [stability]: read by `derive stability` only") and \
        "which refuses [stability].period: periodic bouncing does not read it" in note


def test_the_table_of_keys_covers_the_schema():
    """STABILITY_KEYS names every [stability] field for each motion (a field left out
    would be neither read nor refused), and each motion reads some."""
    from derive.scene.schema import SCENE, STABILITY_KEYS
    fields = {f.key for f in SCENE.fields if f.table == "stability"}
    for kind, keys in STABILITY_KEYS.items():
        assert set(keys) == fields, kind
        assert all(why is None or why.strip() for why in keys.values())


def test_each_key_a_motion_reads_acts(tmp_path, capsys):
    """The other half of 'acts or is refused': each key read changes what is analysed.
    Free flight: period = 2 pi (two periods of C4.2's law), long_periods and
    perturbations (one run of 3 periods at eps = 1e-5); on the plane: impacts_every = 2
    (the 2-orbit: one impact every 2 periods, at a = 0.12, Gamma = 2.2 above its
    existence threshold 2.09)."""
    import json
    path = _scene(tmp_path, ROTATION + "period = 6.283185307179586\nlong_periods = 3\n"
                                      "perturbations = [1e-5]\n")
    assert main(["stability", path, "--json", "-q"]) == 0
    free = json.loads(capsys.readouterr().out)
    assert free["period"] == 2 * np.pi
    assert [(r["eps"], r["periods"]) for r in free["long_runs"]] == [(1e-5, 3)]
    path = _scene(tmp_path, BOUNCER.replace("0.07*sin", "0.12*sin") + "impacts_every = 2\n",
                  "b2.toml")
    assert main(["stability", path, "--json", "-q"]) == 0
    bounce = json.loads(capsys.readouterr().out)
    assert bounce["n"] == 2 and bounce["period"] == pytest.approx(2 * 2 * np.pi / 30,
                                                                  rel=1e-15)
    assert all(c["ok"] for c in bounce["checks"].values())


def test_long_periods_act_on_a_bouncing_orbit(tmp_path, capsys):
    """bl.toml: long_periods = 50, perturbations = [1e-4] on the plane had run nothing
    and said nothing, where the tilt modes on the unit circle are the critical case the
    runs exist for: now one perturbed run of 50 periods, named in the verdict."""
    path = _scene(tmp_path, BOUNCER + "long_periods = 50\nperturbations = [1e-4]\n")
    assert main(["stability", path, "-q"]) == 0
    out = capsys.readouterr().out
    assert "perturbed run, eps = 1e-04, 50 periods:" in out
    verdict = next(ln for ln in out.splitlines() if ln.startswith("  verdict: "))
    assert "tilt modes on the unit circle" in verdict and "perturbed runs: " in verdict


def test_a_bouncing_long_run_follows_the_monodromy():
    """A perturbed run of the hybrid runtime (impacts, flights in the momentum form)
    against the linear prediction of the monodromy (variational equations and the
    saltation matrix): for eps = 1e-7 each period's sample is q_mid + M^k delta to 1e-3
    of eps, the tilt turning while the spin's offset stays; the run's figures are those
    of the samples."""
    from derive.stability import bouncing
    b = bouncing.analyse(load_scene(tomllib.loads(BOUNCER)), check=False)
    hybrid = bouncing.HybridMap(b.scene)
    states: list = []
    run = bouncing.long_run(hybrid, b.t_mid, b.mid_state, b.period, 30, 1e-7,
                            states=states)
    assert run["periods"] == 30 and run["status"] == "done" and len(states) == 31
    d = bouncing.perturbed(b.mid_state, 1e-7) - b.mid_state
    for q in states:
        assert np.max(np.abs(q - b.mid_state - d)) <= 1e-10, np.abs(q - b.mid_state - d)
        d = b.monodromy @ d
    tilt = [np.r_[q[2:4], q[5:7]] - np.r_[b.mid_state[2:4], b.mid_state[5:7]]
            for q in states]
    assert np.max(np.abs(tilt[-1] - tilt[0])) > 1e-8         # the tilt modes turned
    dev = [float(np.max(np.abs(q[2:] - b.mid_state[2:]))) for q in states]
    assert run["initial"] == dev[0] and run["max_deviation"] == max(dev)


def test_an_unstable_orbit_says_why_it_ran_no_perturbed_run(capsys):
    """--long on an orbit a multiplier already condemns: no runs, and the verdict says so
    (it had said nothing of the long_periods asked)."""
    assert main(["stability", "--family", "bounce", "--set", "a=0.1", "--long", "5",
                 "-q"]) == 0
    out = capsys.readouterr().out
    assert "unstable (vertical modes" in out and "no perturbed runs (long_periods 5)" in out
    assert "perturbed run, eps" not in out


# ---- 3: --set of a family: one name once, one view of a parameter ------------------------------
@pytest.mark.parametrize("argv, words", [
    (["stability", "--family", "bounce", "--set", "Gamma=1.2", "--set", "a=0.07"],
     "Gamma and a: are two views of one parameter"),
    (["stability", "--family", "bounce", "--set", "a=0.07", "--set", "a=0.08"],
     "--set: 'a' is set twice (0.07, then 0.08)"),
    (["stability", "--family", "C4.2", "--set", "omega=2", "--set", "omega=3"],
     "--set: 'omega' is set twice"),
])
def test_a_family_parameter_given_twice_is_refused(capsys, argv, words):
    assert words in _refused(capsys, [*argv, "-q"])


@pytest.mark.parametrize("axes", [
    ["--x", "Gamma=1:2:3", "--y", "e=0.3:0.5:2", "--set", "a=0.07"],
    ["--x", "a=0.05:0.1:3", "--y", "Gamma=1:2:2"],
    ["--set", "a=0.07", "--set", "a=0.08"],
])
def test_a_bounce_chart_takes_one_view_of_the_amplitude(tmp_path, capsys, axes):
    """Every point of a chart given both Gamma and a had been charted as 'no body' (its
    values refused one by one): refused before a point runs."""
    out = tmp_path / "chart"
    line = _refused(capsys, ["chart", "stability", "--family", "bounce", *axes, "-o",
                             str(out), "-q"], out)
    assert "Gamma and a" in line or "set twice" in line


# ---- 6: the perturbed runs' two normalisations, named ---------------------------------------
def test_the_perturbed_runs_name_each_ratio():
    """c42.toml printed '(omega, n) max deviation 1.744e-05 (x12.7)' beside a verdict's
    'max deviation / eps from 4.7 to 17.4': the line now names both ratios, each the
    quotient of the figures it prints."""
    from derive.stability import scenes
    from derive.stability.floquet import runs_verdict
    runs = [{"eps": eps, "periods": 200, "initial": 1.372 * eps, "max_deviation": dev,
             "growth_ratio": dev / (1.372 * eps), "envelope_exponent": 1.0,
             "growth": "bounded", "initial_omega": 1.372 * eps,
             "max_deviation_omega": 1.372 * eps, "growth_ratio_omega": 1.0,
             "envelope_exponent_omega": 0.0, "growth_omega": "bounded"}
            for eps, dev in ((1e-6, 1.744e-5), (1e-2, 4.696e-2))]
    result = {"scene": "c42", "kind": "periodic free flight", "period": np.pi,
              "multipliers": [], "moduli": [], "det": 1.0, "liouville": 1.0, "blocks": {},
              "checks": {}, "long_runs": runs, "verdict": runs_verdict(runs)}
    lines = scenes.text(result).splitlines()
    first = next(ln for ln in lines if "(omega, n) max deviation" in ln)
    assert ("max deviation 1.744e-05 = 12.7 x the starting deviation 1.372e-06 = 17.4 x eps"
            in first), first
    assert "(a run's max deviation / its eps 4.7 to 17.4)" in lines[-1]


# ---- 7, 8: sweep.csv's names each once, variants counted from 1 -----------------------------
@pytest.mark.parametrize("sweeps, words", [
    (["point.law[2]=0.07*sin(W*t) for W=30", "point.law[0]=0.01*sin(W*t) for W=3,4"],
     "W, the name of its swept number, already names the swept number of point.law[2]"),
    (["point.law[2]=0.07*sin(impacts*t) for impacts=30"], "sweep.csv's column impacts"),
])
def test_a_column_name_used_twice_is_refused(tmp_path, capsys, sweeps, words):
    out = tmp_path / "sweep"
    argv = ["simulate", "-q", "-o", str(out)]
    for s in sweeps:
        argv += ["--sweep", s]
    assert words in _refused(capsys, argv, out)


def test_variants_count_from_1_as_sweep_csv_numbers_them(tmp_path, capsys):
    """--sweep plane.restitution=0.1,2 said 'variant 1' of the second (from 0) while
    elements count from 1: the message and sweep.csv's variant column agree, from 1."""
    out = tmp_path / "sweep"
    assert main(["simulate", "-q", "--no-plots", "-o", str(out), "--sweep",
                 "plane.restitution=0.1,2", "--set", "run.duration=0.5"]) == 1
    said = capsys.readouterr().out
    assert "e.g. variant 2: [plane].restitution" in said, said
    rows = list(csv.DictReader(open(out / "sweep.csv", encoding="utf-8")))
    assert [r["variant"] for r in rows] == ["1", "2"]
    assert rows[1]["plane_restitution"] == "2.0" and rows[1]["error"].startswith("variant 2: ")
    assert rows[0]["status"] == "done" and rows[0]["error"] == ""
