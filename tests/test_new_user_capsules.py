"""What a new user of capsule robots met (issue 33's new-user report), each end to end
through ``derive`` as they ran it.

* A face run that stops early (tipping, face_lifting, lift_off, at t = 0 too) writes its
  files and says its status with the time, exit 1, no traceback: the ending event has a
  ``before`` row only, which events.csv used to index past.
"""
import warnings
from pathlib import Path

import numpy as np
import pytest

from derive.cli import main

EXAMPLE = Path(__file__).parents[1] / "derive" / "scene" / "examples" / "capsule-crawler.toml"
_LAW = '["0.05*(sin(12*t) + 0.4*sin(24*t))", "0", "0.02"]'


def _crawler(tmp_path, law, extra=""):
    text = EXAMPLE.read_text().replace(_LAW, law)
    assert law in text
    text = text.replace("static_friction = 0.35", "static_friction = 0.35\n" + extra)
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


ENDS = [  # (law, [plane] extra, status, plots): each stops well inside the 10 periods
    # (events.csv names the stop's event by its kind, the status's own name)
    ('["0.05*sin(60*t)", "0", "0.02"]', "", "tipping", False),
    ('["0.05*sin(60*t)", "0", "0.02"]', 'pressure = "linear"', "face_lifting", False),
    ('["0", "0", "0.02 + 0.01*sin(80*t)"]', "", "lift_off", False),
    ('["0.5", "0", "0.5"]', "", "tipping", True),            # a point on a mast: at t = 0
]


@pytest.mark.parametrize("law, extra, status, plots", ENDS)
def test_an_early_stopped_face_run_writes_its_files_and_says_why(tmp_path, capsys, law,
                                                                 extra, status, plots):
    out = tmp_path / "out"
    args = ["simulate", str(_crawler(tmp_path, law, extra)), "-o", str(out), "-q"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")       # (a run of one instant: no singular xlim)
        rc = main(args + ([] if plots else ["--no-plots"]))
    said = capsys.readouterr().out
    assert rc == 1
    assert f": {status};" in said.splitlines()[0] and "stopped at t = " in said
    names = {"trajectory.csv", "events.csv", "impacts.csv", "summary.json"}
    assert names | ({"overview.png"} if plots else set()) <= {p.name for p in out.iterdir()}
    events = (out / "events.csv").read_text().splitlines()
    last = [line.split(",") for line in events[-2:]]
    assert [row[:2] for row in last] == [[status, "before"], [status, "after"]]
    t_stop = float(last[0][2])
    traj = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1, ndmin=2)
    assert traj[-1, 0] <= t_stop + 1e-12 and t_stop < 5.0
    if plots:
        assert t_stop == 0.0


TRAVEL = Path(__file__).parents[1] / "derive" / "planner" / "examples" / "travel.toml"


def _hard_travel(tmp_path, cap=30):
    """The user's task: a 1.5 kg box 0.3 x 0.1 x 0.08 m, max_acceleration 800, max_velocity
    10; its first laws crawl fast for two periods and slow (or tip) later."""
    text = (TRAVEL.read_text().replace("mass = 1.0", "mass = 1.5")
            .replace("half_extents = [0.1, 0.06, 0.04]", "half_extents = [0.15, 0.05, 0.04]")
            .replace("max_velocity = 1.0", "max_velocity = 10.0")
            .replace("max_acceleration = 40.0", "max_acceleration = 800.0"))
    path = tmp_path / "task.toml"
    path.write_text(text + f"max_iterations = {cap}\n")
    return path


def test_a_solved_travel_plan_delivers_its_speed_in_the_scene_it_writes(tmp_path, capsys):
    from derive.runtime import base_report
    from derive.runtime.driver import simulate
    out = tmp_path / "plan"
    rc = main(["plan", str(_hard_travel(tmp_path)), "-o", str(out), "-q"])
    said = capsys.readouterr().out
    assert "stopped at its iteration cap ([plan].max_iterations = 30)" in said
    plan = __import__("json").loads((out / "plan.json").read_text())
    assert (rc == 0) == (plan["status"] == "solved")
    res = simulate(str(out / "scene.toml"))      # the written scene, run apart
    tr = base_report.travel(res)
    if rc == 0:
        assert res.status == "done"
        last = tr["last_period_displacement"][0] / plan["law"]["period"]
        assert abs(last - plan["forward_speed"]) <= 0.02 * plan["forward_speed"]
    else:
        assert "the written scene.toml, run as derive simulate runs it" in plan["message"]


