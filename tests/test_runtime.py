"""Issue 4: the runtime against closed forms, an independent SciPy integration, and its
own reduced models.
"""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from derive.emit.numpy_backend import compile_spec
from derive.models import flight_rhs, gap, impact, lowest_point
from derive.runtime.driver import simulate
from derive.scene import DEFAULT_SCENE, parse_scene
import tomllib


def scene_dict(**changes) -> dict:
    """The default scene as a dict, with sections updated from ``changes``."""
    doc = tomllib.loads(DEFAULT_SCENE)
    for section, values in changes.items():
        if values is None:
            doc.pop(section, None)
        elif isinstance(values, dict):
            doc.setdefault(section, {}).update(values)
        else:
            doc[section] = values
    return doc


def ball(e=0.9, z0=1.5, law=("0", "0", "0"), method="dop853", rtol=1e-12, atol=1e-14,
         duration=2.0, **run):
    """A sphere of radius 0.5 centred at O, the point fixed at O: the classical ball."""
    return scene_dict(point={"mass": 0.2, "law": list(law)},
                      plane={"restitution": e},
                      initial={"com": [0.0, 0.0, z0], "com_velocity": [0.0, 0.0, 0.0],
                               "omega": [0.0, 0.0, 0.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
                      run={"method": method, "rtol": rtol, "atol": atol,
                           "duration": duration, **run})


def test_classical_ball_impact_times_are_exact():
    """Free fall from height H = z0 - R, then flights of 2 e^k v1 / g."""
    g, R, z0, e = 9.81, 0.5, 1.5, 0.9
    res = simulate(ball(e=e, z0=z0), progress=False)
    assert res.status == "done" and res.model == "translational"
    H = z0 - R
    v1 = math.sqrt(2 * g * H)
    expected = [math.sqrt(2 * H / g)]
    v = v1
    while True:
        v *= e
        nxt = expected[-1] + 2 * v / g
        if nxt > 2.0:
            break
        expected.append(nxt)
    got = res.impacts[:, 0]
    assert len(got) == len(expected)
    assert np.max(np.abs(got - expected)) < 1e-12 * 2.0
    # Newton's law and the impulse (m + M)(1 + e) v
    np.testing.assert_allclose(res.impacts[:, 3], -e * res.impacts[:, 2], rtol=1e-13)
    np.testing.assert_allclose(res.impacts[0, 1], 1.2 * (1 + e) * v1, rtol=1e-12)


def test_uniformly_moving_point_impact_time_closed_form():
    """P moves uniformly along the vertical axis (2.2): h(t) = z0 - g t^2/2 - R - nu w t,
    a quadratic whose root is the impact time."""
    w, z0, R, g = 0.3, 1.5, 0.5, 9.81
    nu = 0.2 / 1.2
    res = simulate(ball(z0=z0, law=("0", "0", f"{w}*t"), duration=0.5), progress=False)
    assert res.model == "translational"
    # Z_C is the centre of mass; h = Z_C + n.(OS - nu OP) = Z_C - R - nu w t
    a, b, c = -g / 2, -nu * w, z0 - R
    root = (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert abs(res.impacts[0, 0] - root) < 1e-12 * 0.5


def _reference_general(scene, rtol=1e-13):
    """The default scene integrated by SciPy's DOP853 with the NumPy evaluation of the
    derived equations, an event on the gap, and the derived impact map at each event."""
    s = parse_scene(scene)
    rhs = compile_spec(flight_rhs("general"))
    gap_f = compile_spec(gap("general"))
    imp_f = compile_spec(impact("general"))
    lp = compile_spec(lowest_point("sphere"))
    law = s.law.jets
    p = np.array(s.p)

    def u_at(t):
        v = law(np.array([t]))[:, 0]
        return v[[0, 3, 6, 1, 4, 7, 2, 5, 8]]

    def f(t, q):
        return rhs(q, u_at(t), p)[0]

    def ev(t, q):
        sv = lp(q[15:18], s.center, [s.size[0]])[0]
        return gap_f(q, u_at(t), sv, p)[0][0]
    ev.terminal, ev.direction = True, -1
    t, q = s.t0, np.r_[s.com, s.com_velocity, s.omega, s.A0.reshape(-1)]
    t_end = s.t0 + s.duration
    times = []
    while t < t_end:
        sol = solve_ivp(f, (t, t_end), q, method="DOP853", rtol=rtol, atol=1e-15, events=ev)
        t, q = sol.t[-1], sol.y[:, -1]
        if sol.status == 1:
            sv = lp(q[15:18], s.center, [s.size[0]])[0]
            q = imp_f(q, u_at(t), sv, p, [s.e])[0]
            times.append(t)
            # step off the root so that the terminal event is not re-triggered at once
            sol = solve_ivp(f, (t, min(t + 1e-6, t_end)), q, method="DOP853", rtol=rtol,
                            atol=1e-15)
            t, q = sol.t[-1], sol.y[:, -1]
    return np.array(times), q


def test_default_scene_matches_scipy():
    doc = scene_dict(run={"method": "dop853", "rtol": 1e-12, "atol": 1e-14})
    res = simulate(doc, progress=False)
    times, q_end = _reference_general(doc)
    assert res.status == "done" and res.model == "general"
    assert len(res.impacts) == len(times)
    assert np.max(np.abs(res.impacts[:, 0] - times)) < 1e-8
    assert np.max(np.abs(res.q[-1] - q_end)) < 1e-7


def _agree(a, b, tol):
    assert a.status == b.status == "done"
    assert len(a.impacts) == len(b.impacts)
    if len(a.impacts):
        assert np.max(np.abs(a.impacts[:, 0] - b.impacts[:, 0])) < tol
    assert np.max(np.abs(a.q[-1] - b.q[-1])) < tol


TIGHT = {"method": "dop853", "rtol": 1e-12, "atol": 1e-14}


def test_translational_equals_general():
    doc = ball(law=("0", "0", "0.1*sin(5*t)"), duration=2.0)
    auto = simulate(doc, progress=False)
    forced = copy.deepcopy(doc)
    forced["run"]["model"] = "general"
    full = simulate(forced, progress=False)
    assert auto.model == "translational" and full.model == "general"
    _agree(auto, full, 1e-9)


def test_planar_equals_general():
    # body z axis horizontal: rotate the default attitude by 90 degrees about x
    s = math.sqrt(0.5)
    doc = scene_dict(point={"mass": 0.3, "law": ["0.2*cos(3*t)", "0.1*sin(3*t)", "0"]},
                     initial={"omega": [0.0, 0.0, 2.0], "quaternion": [s, s, 0.0, 0.0],
                              "com": [0.0, 0.0, 1.0]},
                     run={**TIGHT, "duration": 2.0})
    auto = simulate(doc, progress=False)
    forced = copy.deepcopy(doc)
    forced["run"]["model"] = "general"
    full = simulate(forced, progress=False)
    assert auto.model == "planar" and full.model == "general"
    assert len(auto.impacts) >= 2
    _agree(auto, full, 1e-9)


def test_axisymmetric_equals_general():
    doc = scene_dict(body={"inertia": [0.1, 0.1, 0.15]},
                     point={"mass": 0.4, "law": ["0", "0", "0.3*sin(4*t)"]},
                     plane=None, run={**TIGHT, "duration": 3.0})
    auto = simulate(doc, progress=False)
    forced = copy.deepcopy(doc)
    forced["run"]["model"] = "general"
    full = simulate(forced, progress=False)
    assert auto.model == "axisymmetric" and full.model == "general"
    _agree(auto, full, 1e-9)


def test_attitude_and_vertical_equal_general():
    doc = scene_dict(plane=None, run={**TIGHT, "outputs": ["omega"], "duration": 3.0})
    att = simulate(doc, progress=False)
    assert att.model == "attitude"
    full = copy.deepcopy(doc)
    full["run"].update(model="general", outputs=["pose", "omega"])
    ref = simulate(full, progress=False)
    assert np.max(np.abs(att.q[-1] - ref.q[-1, 6:9])) < 1e-9
    doc = scene_dict(run={**TIGHT, "outputs": ["omega", "height", "impacts"]})
    ver = simulate(doc, progress=False)
    assert ver.model == "vertical"
    full = copy.deepcopy(doc)
    full["run"].update(model="general", outputs=["pose", "impacts"])
    ref = simulate(full, progress=False)
    assert len(ver.impacts) == len(ref.impacts)
    assert np.max(np.abs(ver.impacts[:, 0] - ref.impacts[:, 0])) < 1e-9
    last = ref.q[-1]
    assert np.max(np.abs(ver.q[-1] - np.r_[last[2], last[5], last[6:9], last[15:18]])) < 1e-9


def test_accumulating_impacts_end_in_resting_contact():
    """e = 0.5: the impacts accumulate (Zeno); the runtime switches to contact with the
    reaction of a resting ball, (m + M) g, instead of stepping forever or falling, and
    predicts the accumulation time of the geometric series of flights."""
    res = simulate(ball(e=0.5, duration=3.0, rtol=1e-10, atol=1e-12, method="dopri5"),
                   progress=False)
    assert res.status == "done"
    kinds = [e["kind"] for e in res.events]
    assert "contact" in kinds and len(res.impacts) < 100
    contact = next(e for e in res.events if e["kind"] == "contact")
    assert abs(contact["value"] - 1.2 * 9.81) < 1e-6
    # the Zeno time of the classical ball: t_inf = t1 (1 + 2e/(1-e))
    t1 = math.sqrt(2 * 1.0 / 9.81)
    t_inf = t1 * (1 + 2 * 0.5 / 0.5)
    assert abs(contact["t_accumulation"] - t_inf) < 1e-9
    assert t_inf - 1e-3 < contact["t"] <= t_inf
    z_final = res.q[-1][2]
    assert abs(z_final - 0.5) < 1e-9 and abs(res.q[-1][5]) < 1e-9


@pytest.mark.parametrize("wave", ["sin", "cos"])
def test_the_least_normal_reaction_of_a_resting_ball_is_the_closed_forms(wave):
    """A plastic ball resting on the plane while its point oscillates along the vertical,
    z = a sin(W t) or a cos(W t), with nu a W^2 < g: the reaction N = (m + M)(g + nu z'')
    stays positive, its least value (m + M)(g - nu a W^2).  With the sine N falls from
    the start to that least value at t = pi / (2 W) in the middle of the contact: the run's
    summary holds it as sampled at the steps' ends (not below it, and within 1e-4 of
    it: a summary kept 5 % off the least sample would show).  With the cosine it is
    the value at the start, where the ball enters contact, and N rises after it: the
    summary holds the entry's value to 1e-12."""
    a, W, nu, g = 0.3, 5.0, 0.2 / 1.2, 9.81
    z0 = 0.5 + (nu * a if wave == "cos" else 0.0)      # S on the plane at t = 0
    res = simulate(ball(e=0.0, z0=z0, law=("0", "0", f"{a}*{wave}({W}*t)"), duration=1.0,
                        rtol=1e-10, atol=1e-12, method="dopri5"), progress=False)
    assert res.status == "done" and [e["kind"] for e in res.events] == ["impact", "contact"]
    least = 1.2 * (g - nu * a * W * W)
    if wave == "sin":
        assert least * (1 - 1e-12) <= res.min_normal < least * (1 + 1e-4)
    else:
        assert abs(res.min_normal / least - 1) < 1e-12


def test_lift_off_when_the_point_pushes_hard_enough():
    """A plastic ball (e = 0) resting on the plane while its point oscillates along the
    vertical, z = a sin(W t), with nu a W^2 > g: the reaction N = (m + M)(g + nu z'') turns
    negative at nu z'' = -g, so the ball lifts off there, lands, rests, lifts off..."""
    a, W, nu, g = 0.3, 20.0, 0.2 / 1.2, 9.81
    res = simulate(ball(e=0.0, z0=0.5, law=("0", "0", f"{a}*sin({W}*t)"), duration=1.0,
                        rtol=1e-10, atol=1e-12, method="dopri5"), progress=False)
    assert res.status == "done" and res.model == "translational"
    kinds = [e["kind"] for e in res.events]
    assert kinds.count("lift_off") >= 2 and kinds.count("contact") >= 2
    for ev in res.events:
        if ev["kind"] == "lift_off":
            # lift-off where g + nu z''(t) = 0, i.e. sin(W t) = g/(nu a W^2)
            assert abs(math.sin(W * ev["t"]) - g / (nu * a * W * W)) < 1e-8
            assert abs(ev["value"]) < 1e-8


@pytest.mark.parametrize("n", [3, 21])
def test_max_events_is_a_status_not_a_hang(n):
    """The elastic ball stopped by max_events = n after exactly n impacts, at the closed
    form's times sqrt(2 H / g) + k 2 sqrt(2 g H) / g (21: a count 5 % either side, 20 or
    22, would show)."""
    res = simulate(ball(e=1.0, duration=25.0, max_events=n), progress=False)
    assert res.status == "max_events" and len(res.impacts) == n
    H, g = 1.0, 9.81
    times = math.sqrt(2 * H / g) + np.arange(n) * 2 * math.sqrt(2 * g * H) / g
    np.testing.assert_allclose(res.impacts[:, 0], times, rtol=0, atol=1e-8)


def test_compiled_library_is_cached(tmp_path):
    """Built once per machine: a second process only loads it."""
    import subprocess
    import sys
    from derive.runtime.build import library
    lib = library("general")
    code = ("import time; from derive.runtime.build import library; t = time.perf_counter(); "
            "lib = library('general'); print(lib.path, time.perf_counter() - t)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[0] == str(lib.path)
    assert float(out[1]) < 0.5          # loading, not compiling (a build takes seconds)


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853", "lie", "lie5", "lie8"])
def test_every_method_runs_the_default_scene(method):
    res = simulate(scene_dict(run={"method": method}), progress=False)
    assert res.status == "done" and len(res.impacts) == 8


def test_laws_with_pi_and_every_function_compile_and_run():
    law = ["0.1*sin(2*pi*t) + 0.01*tanh(t)", "0.05*cos(pi*t)*exp(-t)",
           "0.02*sqrt(1 + t^2) + 0.01*log(2 + t) + 0.001*atan(t)"]
    res = simulate(scene_dict(point={"mass": 0.2, "law": law}, run={"duration": 1.0}),
                   progress=False)
    assert res.status == "done"
