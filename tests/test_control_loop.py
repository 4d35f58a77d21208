"""The loop closed at run time (crt_control.h, derive/runtime/loop.py): calls at samples
and events, the law a controller sets, pushes, noise, the realised law and its replay,
refusals.  Each check compares with something computed another way: the momentum
theorems for a push, the noise's sample statistics, an open-loop rerun of the realised
law, the state a sample reads against the run's own row."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from derive import layout
from derive.runtime.driver import prepare, run_prepared
from derive.runtime.loop import STOP, Loop, Segments, hermite, realised_law
from derive.scene import builtin_doc, parse_scene
from test_runtime import ball

G = layout.GENERAL


def _scene(**run):
    doc = builtin_doc()
    doc["run"].update({"duration": 2.0, **run})
    return parse_scene(doc)


def _follow(scene, horizon=0.05):
    """A controller that follows the scene's own law by Hermite pieces of ``horizon``."""
    calls = []

    def controller(call):
        calls.append(call)
        t1 = call.t + horizon
        u1 = scene.law.point(t1)
        coef = hermite(call.t, call.u[:3], call.u[3:6], t1, u1[:3], u1[3:6])
        return Segments(np.array([call.t, t1]), coef[None])
    return controller, calls


def test_samples_and_events_call_the_controller_with_the_runs_own_state():
    scene = _scene()
    controller, calls = _follow(scene)
    res = run_prepared(prepare(scene), loop=Loop(controller, period=0.05))
    assert res.status == "done"
    samples = [c for c in calls if c.reason == "sample"]
    ks = np.round([(c.t - scene.t0) / 0.05 for c in samples], 9)
    assert np.array_equal(ks, np.arange(1, len(samples) + 1))      # exactly on the grid
    # the state a sample reads is the row the run wrote at that time (a step's end)
    for c in samples[::7]:
        i = np.flatnonzero(res.t == c.t)
        assert len(i) and np.array_equal(res.q[i[0]], c.q)
    impacts = [c.t for c in calls if c.reason == "event" and c.event == "impact"]
    assert np.allclose(impacts, res.impacts[:, 0], rtol=0, atol=0)
    assert calls[0].reason == "start" and calls[0].t == scene.t0
    assert res.stats["controller_calls"] == len(calls)


def test_a_closed_loop_replayed_open_loop_by_its_realised_law_is_the_same_run():
    scene = _scene()
    controller, _ = _follow(scene, 0.037)
    loop = Loop(controller, period=0.037)
    prep = prepare(scene)
    res = run_prepared(prep, loop=loop)
    law = realised_law(loop.law_rows())
    assert law.knots[0] == scene.t0 and law.knots[-1] == pytest.approx(scene.t0 + 2.0)
    replay = run_prepared(dataclasses.replace(prep, scene=dataclasses.replace(
        scene, law=law, law_text=())))
    assert replay.status == "done"
    assert np.allclose(replay.impacts[:, 0], res.impacts[:, 0], rtol=0, atol=1e-10)
    assert np.max(np.abs(replay.q[-1] - res.q[-1])) < 1e-9


def test_a_law_that_jumps_is_refused_naming_the_fault():
    scene = _scene()

    def jump(call):
        t1 = call.t + 0.1
        coef = hermite(call.t, call.u[:3] + np.array([1e-6, 0, 0]), call.u[3:6], t1,
                       call.u[:3], call.u[3:6])
        return Segments(np.array([call.t, t1]), coef[None])

    def kink(call):
        t1 = call.t + 0.1
        coef = hermite(call.t, call.u[:3], call.u[3:6] + np.array([0, 0, 1e-6]), t1,
                       call.u[:3], call.u[3:6])
        return Segments(np.array([call.t, t1]), coef[None])
    for fn, fault in ((jump, "position_jump"), (kink, "velocity_jump")):
        with pytest.raises(ValueError, match=fault):
            run_prepared(prepare(scene), loop=Loop(fn, period=0.1))


def test_a_controller_that_raises_or_stops():
    scene = _scene()

    def broken(call):
        raise KeyError("the controller's own bug")
    with pytest.raises(KeyError, match="own bug"):
        run_prepared(prepare(scene), loop=Loop(broken, period=0.1))

    def stop_at_half(call):
        return STOP if call.t >= 1.0 else None
    res = run_prepared(prepare(scene), loop=Loop(stop_at_half, period=0.25))
    assert res.status == "stopped" and res.t[-1] == pytest.approx(1.0)


def test_a_push_changes_the_momenta_as_the_theorems_say():
    """Q+ - Q- = P and K+ - K- = CA x P about C (fixed axes), A the body point."""
    scene = _scene(outputs=["pose", "momentum"], model="general")
    P, at = np.array([0.2, -0.3, 0.5]), np.array([0.1, -0.2, 0.3])
    loop = Loop(lambda call: None, pushes=[[0.7, *P, *at]])
    res = run_prepared(prepare(scene), loop=loop)
    assert res.stats["pushes"] == 1
    i = int(np.flatnonzero((res.t == 0.7) & (res.row_kind == 1))[0])   # before, after
    before, after = res.general[i], res.general[i + 1]
    mass = scene.M + scene.m
    assert np.allclose((after[G.com_velocity] - before[G.com_velocity]) * mass, P,
                       atol=1e-13)
    K = res.momentum["K_fixed"]
    A = before[G.A].reshape(3, 3)
    r = scene.law.point(0.7)[:3]
    CA = A @ (at - scene.nu * r)                  # OC = nu OP: C's offset from O
    assert np.allclose(K[i + 1] - K[i], np.cross(CA, P), atol=1e-12)


