"""A box or a cylinder that comes down on a face flat stops there, status flat_landing
(crt_collide: every corner of the face within the runtime's height resolution is a
multi-point impact no model makes), in every flight, not only a base run's after its
lift-off; a touch on one corner goes on.  Each check against something computed apart:

* trial 3's box (identity attitude, omega 0, the point moving along body x: no torque,
  the body translates) stops at its first touch: the time against the free fall's closed
  form, the event's v_n against -g t, its spread 0; the box on a rough plane (the rough
  model) likewise, and the box started on the plane moving down (the touch before the
  first step), at t0; a cylinder standing on its end in the translational model bounces
  instead (omega = 0 and C above the face's centre, C2.4: the one-point impact at the
  centre is the multi-point impact's own answer), v_n+ = -e v_n- at the free fall's time;
* the same box tilted about the horizontal diagonal by 0.98 and 1.02 of the angle whose
  spread (2 (a |n_x| + b |n_y|), derive/runtime/handover.py's flat_spread, written from
  the face apart from the C's) equals the runtime's height resolution at the touch: the
  first stops flat_landing, the second lands on the corner (a, -b, -c), its impulse the
  single-point impact's closed form (1 + e) |v_n| / (1/m + (r x n) J_C^-1 (r x n)), and
  goes on to the next touch (the opposite corner, the face flat again: flat_landing);
* the batch (derive.simulate_many) gives each variant's status and end time as one run
  does: two drop heights in bulk, the two tilts one at a time.
"""
import math

import numpy as np
import pytest

import derive
from derive import layout
from derive.runtime import handover
from derive.runtime.driver import simulate
from derive.scene import parse_scene

G = layout.GENERAL
g = 9.81
M, m, e = 1.0, 0.1, 0.5
a, b, c = 0.1, 0.05, 0.03
J = (0.0011, 0.0035, 0.0042)
Z0 = 0.5

# trial 3's scene (/work/wt/trial3/scratch/flatbox2.toml)
_BOX = f"""
name = "flat box drop"
[body]
mass = {M}
inertia = [{J[0]}, {J[1]}, {J[2]}]
shape = "box"
half_extents = [{a}, {b}, {c}]
[point]
mass = {m}
law = ["0.02*sin(5*t)", "0", "0"]
[plane]
restitution = {e}
{{plane}}
[initial]
com = [0.0, 0.0, {Z0}]
quaternion = {{quaternion}}
[run]
duration = {{duration}}
"""


def box(quaternion=(1.0, 0.0, 0.0, 0.0), duration=1.0, plane=""):
    return parse_scene(_BOX.format(quaternion=list(quaternion), duration=duration,
                                   plane=plane))


def t_fall(z0=Z0, drop=c):
    """C falls freely (no torque: the point moves along the line through O) until the
    face, c below C, reaches the plane."""
    return math.sqrt(2.0 * (z0 - drop) / g)


def tilt(theta):
    """The quaternion of a turn by theta about the horizontal (1, 1, 0)/sqrt(2): n =
    (-sin theta, sin theta, cos theta sqrt 2)/sqrt 2, the lowest corner (a, -b, -c)."""
    s = math.sin(theta / 2.0) / math.sqrt(2.0)
    return (math.cos(theta / 2.0), s, s, 0.0)


@pytest.fixture(scope="module")
def flat():
    return simulate(box())


def test_trial_box_lands_flat_at_the_free_fall_time(flat):
    assert flat.status == "flat_landing" and flat.model == "general"
    (ev,) = flat.events
    assert ev["kind"] == "flat_landing" and flat.stats["impacts"] == 0
    assert abs(ev["t"] - t_fall()) < 1e-9 and abs(flat.t[-1] - t_fall()) < 1e-9
    assert abs(ev["v_minus"] + g * t_fall()) < 1e-8 and math.isnan(ev["v_plus"])
    assert ev["value"] == 0.0 == handover.flat_spread(flat.scene, flat.model_q[-1, G.A])
    # no impulse applied: the last row is the touch's, the body not turned
    assert np.all(flat.model_q[-1, G.omega] == 0.0)


def test_the_rough_model_lands_flat():
    run = simulate(box(plane="friction = 0.5"))
    assert run.model == "rough" and run.status == "flat_landing"
    assert [ev["kind"] for ev in run.events] == ["flat_landing"]
    assert abs(run.events[0]["t"] - t_fall()) < 1e-9


_CYLINDER = """name = "cylinder on its end"
[body]
mass = 1.0
inertia = [0.004, 0.004, 0.002]
shape = "cylinder"
radius = 0.06
half_length = 0.08
[point]
mass = 0.1
law = ["0", "0", "0"]
[plane]
restitution = 0.5
[initial]
com = [0.0, 0.0, 0.5]
[run]
duration = 1.0
"""


def test_the_translational_model_bounces_flat_as_every_corner_would():
    """omega = 0, P on the axis through O, C above the end's centre S (C2.4): the
    one-point impact at S (V_z+ = -e V_z-, no turn) is what Newton's law at every point of
    the rim gives, so the translational model goes on (no flat_landing there)."""
    run = simulate(parse_scene(_CYLINDER))
    assert run.model == "translational" and run.status != "flat_landing"
    first = run.events[0]
    assert first["kind"] == "impact" and abs(first["t"] - t_fall(drop=0.08)) < 1e-9
    assert abs(first["v_minus"] + g * t_fall(drop=0.08)) < 1e-8
    assert abs(first["v_plus"] + 0.5 * first["v_minus"]) < 1e-12 * g
    assert "flat_landing" not in {ev["kind"] for ev in run.events}