def test_a_travel_plan_that_its_scene_does_not_deliver_fails_in_words(tmp_path, capsys,
                                                                      monkeypatch):
    from derive.planner import travel
    monkeypatch.setattr(travel, "DELIVERED", -1.0)       # no re-run can deliver
    rc = main(["plan", str(_hard_travel(tmp_path, cap=10)), "-o", str(tmp_path / "o"), "-q"])
    cap = capsys.readouterr()
    assert rc == 1 and cap.out.startswith("travel: failed")
    assert "derive plan: failed: the written scene.toml, run as derive simulate runs it, " \
           "crawls" in cap.err


_TILT = "[[0.984807753, 0.0, 0.173648178], [0.0, 1.0, 0.0], [-0.173648178, 0.0, 0.984807753]]"
FALLS_OUT = [  # (a change to the crawler, the field said, the cause said)
    ("[initial]\n", f"[initial]\nmatrix = {_TILT}\n", "[initial].matrix",
     "puts a box on the plane on an edge"),     # (10 degrees about y: the edge along y)
    ("[initial]\n", "[initial]\nomega = [0.0, 1.0, 0.0]\n", "[initial].omega",
     "is not along the vertical"),
    ("carrier_velocity = [0.0, 0.0, 0.0]", "carrier_velocity = [0.0, 0.0, 0.3]",
     "[initial].carrier_velocity", "O starts with a vertical velocity"),
    ("friction = 0.3 ", "friction = 0.0 ", "[plane].restitution", "[plane].friction = 0"),
    ("static_friction = 0.35 ", "", "[disturbance]", "a push would tilt the body"),
]


@pytest.mark.parametrize("old, new, field, cause", FALLS_OUT)
def test_a_scene_that_falls_out_of_the_face_down_model_names_the_cause(tmp_path, capsys, old,
                                                                       new, field, cause):
    text = EXAMPLE.read_text()
    assert old in text
    text = text.replace(old, new, 1)
    if field == "[disturbance]":
        text += ("\n[disturbance]\npushes = [{time = 0.2, impulse = [0.0, 0.05, 0.0], "
                 "at = [0.05, 0.0, 0.0]}]\n")
    path = tmp_path / "scene.toml"
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["simulate", str(path), "-o", str(out), "--no-plots", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"derive simulate: {field}: ")
    assert cause in err[0] and not out.exists()


TASK_SLIPS = [  # (a change to the travel example, the field said, what it says)
    ("friction = 0.3\n", "friction = 0.3\nspin_friction = 0.01\n", "[plane].spin_friction",
     "is a scene key that a task does not read"),
    ("friction = 0.3\n", "friction = 0.3\nrestitution = 0.0\n", "[plane].restitution",
     "is not read by travel"),
    ("on_plane = true\n", "on_plane = true\ncarrier_velocity = [0.0, 0.0, 0.0]\n",
     "[initial].carrier_velocity", "which the planner makes"),
]


