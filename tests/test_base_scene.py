"""The base model reaches the user (issue 33 phase 3): chosen for a box or a cylinder
resting on a face on a rough plane, run by ``derive simulate``, its keys acting or
refused by name.

* derive/scene/examples/capsule-crawler.toml through ``derive simulate``: summary.json's
  displacement per period (the mean over ten periods and the last period's) against the
  1-D stick-slip closed form of tests/test_base_closed_forms.py, to 1e-9 m;
* the rows in the general layout against the model's own state: C = O + A OC with the
  point's law, S (the face) on the plane, the attitude a rotation about the vertical;
* the choice: auto picks base and says why; each condition it reads, missed, refuses a
  forced ``[run].model = "base"`` with that condition; the face keys (static_friction,
  pressure) act on base and are refused by name elsewhere; [control] and the rough
  model's couples refused on a base scene.
"""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from derive.cli import main
from derive.runtime import choice
from derive.runtime.driver import simulate
from derive.scene import SceneError
from derive.scene.parse import parse_scene

import test_base_closed_forms as cf

EXAMPLE = Path(__file__).parents[1] / "derive" / "scene" / "examples" / "capsule-crawler.toml"
PERIOD = 2 * math.pi / cf.W


def closed_X(t: float) -> float:
    """X_O at t from the closed form's events: constant while stuck, the slip's parabola
    (tests/test_base_closed_forms.py's formula) while sliding."""
    X, start = 0.0, None
    for ev in cf.closed_form_1d(t):
        if ev[0] > t:
            break
        assert ev[1] in ("slip", "stick")
        if ev[1] == "stick":
            X, start = ev[2], None
        else:
            start = ev[0]
    if start is None:
        return X
    x1, xd1, xdd1 = cf.x_law(start)
    sigma = 1.0 if -xdd1 > 0 else -1.0
    dt = t - start
    return X - cf.NU * (cf.x_law(t)[0] - x1 - xd1 * dt) - sigma * cf.MU_K * cf.G * dt * dt / 2