def test_a_face_on_the_plane_moving_down_stops_at_the_start():
    """The touch found before the first step (crt_events_collide_now) is judged alike."""
    text = _BOX.format(quaternion=[1.0, 0.0, 0.0, 0.0], duration=1.0, plane="")
    text = text.replace(f"com = [0.0, 0.0, {Z0}]",
                        f"com = [0.0, 0.0, {c}]\ncom_velocity = [0.0, 0.0, -1.0]")
    run = simulate(parse_scene(text))
    assert run.status == "flat_landing" and run.t[-1] == 0.0 and run.stats["steps"] == 0
    (ev,) = run.events
    assert ev["kind"] == "flat_landing" and ev["v_minus"] == -1.0


def _threshold(flat) -> float:
    """The tilt whose spread sqrt(2) sin(theta) (a + b) is the runtime's height resolution
    at the flat touch (the tilted touches' differ by 1e-11 m in Z_C: a part in 1e9)."""
    res = handover.noise(flat, len(flat.t) - 1)[0]
    return math.asin(res / (math.sqrt(2.0) * (a + b)))


def _corner_impulse(run, i) -> float:
    """(1 + e) |v_n| / (1/m + (r x n) J_C^-1 (r x n)) for the body and its point frozen at
    the touch's row i, r from C to the corner (a, -b, -c), n = e_z (the tilt: 1e-10)."""
    q = run.model_q[i]
    xp = 0.02 * math.sin(5.0 * run.t[i])
    d_P = np.array([M * xp / (M + m), 0.0, 0.0])        # P and O from C, body axes
    d_O = np.array([-m * xp / (M + m), 0.0, 0.0])
    JC = np.diag(J) + sum(k * (d @ d * np.eye(3) - np.outer(d, d))
                          for k, d in ((M, d_O), (m, d_P)))
    r = np.array([a, -b, -c]) - (-d_O)                  # the corner from C
    rn = np.cross(r, [0.0, 0.0, 1.0])
    v_n = q[G.com_velocity][2]
    return (1.0 + e) * -v_n / (1.0 / (M + m) + rn @ np.linalg.solve(JC, rn))


def test_tilt_either_side_of_the_resolution(flat):
    theta = _threshold(flat)
    assert 1e-12 < theta < 1e-8
    below = simulate(box(tilt(0.98 * theta), duration=0.31))
    assert below.status == "flat_landing" and abs(below.t[-1] - t_fall()) < 1e-9
    spread = below.events[-1]["value"]
    assert abs(spread - math.sqrt(2.0) * math.sin(0.98 * theta) * (a + b)) < 1e-6 * spread
    assert abs(spread - handover.flat_spread(below.scene, below.model_q[-1, G.A])) \
        < 1e-6 * spread
    above = simulate(box(tilt(1.02 * theta), duration=0.31))
    first, then = above.events
    assert first["kind"] == "impact" and abs(first["t"] - t_fall()) < 1e-9
    i = int(np.searchsorted(above.t, first["t"]))
    assert abs(first["value"] - _corner_impulse(above, i)) < 1e-8 * first["value"]
    # the corner impact turns the box (no pure translation: I would be (1 + e) m v), and
    # 2.6e-11 s later the opposite corner comes down with the face within the resolution
    # once more: a flat landing there, judged by the same rule
    assert first["value"] < 0.99 * (1.0 + e) * (M + m) * g * t_fall()
    assert then["kind"] == "flat_landing" and 0.0 < then["t"] - first["t"] < 1e-9
    assert then["value"] <= handover.noise(above, len(above.t) - 1)[0]
    assert abs(then["value"] - handover.flat_spread(above.scene, above.model_q[-1, G.A])) \
        < 1e-6 * then["value"]


def test_batch_as_one_run(flat):
    theta = _threshold(flat)
    scene = {"name": "flat box drop", "body": {"mass": M, "inertia": list(J), "shape": "box",
                                               "half_extents": [a, b, c]},
             "point": {"mass": m, "law": ["0.02*sin(5*t)", "0", "0"]},
             "plane": {"restitution": e}, "initial": {"com": [0.0, 0.0, Z0]},
             "run": {"duration": 0.31}}
    heights = derive.simulate_many(scene, {"initial.com": [[0.0, 0.0, Z0], [0.0, 0.0, 0.3]]})
    assert list(heights.column("status")) == ["flat_landing"] * 2
    assert np.allclose(heights.column("t_end"), [t_fall(), t_fall(0.3)], rtol=0, atol=1e-9)
    tilts = derive.simulate_many(scene, [{"initial.quaternion": list(tilt(k * theta))}
                                         for k in (0.98, 1.02)])
    singles = [simulate(box(tilt(k * theta), duration=0.31)) for k in (0.98, 1.02)]
    assert list(tilts.column("status")) == [r.status for r in singles]
    assert list(tilts.column("impacts")) == [r.stats["impacts"] for r in singles] == [0, 1]
    assert np.array_equal(tilts.column("t_end"), [r.t[-1] for r in singles])
