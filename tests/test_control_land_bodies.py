"""derive control on a land task of several bodies (``[plan].decide``; a new user's trial:
a hopping robot's landing by one of its two masses never ran).  The task is the trial's
made small (a drop of 0.65 m, six pieces, one RK4 step each) so that its setup, one per
module, takes a few seconds.  Each check compares with something computed another way:

* the plant's tables run past the plan's (land's default duration, touchdown and a
  fifth, against the plan's table, touchdown and a twentieth: the plant was refused,
  naming a [disturbance] the task may not have): played undisturbed, the plant touches
  down when the planner's own re-simulation of its scene.toml did, and after the plan's
  end the decided point stays where the law holds it (at rest);
* the pipeline end to end (the open loop's measure read a point law a plan of bodies
  does not have: a traceback): the closed loop lands within the goal where the plan
  played on the pushed plant misses it;
* a plant refused is named for what refused it: the plan's scene (no field of the
  task's) or [disturbance]'s factors;
* a run that stopped early says so on its printed line (control.json's status).
"""
from __future__ import annotations

import tomllib
from dataclasses import replace

import numpy as np
import pytest

from derive.control.core import ControlError, load_control_task, plant_of
from derive.control.replan import run, setup
from derive.scene import SceneError
from derive.scene.scene import Disturbance

TASK = """
name = "a small landing by a decided point"
[body]
mass = 1.0
inertia = [0.016, 0.017, 0.018]
shape = "sphere"
radius = 0.15
[[point]]
mass = 0.2
law = ["0.02", "0", "0"]
[[point]]
mass = 0.4
[plane]
restitution = 0.5
[initial]
com = [0.0, 0.0, 0.8]
omega = [0.2, -0.1, 0.3]
[plan]
goal = "land"
horizon = 0.4
decide = ["point 2"]
target_matrix = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
region = { center = [0.0, 0.0, 0.0], radius = 0.1 }
max_acceleration = 60.0
rest_at_ends = true
intervals = 6
substeps = 1
[control]
mode = "replan"
period = 0.02
intervals = 6
[disturbance]
pushes = [ { time = 0.1, impulse = [0.0, 0.03, 0.0], at = [0.15, 0.0, 0.0] } ]
"""


@pytest.fixture(scope="module")
def su():
    return setup(load_control_task(tomllib.loads(TASK)))


@pytest.fixture(scope="module")
def result(su):
    return run(su.task, setup_=su)


def test_the_plants_table_runs_past_the_plans_and_plays_the_plan(su):
    T = su.T_plan
    table_end = max(float(r[-1, 0]) for r in su.plan.tables.values())
    assert su.duration == pytest.approx(1.2 * T) and table_end < su.duration
    opened = su.open(su.plant(None), None)
    assert opened.status == "done" and opened.t[-1] == pytest.approx(su.duration)
    planned = su.plan.summary.achieved["runtime"]["touchdown_time"]
    assert opened.impacts[0, 0] == pytest.approx(planned, abs=1e-9)
    # past the plan's end the decided point is held where the law ends, at rest
    rows = np.loadtxt(f"{su.folder.name}/point2.csv", delimiter=",", skiprows=1)
    late = rows[rows[:, 0] > T]
    assert rows[-1, 0] == pytest.approx(su.duration) and len(late) > 1
    end = su.plan.law.u([T])[:, 0]
    np.testing.assert_allclose(late[:, 1:4], np.tile(end[0:3], (len(late), 1)),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(late[:, 4:], 0.0, rtol=0, atol=1e-12)


def test_land_by_a_decided_point_closes_the_loop_end_to_end(result):
    s = result.summary
    closed, opened = s["closed_loop"], s["open_loop"]
    assert closed["status"] == "done" and opened["status"] == "done"
    assert closed["goal_met"] and not opened["goal_met"], (closed, opened)
    assert closed["attitude_error_rad"] < 0.1 * opened["attitude_error_rad"]
    assert s["controller"]["qp_failures"] == 0 and s["controller"]["calls"] > 10


def test_a_run_that_stopped_early_says_its_status(result):
    from derive.control.cli import report_lines
    lines = report_lines(result)
    assert not any("stopped early" in ln for ln in lines)
    stopped = dict(result.summary["closed_loop"], status="step_underflow", goal_met=False)
    other = replace(result, summary=dict(result.summary, closed_loop=stopped))
    line = next(ln for ln in report_lines(other) if "closed loop" in ln)
    assert "stopped early: step_underflow" in line and "goal NOT met" in line


def test_a_refused_plant_is_named_for_what_refused_it(su):
    doc = dict(su.doc, run=dict(su.doc["run"], duration=3 * su.duration))
    for dist in (None, Disturbance(mass_factor=1.1)):   # the plan's table: not the task's
        with pytest.raises(ControlError, match="offline plan's scene"):
            plant_of(doc, dist, su.folder.name)
    bad = Disturbance(inertia_factor=(3.0, 1.0, 1.0))    # J_x > J_y + J_z
    assert 3.0 * 0.016 > 0.017 + 0.018
    with pytest.raises(SceneError) as info:
        plant_of(su.doc, bad, su.folder.name)
    assert info.value.where == "[disturbance]"