def test_the_noise_has_the_deviations_asked_and_is_the_seeds():
    scene = _scene(model="general")
    seen = []

    def record(call):
        if call.reason == "sample":
            seen.append((call.t, call.q))
        return None
    true = run_prepared(prepare(scene), loop=Loop(record, period=0.01))
    runs = []
    for seed in (5, 5, 6):
        seen.clear()
        run_prepared(prepare(scene), loop=Loop(record, period=0.01, seed=seed,
                                               noise=(0.01, 0.002, 0.001, 0.02)))
        runs.append(list(seen))
    q = np.array([row for _, row in runs[0]])
    assert np.array_equal(q, np.array([row for _, row in runs[1]]))
    assert not np.array_equal(q, np.array([row for _, row in runs[2]]))
    q_true = np.array([true.q[np.flatnonzero((true.t == t) & (true.row_kind == 0))[0]]
                       for t, _ in runs[0]])
    d = q - q_true
    assert len(d) > 150
    for part, std in ((G.omega, 0.01), (G.com, 0.001), (G.com_velocity, 0.02)):
        got = np.std(d[:, part])
        assert abs(got - std) < 0.15 * std, (part, got)
    # the attitude: A exp(delta^), a rotation, delta of the deviation asked per axis
    angles = []
    for row, qt in zip(q, q_true):
        A, At = row[G.A].reshape(3, 3), qt[G.A].reshape(3, 3)
        assert np.allclose(A @ A.T, np.eye(3), atol=1e-12)
        R = At.T @ A
        angles.append(math.acos(max(-1.0, min(1.0, (np.trace(R) - 1) / 2))))
    # |delta| of three normal deviates of 0.002: its mean is 0.002 sqrt(8/pi)
    assert abs(np.mean(angles) - 0.002 * math.sqrt(8 / math.pi)) < 0.15 * 0.0032


def test_a_session_runs_open_loop_again_after_a_closed_loop():
    """A run leaves the session on the controller's buffers; the next open-loop run of
    the same law must read the law set before (it had read freed memory)."""
    from derive.runtime.session import session_for
    scene = _scene()
    prep = prepare(scene)
    first = run_prepared(prep)
    for _ in range(3):
        controller, _ = _follow(scene, 0.1)
        run_prepared(prep, session=session_for(prep.kind), loop=Loop(controller, 0.1))
        again = run_prepared(prep, session=session_for(prep.kind))
        assert np.array_equal(again.q, first.q)


def test_a_law_that_lifts_the_body_off_at_a_sample_tells_the_controller():
    """The classical ball resting on the plane (landed at 1 mm/s with e = 0, in contact);
    at the sample t = 0.1 s the controller sets z = -40 (t - 0.1)^2: the point
    accelerates down at 80 m/s^2 and N = (M + m) g - 80 m < 0 at once, so the lift-off is
    due at the start of the next step, at 0.1 s exactly, and the controller is called
    with it (reason event, liftoff).  After it the system's centre C falls freely from
    rest, Z_C = R - g (t - 0.1)^2 / 2, while the body rises about it."""
    g, R, M, m, t_s = 9.81, 0.5, 1.0, 0.2, 0.1
    doc = ball(e=0.0, z0=R, duration=0.3, method="dopri5", rtol=1e-10, atol=1e-12)
    doc["initial"]["com_velocity"] = [0.0, 0.0, -1e-3]
    assert doc["body"]["mass"] == M and doc["point"]["mass"] == m
    calls = []

    def controller(call):
        calls.append((call.t, call.reason, call.event))
        if call.reason == "sample" and abs(call.t - t_s) < 1e-12:
            coef = np.zeros((1, 3, 4))
            coef[0, 2, 1] = -40.0
            return Segments(np.array([t_s, 1.0]), coef)
        return None
    res = run_prepared(prepare(parse_scene(doc)), loop=Loop(controller, period=t_s))
    assert res.status == "done"
    kinds = [(e["kind"], e["t"]) for e in res.events]
    assert ("liftoff", t_s) in kinds and kinds[0][0] == "impact"
    assert (t_s, "event", "liftoff") in calls
    s = res.t[-1] - t_s
    assert abs(res.q[-1, 2] - (R - 0.5 * g * s * s)) < 1e-9       # C, in free fall
    # S above the plane: the body rises as the point goes down inside it
    assert res.min_height >= -1e-9 and len(res.impacts) == 1


@pytest.mark.parametrize("t0", [10.0, -10.0])
def test_pushes_act_at_their_times_also_far_from_t_0(t0):
    """The scene started at t0 = 10 s or -10 s with a push at t0 itself (due at the loop's
    first pass) and one 0.2 s later (a stop 2 % of |t| ahead, not due yet): each is applied
    at its own time, once, and changes C's momentum by its impulse, Q+ - Q- = P."""
    doc = builtin_doc()
    doc["initial"]["time"] = t0
    doc["run"].update({"duration": 0.5, "outputs": ["pose", "momentum"], "model": "general"})
    scene = parse_scene(doc)
    P = np.array([0.2, -0.3, 0.5])
    loop = Loop(lambda call: None, pushes=[[t0, *P, 0.0, 0.0, 0.0],
                                           [t0 + 0.2, *(-P), 0.0, 0.0, 0.0]])
    res = run_prepared(prepare(scene), loop=loop)
    assert res.status == "done" and res.stats["pushes"] == 2
    mass = scene.M + scene.m
    for t, impulse in ((t0, P), (t0 + 0.2, -P)):
        rows = np.flatnonzero((res.t == t) & (res.row_kind == 1))
        i = int(rows[0])
        jump = (res.general[i + 1][G.com_velocity] - res.general[i][G.com_velocity]) * mass
        assert np.allclose(jump, impulse, atol=1e-13), (t, jump)