@pytest.mark.parametrize("old, new, field, says", TASK_SLIPS)
def test_a_travel_tasks_slips_are_said_whole(tmp_path, capsys, old, new, field, says):
    text = TRAVEL.read_text()
    assert old in text
    path = tmp_path / "task.toml"
    path.write_text(text.replace(old, new, 1))
    out = tmp_path / "out"
    assert main(["plan", str(path), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"derive plan: {field}: ") and says in err[0]
    assert not out.exists()


def test_planning_md_travel_task_is_one_the_planner_takes():
    """planning.md's travel task, as printed, parses (it gave restitution, which the scene
    the plan writes refuses)."""
    from derive.planner.task import parse_task
    doc = (Path(__file__).parents[1] / "derive" / "docs" / "planning.md").read_text()
    start = doc.index("```toml\n", doc.index('goal = "travel"') - 1200) + len("```toml\n")
    task = parse_task(doc[start:doc.index("```", start)])
    assert task.goal == "travel"


def test_a_capsules_law_is_swept_by_its_element_and_sweep_csv_says_w(tmp_path, capsys):
    """point[1].law[0] names [[point]] 1's first formula (point.law[0] the only one's);
    sweep.csv carries W's own column, and a base run's impact columns are empty."""
    two = EXAMPLE.parent / "two-mass-capsule.toml"
    sweep = "point.law[0]=0.05*sin(W*t) for W=10,20"
    assert main(["simulate", str(two), "--sweep", sweep, "-o", str(tmp_path / "x")]) == 2
    assert "name one, as point[1].law[0]" in capsys.readouterr().err
    rows = {}
    for name in ("point", "point[1]"):
        out = tmp_path / name
        assert main(["simulate", str(EXAMPLE), "--sweep", sweep.replace("point", name, 1),
                     "-o", str(out), "-q", "--no-plots"]) == 0
        lines = (out / "sweep.csv").read_text().splitlines()
        head = lines[0].split(",")
        assert head[0] == "variant" and head[2] == "W"
        rows[name] = [dict(zip(head, line.split(","))) for line in lines[1:]]
    for r, w in zip(rows["point"], ("10.0", "20.0")):
        assert r["W"] == w and r["status"] == "done" and r["model"] == "base"
        assert r["impacts"] == r["contacts"] == r["min_height"] == r["first_contact_t"] == ""
    # the two sweeps ran the same laws: the same travel (the one formula set two ways)
    assert [r["X_C_end"] for r in rows["point"]] == [r["X_C_end"] for r in rows["point[1]"]]
    assert rows["point"][0]["X_C_end"] != rows["point"][1]["X_C_end"]


def test_a_signed_sweep_colours_a_slow_crawl_forward_beside_a_fast_slide_back():
    """README's capsule sweep: 6.6 mm/s forward, 71 mm/s back; on the old symmetric scale
    the forward cell sat at 0.55 of the colour range (white)."""
    from derive.runtime.sweep_plot import signed_norm
    Z = np.ma.masked_invalid(np.array([[-0.0709, 0.0, 0.0066], [0.0052, -0.01, np.nan]]))
    norm = signed_norm(Z)
    assert float(norm(0.0066)) == 1.0 and float(norm(-0.0709)) == 0.0
    assert float(norm(0.0)) == 0.5 and float(norm(0.0052)) > 0.89


def test_chart_modes_runs_another_scene_of_the_papers_kind_and_refuses_others(tmp_path,
                                                                              capsys):
    """derive chart modes --scene: a point on another circle (r 0.04 m about x = 0.01,
    w = 15 rad/s, another phase) maps the same types cell by cell as the example, as
    the motion depends on mu and beta alone; a law off a circle, or a second friction
    coefficient, is refused by field."""
    bp = EXAMPLE.parent / "bardin-panev.toml"
    law = 'law = ["0.05*cos(20*t)", "0", "0.05*sin(20*t)"]'
    text = bp.read_text()
    assert law in text
    other = tmp_path / "other.toml"
    other.write_text(text.replace(law, 'law = ["0.01 + 0.04*sin(15*t + 1.5707963267948966)"'
                                       ', "0", "0.04*sin(15*t)"]'))
    grid = ["--x", "mu=0.1,0.5", "--y", "beta=0.3,0.6", "--periods", "10", "-q"]
    types = {}
    for name, scene in (("example", []), ("other", ["--scene", str(other)])):
        assert main(["chart", "modes", *scene, *grid, "-o", str(tmp_path / name)]) == 0
        lines = (tmp_path / name / "modes.csv").read_text().splitlines()[1:]
        types[name] = [line.split(",")[4] for line in lines]
    assert types["other"] == types["example"]
    assert {"two reversals", "at rest", "a rest and a reversal"} <= set(types["example"])
    capsys.readouterr()
    off = tmp_path / "off.toml"
    off.write_text(text.replace("0.05*sin(20*t)", "0.03*sin(20*t)"))
    two = tmp_path / "two.toml"
    two.write_text(text.replace("friction = 0.3 ", "friction = 0.3\nstatic_friction = 0.4 "))
    for path, field in ((off, "[point].law"), (two, "[plane].static_friction")):
        assert main(["chart", "modes", "--scene", str(path), *grid,
                     "-o", str(tmp_path / "x")]) == 2
        assert capsys.readouterr().err.startswith(f"derive chart: {field}: ")
