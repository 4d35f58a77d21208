"""The flat landing's rule at its edges, each side computed apart from the runtime's C:

* the height resolution the rule compares with (crt_plane.h's crt_height_resolution through
  crt_kept_rtol and crt_kept_atol) is the rule's own arithmetic, 10 max(atol + rtol (|Z_C|
  + L), 64 eps (|Z_C| + L)) with rtol and atol the scene's under an adaptive method and
  (64 eps, 0) under RK4, which keeps no tolerance (derive/docs/runtime.md);
* model.c.jinja's model_face_spread_n on faces tests/test_flat_landing.py does not land
  on: a cylinder in the general model dropped on its end, and a box on its -x face (the
  face of half-extents b, c), each tilted about a horizontal diagonal by 0.98 and 1.02 of
  the angle whose spread (2 R sin theta; sqrt(2) sin theta (b + c)) equals that resolution:
  the first stops flat_landing with the spread of derive/face.py's face
  (handover.flat_spread), the second takes an impact on the rim's (the corner's) lowest
  point at the free fall's time.  The tilt puts the vertical along two body axes at once,
  so either term of the spread dropped, or the cylinder's end not taken for its face,
  moves the 1.02 side under the resolution or the 0.98 side off it.
"""
import math

import numpy as np
import pytest

from derive import layout
from derive.runtime import choice, handover
from derive.runtime.driver import simulate
from derive.scene import parse_scene

G = layout.GENERAL
g = 9.81
EPS = np.finfo(float).eps
Z0 = 0.5
R, H = 0.06, 0.08                   # the cylinder's radius and half-length
a, b, c = 0.1, 0.05, 0.03           # the box's half-extents

_CYLINDER = """name = "cylinder dropped on its end"
[body]
mass = 1.0
inertia = [0.004, 0.004, 0.002]
shape = "cylinder"
radius = {R}
half_length = {H}
[point]
mass = 0.1
law = ["0.02*sin(5*t)", "0", "0"]
[plane]
restitution = 0.5
[initial]
com = [0.0, 0.0, {Z0}]
quaternion = {q}
[run]
duration = 0.31
{run}
"""

# the point moves along body z, horizontal once body x points down: through O, no torque
_BOX = """name = "box dropped on its -x face"
[body]
mass = 1.0
inertia = [0.0011, 0.0035, 0.0042]
shape = "box"
half_extents = [{a}, {b}, {c}]
[point]
mass = 0.1
law = ["0", "0", "0.02*sin(5*t)"]
[plane]
restitution = 0.5
[initial]
com = [0.0, 0.0, {Z0}]
quaternion = {q}
[run]
duration = 0.31
{run}
"""

# body x turned down: a quarter turn about the world's y
_X_DOWN = (math.cos(math.pi / 4.0), 0.0, math.sin(math.pi / 4.0), 0.0)
# (scene, attitude before the tilt, the face's depth below C, K: the spread is K sin theta)
_CASES = {"cylinder": (_CYLINDER, (1.0, 0.0, 0.0, 0.0), H, 2.0 * R),
          "box -x": (_BOX, _X_DOWN, a, math.sqrt(2.0) * (b + c))}


def _qmul(p, q):
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


def _tilt(theta):
    """A turn by theta about the world's horizontal (1, 1, 0)/sqrt(2)."""
    s = math.sin(theta / 2.0) / math.sqrt(2.0)
    return (math.cos(theta / 2.0), s, s, 0.0)


def _run(case, theta=0.0, run=""):
    text, base, _, _ = _CASES[case]
    q = _qmul(_tilt(theta), base)
    return simulate(parse_scene(text.format(R=R, H=H, a=a, b=b, c=c, Z0=Z0, run=run,
                                            q=[float(x) for x in q])))


def _resolution(run, i, rtol=1e-10, atol=1e-12, rk4=False):
    """The rule's arithmetic at row i (the schema's default tolerances)."""
    size = abs(run.model_q[i, G.com][2]) + choice.length_scale(run.scene)
    if rk4:
        rtol, atol = 64.0 * EPS, 0.0
    return 10.0 * max(atol + rtol * size, 64.0 * EPS * size)


@pytest.fixture(scope="module", params=sorted(_CASES))
def flat(request):
    return request.param, _run(request.param)


@pytest.mark.parametrize("method, rtol, atol", [("dop853", 1e-10, 1e-12),
                                                ("dopri5", 1e-9, 3e-11),
                                                ("rk4", 1e-3, 1e-3)])
def test_the_height_resolution_is_the_rules_arithmetic(method, rtol, atol):
    """rtol and atol under the adaptive methods (atol a sizeable share in the second),
    round-off under RK4 whatever the scene says."""
    run = _run("cylinder", run=f'method = "{method}"\nrtol = {rtol}\natol = {atol}')
    assert run.status == "flat_landing"
    i = len(run.t) - 1
    want = _resolution(run, i, rtol, atol, rk4=method == "rk4")
    assert abs(handover.noise(run, i)[0] - want) <= 1e-15 * want


def test_flat_on_the_face_at_the_free_fall_time(flat):
    case, run = flat
    drop = _CASES[case][2]
    assert run.model == "general" and run.status == "flat_landing"
    (ev,) = run.events
    t_fall = math.sqrt(2.0 * (Z0 - drop) / g)
    assert ev["kind"] == "flat_landing" and abs(ev["t"] - t_fall) < 1e-9
    assert ev["value"] <= 1e-15 and handover.flat_spread(run.scene, run.model_q[-1, G.A]) \
        <= 1e-15


def test_tilt_either_side_of_the_resolution(flat):
    case, run = flat
    _, _, drop, K = _CASES[case]
    theta = math.asin(_resolution(run, len(run.t) - 1) / K)     # K sin(theta): the resolution
    t_fall = math.sqrt(2.0 * (Z0 - drop) / g)
    below = _run(case, 0.98 * theta)
    assert below.status == "flat_landing" and [e["kind"] for e in below.events] == \
        ["flat_landing"]
    spread = below.events[0]["value"]
    assert abs(spread - K * math.sin(0.98 * theta)) < 1e-6 * spread
    assert abs(spread - handover.flat_spread(below.scene, below.model_q[-1, G.A])) \
        < 1e-6 * spread
    above = _run(case, 1.02 * theta)
    first = above.events[0]
    assert first["kind"] == "impact" and abs(first["t"] - t_fall) < 1e-9
