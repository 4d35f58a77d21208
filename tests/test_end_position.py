"""Where C ends, as summary.json, the console, sweep.csv and Batch.column say it, against the
run's own last state (trajectory.csv's X_C, Y_C), for every model that holds C's horizontal
position in its state.  A new user found the moments_rough model reported the smooth plane's
uniform drift (X_C0 + X_C0' t) instead: friction had moved C and the summary did not see it."""
import numpy as np
import pytest

import derive
from derive import layout
from derive.runtime import report
from derive.scene.parse import parse_scene

TWO = """
name = "two points and a rotor, pushed"
[body]
mass = 1.0
inertia = [0.004, 0.004, 0.004]
shape = "sphere"
radius = 0.1
[[point]]
mass = 0.1
law = ["0.05*sin(3*t)", "0", "0"]
[[point]]
mass = 0.1
law = ["0", "0.05*sin(3*t)", "0.02*cos(3*t)"]
[[rotor]]
axis = [0.0, 0.0, 1.0]
inertia = 0.002
law = "40*t - 10*cos(t)"
[plane]
restitution = 0.5
friction = FRICTION
[initial]
com = [0.0, 0.0, 0.5]
com_velocity = [0.4, -0.2, 0.0]
[run]
duration = 1.5
"""


@pytest.mark.parametrize("friction, model", [(0.3, "moments_rough"), (0.0, "moments")])
def test_summary_travel_is_the_last_state(friction, model):
    scene = parse_scene(TWO.replace("FRICTION", str(friction)))
    result = derive.simulate(scene)
    assert result.model == model
    G = layout.GENERAL
    x_end, y_end = result.model_q[-1][G.horizontal]
    travel = report.summary(result)["travel"]
    assert travel["X_C_end"] == pytest.approx(x_end, abs=1e-12)
    assert travel["Y_C_end"] == pytest.approx(y_end, abs=1e-12)
    drift = (0.4 * 1.5, -0.2 * 1.5)                 # the smooth plane's uniform motion
    if friction:                                    # friction moved C: the drift is wrong
        assert abs(x_end - drift[0]) > 1e-3
    else:
        assert (x_end, y_end) == pytest.approx(drift, abs=1e-9)
    batch = derive.simulate_many(scene, [{"plane.restitution": 0.5}])
    assert batch.column("X_C_end")[0] == pytest.approx(x_end, abs=1e-12)
    assert batch.column("distance")[0] == pytest.approx(np.hypot(x_end, y_end), abs=1e-12)