def test_the_capsule_crawler_crawls_as_the_closed_form_says(tmp_path):
    """The example's law and numbers are the closed form's (M, m, A, W, beta, mu, mu_s)."""
    assert main(["simulate", str(EXAMPLE), "-o", str(tmp_path), "--no-plots"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["model"] == "base" and summary["status"] == "done"
    tr = summary["travel"]
    assert tr["whole_periods"] == 10 and abs(tr["period"] - PERIOD) < 1e-15
    # x(k T) = x(0): C's displacement over whole periods is O's
    X10, X9 = closed_X(10 * PERIOD), closed_X(9 * PERIOD)
    assert abs(tr["displacement_per_period"][0] - X10 / 10) < 1e-9
    assert abs(tr["last_period_displacement"][0] - (X10 - X9)) < 1e-9
    assert abs(tr["mean_velocity"][0] - X10 / 10 / PERIOD) < 1e-9
    assert abs(tr["last_period_displacement"][0] - 4.7774e-4) < 1e-7     # the steady crawl
    assert tr["displacement_per_period"][1] == 0.0
    # each period's displacement, the first from rest; the steady crawl from the second
    X = [closed_X(k * PERIOD) for k in range(11)]
    each = np.array(tr["period_displacements"])
    assert each.shape == (10, 2) and np.abs(each[:, 0] - np.diff(X)).max() < 1e-9
    assert abs(X[1] - X[2] + X[1]) > 1e-4                 # the start-up is no steady period
    st = tr["steady"]
    assert (st["from_period"], st["periods"]) == (2, 9)
    assert abs(st["displacement_per_period"][0] - (X[10] - X[1]) / 9) < 1e-9
    assert abs(st["mean_speed"] - (X[10] - X[9]) / PERIOD) < 1e-9
    assert abs(st["mean_speed"] / tr["mean_speed"] - 1) > 0.1       # the start-up's share
    contact = summary["contact"]
    assert contact["static_friction"] == cf.MU_S and contact["friction"] == cf.MU_K
    assert contact["slips"] == 20 and contact["sticks"] == 19
    assert abs(contact["min_normal_force"] - (cf.M + cf.m) * cf.G) < 1e-12


def test_the_steady_crawl_starts_where_the_periods_repeat():
    """base_report.steady: the first period from which all repeat the last (to 1e-6 of the
    largest); None while the last two differ, or for one period."""
    from derive.runtime.base_report import steady
    assert steady([[5e-4, 0], [1e-4, 2e-5], [1e-4, 2e-5]]) == 2
    assert steady([[1e-4, 0], [1e-4, 0]]) == 1
    assert steady([[1e-4, 0], [2e-4, 0], [3e-4, 0]]) is None
    assert steady([[1e-4, 0], [1e-4 * (1 + 2e-6), 0]]) is None
    assert steady([[1e-4, 0]]) is None
    assert steady([[0.0, 0.0], [0.0, 0.0]]) == 1                 # at rest: steady at 0


def test_the_rows_in_the_general_layout_are_the_model_state_seen_from_c():
    """A turning cylinder on its end, a point on a circle: the general rows hold C = O + A
    OC, the face on the plane, A a rotation about the vertical by psi."""
    scene = parse_scene(f"""
[body]
mass = 1.2
inertia = [0.006, 0.006, 0.008]
shape = "cylinder"
radius = 0.1
half_length = 0.03
[[point]]
mass = 0.3
law = ["0.04*cos(9*t)", "0.04*sin(9*t)", "0.01"]
[plane]
friction = 0.4
[initial]
on_plane = true
carrier_velocity = [0.2, -0.1, 0.0]
omega = [0, 0, 3.0]
quaternion = [{math.cos(0.35)}, 0, 0, {math.sin(0.35)}]
[run]
duration = 0.4
""")
    r = simulate(scene)
    assert r.model == "base"
    q = r.model_q
    g = r.general
    A = g[:, 9:18].reshape(-1, 3, 3)
    psi = q[:, 2]
    assert abs(psi[0] - 0.7) < 1e-12
    c, s = np.cos(psi), np.sin(psi)
    assert np.abs(A[:, 0, 0] - c).max() < 1e-12 and np.abs(A[:, 1, 0] - s).max() < 1e-12
    assert np.abs(A[:, 2, 2] - 1).max() < 1e-12
    P = np.column_stack([0.04 * np.cos(9 * r.t), 0.04 * np.sin(9 * r.t), np.full(len(r.t), 0.01)])
    nu = 0.3 / 1.5
    r_C = np.column_stack([q[:, 0], q[:, 1], np.full(len(r.t), 0.03)]) \
        + nu * np.einsum("nij,nj->ni", A, P)
    assert np.abs(g[:, 0:3] - r_C).max() < 1e-12
    assert np.abs(r.height).max() < 1e-12           # the lowest point on the plane
    assert np.abs(g[:, 8] - q[:, 5]).max() == 0.0   # omega_z = psi'
    assert abs(q[0, 3] - 0.2) < 1e-15 and abs(q[0, 4] + 0.1) < 1e-15


_BOX = """
[body]
mass = 1.0
inertia = [0.01, 0.02, 0.025]
shape = "{shape}"
{sizes}
[[point]]
mass = 0.4
law = ["{amp}*sin(12*t)", "0", "{z}"]
[plane]
friction = {mu}
{plane}
[initial]
on_plane = {on_plane}
carrier_velocity = [0.0, 0.0, {vz}]
{initial}
[run]
duration = 0.5
model = "{model}"
{extra}
"""


def _scene(e=None, **kw):
    """The scene of _BOX; ``e``: a restitution, which every model but base needs."""
    v = dict(amp=0.05, shape="box", sizes="half_extents = [0.1, 0.06, 0.04]", z="0.02", mu=0.3,
             plane="", on_plane="true", vz=0.0, initial="", model="auto", extra="")
    v.update(kw)
    if e is not None:
        v["plane"] += f"\nrestitution = {e}"
    if v["shape"] == "ellipsoid":
        v["sizes"] = "semi_axes = [0.1, 0.06, 0.04]"
    return parse_scene(_BOX.format(**v))


def test_auto_chooses_base_and_says_why():
    kind, why = choice.choose(_scene())
    assert kind == "base" and "box on a face" in why and "mu = 0.3" in why
    kind, why = choice.choose(_scene(plane="static_friction = 0.4"))
    assert kind == "base" and "mu_s = 0.4" in why
    # a body on a face on a smooth plane is no model's (one point in the face's middle:
    # tests/test_flat_starts.py), and in the air not the base model's
    with pytest.raises(SceneError, match=r"^\[initial\]\.quaternion: puts a box on the "
                                         r"plane on a face.*give \[plane\]\.friction > 0"):
        choice.choose(_scene(mu=0.0, e=0.0))
    assert choice.choose(_scene(on_plane="false", initial="com = [0, 0, 1]", e=0.0))[0] \
        != "base"


@pytest.mark.parametrize("kw, says", [
    (dict(shape="ellipsoid", e=0.0), "needs a box or a cylinder"),
    (dict(mu=0.0, e=0.0), "needs [plane].friction > 0"),
    (dict(on_plane="false", initial="com = [0, 0, 1]", e=0.0), "on_plane = true"),
    (dict(initial="quaternion = [0.9, 0.1, 0, 0]"), "along no face normal"),
    (dict(initial="omega = [0.1, 0, 1]"), "omega is not along the vertical"),
    (dict(vz=0.1), "O starts with a vertical velocity"),
])
def test_forced_base_is_refused_with_the_condition_missed(kw, says):
    with pytest.raises(SceneError) as exc:
        choice.choose(_scene(model="base", **kw))
    assert str(exc.value).startswith('[run].model: "base" cannot run this scene') \
        and says in str(exc.value) and "\n" not in str(exc.value)


@pytest.mark.parametrize("kw, field, says", [
    (dict(plane="static_friction = 0.2"), "[plane].static_friction", "must be >= "),
    (dict(plane="static_friction = 0.4", model="rough", e=0.0), "[plane].static_friction",
     "base model only"),
    (dict(plane='pressure = "uniform"', initial="quaternion = [0.9, 0.1, 0, 0]", e=0.0),
     "[plane].pressure", "base model only"),
    (dict(plane="spin_friction = 0.01"), "[plane].spin_friction", "remove it"),
    (dict(extra='[control]\nmode = "replan"'), "[control]", ""),
])
def test_face_keys_act_on_base_and_are_refused_elsewhere(kw, field, says):
    with pytest.raises(SceneError) as exc:
        choice.choose(_scene(**kw))
    assert str(exc.value).startswith(field) and says in str(exc.value)


def test_static_friction_acts():
    """mu_s above mu holds the rest longer: the same law slips later."""
    first = [simulate(_scene(amp=0.1, plane=f"static_friction = {mu_s}")).events[0]
             for mu_s in (0.3, 0.35)]
    assert first[0]["kind"] == first[1]["kind"] == "slip"
    # the rest breaks where m |x''| = mu_s (M + m) g: x'' = -A W^2 sin(W t)
    for ev, mu_s in zip(first, (0.3, 0.35)):
        t = math.asin(mu_s * 1.4 * 9.81 / (0.4 * 0.1 * 144)) / 12
        assert abs(ev["t"] - t) < 1e-9


def test_linear_pressure_acts_and_is_said():
    """pressure = "linear" reaches the C (a point walking out lifts the face at the kern,
    where uniform pressure runs on) and summary's contact says which pressure ran."""
    walk = dict(amp=0.0, z="0", extra="", plane="")
    law = '["0.2*t", "0", "0"]'
    runs = {}
    for pressure in ("uniform", "linear"):
        text = _BOX.format(**{**dict(shape="box", sizes="half_extents = [0.1, 0.06, 0.04]",
                                     mu=0.5, on_plane="true", vz=0.0, initial="",
                                     model="auto"), **walk,
                              "plane": f'pressure = "{pressure}"'})
        text = text.replace('law = ["0.0*sin(12*t)", "0", "0"]', f"law = {law}")
        text = text.replace("duration = 0.5", "duration = 1.0")
        runs[pressure] = simulate(parse_scene(text))
    lin, uni = runs["linear"], runs["uniform"]
    assert uni.status == "done" and lin.status == "face_lifting"
    # cp = m x/(M + m) = 0.4 * 0.2 t / 1.4 reaches a/3 at t = 1.4/(3 * 0.8)
    assert abs(lin.t[-1] - 0.1 / 3 * 1.4 / 0.08) < 1e-9
    from derive.runtime import base_report
    assert base_report.contact(lin)["pressure"] == "linear"
    assert base_report.contact(uni)["pressure"] == "uniform"
