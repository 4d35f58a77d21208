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

from derive import abi, layout
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


@pytest.mark.parametrize("share", [0.98, 1.02])
@pytest.mark.parametrize("part", ["position", "velocity"])
def test_a_jump_at_the_continuity_tolerance_is_taken_within_and_refused_beyond(part, share):
    """The start's law off the law in use by share of the tolerance the runtime states
    (x: 1e-12 (1 + |x| + the length scale), x': 1e-12 (1 + |x'|)), in each of x, y, z in
    turn: within it the run goes on, beyond it the law is refused naming the fault."""
    from derive import abi
    doc = builtin_doc()
    doc["run"]["duration"] = 0.2
    prep = prepare(parse_scene(doc))
    L = prep.options[abi.OPT["length_scale"]]
    for c in range(3):
        def offset(call, c=c):
            if call.reason != "start":
                return None
            u0, v0 = call.u[:3].copy(), call.u[3:6].copy()
            if part == "position":
                u0[c] += share * 1e-12 * (1.0 + abs(u0[c]) + L)
            else:
                v0[c] += share * 1e-12 * (1.0 + abs(v0[c]))
            t1 = call.t + 0.1
            coef = hermite(call.t, u0, v0, t1, call.u[:3], call.u[3:6])
            return Segments(np.array([call.t, t1]), coef[None])
        if share < 1.0:
            assert run_prepared(prep, loop=Loop(offset)).status == "done"
        else:
            with pytest.raises(ValueError, match=f"{part}_jump"):
                run_prepared(prep, loop=Loop(offset))


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


def test_pushes_before_the_start_are_not_applied_and_those_after_it_are():
    """A run from t0 = 1 with pushes at t0 - 0.02 (before the start: never applied), t0 +
    0.02 and t0 + 0.3 (applied, at their times, not at the samples every 0.03 s before
    them): two push events, at those times, each the momentum its impulse gives (Q+ - Q-
    = P)."""
    doc = builtin_doc()
    doc["run"].update({"duration": 0.5, "model": "general", "outputs": ["pose", "momentum"]})
    doc.setdefault("initial", {})["time"] = 1.0
    scene = parse_scene(doc)
    P = np.array([0.2, -0.3, 0.5])
    pushes = [[t, *(k * P), 0.1, -0.2, 0.3] for k, t in enumerate((0.98, 1.02, 1.3), 1)]
    res = run_prepared(prepare(scene), loop=Loop(lambda call: None, period=0.03,
                                                 pushes=pushes))
    assert res.stats["pushes"] == 2
    mass = scene.M + scene.m
    for k, t in ((2, 1.02), (3, 1.3)):
        i = int(np.flatnonzero((res.t == t) & (res.row_kind == 1))[0])
        dv = res.general[i + 1][G.com_velocity] - res.general[i][G.com_velocity]
        assert np.allclose(dv * mass, k * P, atol=1e-13), (t, dv * mass)


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


def test_the_vertical_models_noise_is_on_z_and_its_rate_and_tilts_n():
    """The vertical model (Z_C, Z_C', omega, n): position and velocity noise go to Z_C and
    Z_C' once each (sample deviations those asked, within 15 % over 400 samples), omega's
    to omega, and the attitude's tilts n by |delta_perp| of two normal deviates (mean
    0.002 sqrt(pi/2), the Rayleigh mean), n staying a unit vector."""
    from derive.stability import bouncing
    V = layout.VERTICAL
    doc = bouncing.bouncing_scene(a=0.1)
    doc["run"]["duration"] = 2.0
    prep = prepare(dataclasses.replace(parse_scene(doc), model="vertical"))
    seen = []

    def record(call):
        if call.reason == "sample":
            seen.append((call.t, call.q))
        return None
    true = run_prepared(prep, loop=Loop(record, period=0.005))
    seen.clear()
    run_prepared(prep, loop=Loop(record, period=0.005, seed=3,
                                 noise=(0.01, 0.002, 0.001, 0.02)))
    q = np.array([row for _, row in seen])
    q_true = np.array([true.q[np.flatnonzero((true.t == t) & (true.row_kind == 0))[0]]
                       for t, _ in seen])
    d = q - q_true
    assert len(d) >= 390
    n, n_true = q[:, 5:8], q_true[:, 5:8]
    for col, std in ((V.Z, 0.001), (V.Zd, 0.02), (2, 0.01), (3, 0.01), (4, 0.01)):
        assert abs(np.std(d[:, col]) - std) < 0.15 * std, (col, np.std(d[:, col]))
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    tilt = np.arccos(np.clip(np.sum(n * n_true, axis=1), -1.0, 1.0))
    assert abs(np.mean(tilt) - 0.002 * math.sqrt(math.pi / 2)) < 0.15 * 0.0025


@pytest.mark.parametrize("t0", [0.0, -2.0])
def test_the_law_log_tiles_the_run_with_the_pieces_the_controller_set(t0):
    """A controller setting laws of four pieces each (0.04 s) every 0.03 s sample, so that
    each law is cut inside its pieces: the log's rows (knot, from, to, coefficients) are
    contiguous from the start to the end (each from the last one's to), each of positive
    length, each within its piece (the last piece of the run's law may run on past its
    knot) and with that piece's coefficients, against the Segments the controller
    returned.  Also at negative times, where a sample is within 5 % of the one before."""
    doc = builtin_doc()
    doc["run"]["duration"] = 0.5
    doc.setdefault("initial", {})["time"] = t0
    scene = parse_scene(doc)
    laws = []

    def controller(call):
        ts = call.t + 0.01 * np.arange(5)
        u = [scene.law.point(t) for t in ts]
        u[0] = call.u
        coef = np.stack([hermite(ts[i], u[i][:3], u[i][3:6], ts[i + 1], u[i + 1][:3],
                                 u[i + 1][3:6]) for i in range(4)])
        laws.append(Segments(ts, coef))
        return laws[-1]
    loop = Loop(controller, period=0.03)
    res = run_prepared(prepare(scene), loop=loop)
    assert res.status == "done"
    rows = loop.law_rows()
    starts = [law.knots[0] for law in laws]
    assert rows[0, 1] == t0 == scene.t0 and rows[-1, 2] == pytest.approx(t0 + 0.5, abs=1e-12)
    assert np.array_equal(rows[1:, 1], rows[:-1, 2]) and np.all(rows[:, 2] > rows[:, 1])
    for row in rows:
        law = laws[int(np.searchsorted(starts, row[1], side="right")) - 1]
        i = int(np.flatnonzero(law.knots == row[0])[0])
        assert row[1] >= law.knots[i] and (i == 3 or row[2] <= law.knots[i + 1]), row[:3]
        assert np.array_equal(row[3:].reshape(3, 4), law.coef[i])
    assert len(rows) > 2 * len(laws)


def test_the_runtime_checks_the_loops_pushes_and_channels_itself():
    """crt_control_setup and crt_control_channels called directly (Python sorts the pushes
    before them): pushes in time order, equal times included, accepted; one 2 % earlier
    than the one before, or none given where one is counted, refused (bad_argument).
    Channels: 0 to 3 outputs, -1 (none) among them, accepted; -1 or 4 outputs, an output
    below -1, or none given where some are counted, refused."""
    import ctypes
    from derive import abi
    from derive.runtime.loop import CONTROLLER_FN
    prep = prepare(_scene(model="general"))
    lib = prep.library.lib
    mem = ctypes.create_string_buffer(lib.crt_control_sizeof() + 64)
    handle = ctypes.c_void_p((ctypes.addressof(mem) + 63) // 64 * 64)
    fn = CONTROLLER_FN(lambda *args: 0)
    log = np.zeros((64 * 2 * abi.CTL_MAX_KNOTS, len(abi.LOG_COLUMNS)))
    noise = np.zeros(4)
    dp = ctypes.POINTER(ctypes.c_double)

    def setup(times, n=None, given=True):
        rows = np.zeros((len(times), 7))
        rows[:, 0] = times
        rows[:, 3] = 0.1
        return lib.crt_control_setup(handle, ctypes.cast(fn, ctypes.c_void_p), None, 0.0,
                                     noise.ctypes.data_as(dp), 0.0,
                                     rows.ctypes.data_as(dp) if given else None,
                                     len(times) if n is None else n,
                                     log.ctypes.data_as(dp), len(log))
    ok, bad = abi.STATUS["ok"], abi.STATUS["bad_argument"]
    assert setup([1.0, 1.0, 1.02]) == ok and setup([-1.0, -0.98]) == ok
    assert setup([1.0, 0.98]) == bad and setup([-0.98, -1.0]) == bad
    assert setup([], n=1, given=False) == bad

    def channels(outs, n=None, given=True):
        arr = (ctypes.c_int * max(len(outs), 1))(*outs)
        return lib.crt_control_channels(handle, len(outs) if n is None else n,
                                        arr if given else None)
    assert setup([]) == ok
    for outs in ([], [0], [4, -1], [0, 1, 2], [-1, -1, 7]):
        assert channels(outs) == ok, outs
    for outs, n, given in (([0, 1, 2, 3], None, True), ([0], -1, True), ([0, -2], None, True),
                           ([0], 1, False)):
        assert channels(outs, n, given) == bad, (outs, n, given)


def test_a_seed_past_the_runtimes_range_is_seed_zero():
    """The noise's seed is taken as given below 1.8e19 and as 0 from there (a double's
    conversion to the generator's 64 bits): at 0.98 of it the noise is not seed 0's, at
    1.02 it is."""
    scene = _scene(model="general", duration=0.1)
    seen = []

    def record(call):
        seen.append(call.q.copy())
        return None

    def noisy(seed):
        seen.clear()
        run_prepared(prepare(scene), loop=Loop(record, period=0.02, seed=seed,
                                               noise=(0.01, 0.002, 0.001, 0.02)))
        return np.array(seen)
    zero = noisy(0)
    assert not np.array_equal(noisy(int(0.98 * 1.8e19)), zero)
    assert np.array_equal(noisy(int(1.02 * 1.8e19)), zero)


def test_pushes_on_a_model_without_them_are_refused():
    """The vertical model has no push map (MODEL_PUSH 0): a loop with a push is refused,
    not run with the push dropped; without pushes it runs."""
    from derive.stability import bouncing
    doc = bouncing.bouncing_scene(a=0.1)
    doc["run"]["duration"] = 0.2
    prep = prepare(dataclasses.replace(parse_scene(doc), model="vertical"))
    assert run_prepared(prep, loop=Loop(lambda call: None)).status == "done"
    with pytest.raises(ValueError, match="pushes need the general model"):
        run_prepared(prep, loop=Loop(lambda call: None, pushes=[[0.1, 0, 0, 0.1, 0, 0, 0]]))


def test_the_controller_is_called_after_each_contact_and_lift_off():
    """A ball on a vibrating table that comes to rest and lifts off again (e = 0): the
    controller is called once after each contact and each lift-off, as many times as
    the run's counters say."""
    from derive.stability import bouncing
    doc = bouncing.bouncing_scene(a=0.1)
    doc["plane"]["restitution"] = 0.0
    doc["run"]["duration"] = 1.0
    prep = prepare(dataclasses.replace(parse_scene(doc), model="vertical"))
    calls = []
    res = run_prepared(prep, loop=Loop(lambda c: calls.append((c.t, c.event)) or None))
    got = {kind: [t for t, e in calls if e == kind] for kind in ("contact", "lift_off")}
    assert len(got["contact"]) == res.stats["contacts"] >= 2
    assert len(got["lift_off"]) == res.stats["lift_offs"] >= 2
    assert {e for _, e in calls[1:]} <= {"impact", "contact", "lift_off"}


def test_channels_read_and_drive_the_outputs_of_a_law_of_bodies():
    """Two points and a rotor (the moments model), the controller's x, y, z on point 0's
    y, none, and the rotor's psi (channels 1, -1, 6): what a call reads is those outputs
    of the scene's law (its NumPy twin, BodiesLaw.u) until the controller sets a
    law, and then that law's values at the call's time; the column with no output reads
    0.  Channels past the law's outputs are refused."""
    from derive.verify.generators import random_bodies_scene
    scene = parse_scene(random_bodies_scene(np.random.default_rng(1), 1.0, n_points=2,
                                            n_rotors=1))
    prep = prepare(scene)
    law = scene.bodies_law
    slot = {1: (1, 3), 6: (18, 1)}                 # output -> (its value in u, step)
    calls, laws = [], []

    def controller(call):
        calls.append(call)
        if call.t < 0.45:
            return None
        t1 = call.t + 0.3
        goal = call.u[:3] + 0.05 * np.array([1.0, 0.0, -2.0])
        coef = hermite(call.t, call.u[:3], call.u[3:6], t1, goal, np.zeros(3))
        laws.append(Segments(np.array([call.t, t1]), coef[None]))
        return laws[-1]
    res = run_prepared(prep, loop=Loop(controller, period=0.1, channels=(1, -1, 6)))
    assert res.status == "done" and len(laws) >= 4
    for call in calls[1:]:
        before = [law for law in laws if law.knots[0] < call.t]
        if before:
            want = before[-1].at(call.t)
        else:
            u = law.u([call.t])[:, 0]
            want = np.zeros(9)
            for c, o in ((0, 1), (2, 6)):
                at, step = slot[o]
                want[[c, 3 + c, 6 + c]] = u[[at, at + step, at + 2 * step]]
        for c in (0, 2):
            assert np.allclose(call.u[[c, 3 + c, 6 + c]], want[[c, 3 + c, 6 + c]],
                               rtol=1e-12, atol=1e-12), (call.t, c)
        assert np.all(call.u[[1, 4, 7]] == 0.0)
    for bad in ((8,), (0, 1, 9)):
        with pytest.raises(ValueError):
            run_prepared(prep, loop=Loop(controller, period=0.1, channels=bad))


@pytest.mark.parametrize("kind", ["table", "formula"])
def test_a_loop_that_sets_no_law_leaves_the_run_as_it_was(kind):
    """A point law given as formulas or as a table (its samples): a loop whose controller
    never sets a law (no samples, so no step ends added) runs the same rows as the open
    loop, bit for bit."""
    doc = builtin_doc()
    doc["run"]["duration"] = 0.5
    if kind == "table":
        ts = np.linspace(0.0, 0.6, 13)
        doc["point"] = {"mass": 0.2, "ends": "free", "samples": np.column_stack(
            [ts, 0.2 * np.sin(3 * ts), 0.1 + 0 * ts, 0.05 * np.cos(2 * ts)]).tolist()}
    prep = prepare(parse_scene(doc))
    open_loop = run_prepared(prep)
    closed = run_prepared(prep, loop=Loop(lambda call: None))
    assert closed.status == open_loop.status == "done"
    assert np.array_equal(closed.t, open_loop.t) and np.array_equal(closed.q, open_loop.q)

def test_a_law_that_lifts_the_body_off_at_a_sample_tells_the_controller():
    """The classical ball resting on the plane (landed at 1 mm/s with e = 0, in contact);
    at the sample t = 0.1 s the controller sets z = -40 (t - 0.1)^2: the point
    accelerates down at 80 m/s^2 and N = (M + m) g - 80 m < 0 at once, so the lift-off is
    due at the start of the next step, at 0.1 s exactly, and the controller is called
    with it (reason event, lift_off).  After it the system's centre C falls freely from
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
    assert ("lift_off", t_s) in kinds and kinds[0][0] == "impact"
    assert (t_s, "event", "lift_off") in calls
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


def _high_flight(t0: float, **run):
    """The built-in body in free flight 100 m up from t0 (no impact for seconds), by RK4
    (C's parabola exactly, stage by stage): C's state at t in closed form."""
    doc = builtin_doc()
    doc["initial"].update(time=t0, com=[0.0, 0.0, 100.0])
    doc["run"].update({"outputs": ["pose", "momentum"], "model": "general", "method": "rk4",
                       **run})
    scene = parse_scene(doc)

    def com(t):
        s = t - t0
        v0 = np.array(doc["initial"]["com_velocity"], dtype=float)
        g = np.array([0.0, 0.0, -scene.g])
        return np.array(doc["initial"]["com"]) + v0 * s + 0.5 * g * s * s, v0 + g * s
    return scene, com


@pytest.mark.parametrize("t0", [0.2, 0.3])
def test_a_step_cut_to_a_push_ends_at_its_time_exactly(t0):
    """One RK4 step of 1 s from t0 = 0.2 s or 0.3 s is cut to a push at 0.9 s, where t0 +
    (0.9 - t0) rounds 1.1e-16 below or above 0.9: the step ends at the push's time
    itself, the push acts there once, its rows at 0.9 exactly, C on its parabola
    before it and the impulse's jump after it, and the run goes on to the end (ended a
    rounding error short, the loop would take a step of 1e-16 s: a step underflow)."""
    T, P = 0.9, np.array([0.2, -0.3, 0.5])
    assert t0 + (T - t0) != T                      # the rounding the loop corrects
    scene, com = _high_flight(t0, duration=1.0, step=1.0)
    res = run_prepared(prepare(scene), loop=Loop(lambda call: None,
                                                 pushes=[[T, *P, 0.0, 0.0, 0.0]]))
    assert res.status == "done" and res.stats["pushes"] == 1 and res.t[-1] == t0 + 1.0
    i = int(np.flatnonzero((res.t == T) & (res.row_kind == 1))[0])
    x, v = com(T)
    before, after = res.general[i], res.general[i + 1]
    np.testing.assert_allclose(before[G.com], x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(before[G.com_velocity], v, rtol=0, atol=1e-12)
    np.testing.assert_allclose(after[G.com_velocity] - v, P / (scene.M + scene.m),
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("t0", [1.0, -1.0])
def test_a_push_that_the_last_step_allowed_reaches_is_applied(t0):
    """max_steps = 2 RK4 steps of 0.25 s end on a push at t0 + 0.5 (t0 = 1 s or -1 s):
    the loop acts on it after the step that reaches it, before the step count stops the
    run (left to the next pass, as a stop 5 % short of the step's end would be on one
    side of t = 0, it is never applied): the status is max_steps, the push applied once,
    C's velocity its impulse's jump off the parabola's."""
    P = np.array([0.2, -0.3, 0.5])
    scene, com = _high_flight(t0, duration=1.0, step=0.25, max_steps=2)
    res = run_prepared(prepare(scene), loop=Loop(lambda call: None,
                                                 pushes=[[t0 + 0.5, *P, 0.0, 0.0, 0.0]]))
    assert res.status == "max_steps" and res.stats["steps"] == 2
    assert res.stats["pushes"] == 1
    assert res.t[-1] == t0 + 0.5 and res.row_kind[-1] == abi.ROW_KIND["after_event"]
    _, v = com(t0 + 0.5)
    np.testing.assert_allclose(res.general[-1][G.com_velocity] - v, P / (scene.M + scene.m),
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("t_push, v_up", [(0.9, 0.05), (0.5, 1.47)])
def test_the_least_normal_reaction_holds_across_two_contacts(t_push, v_up):
    """A plastic ball resting from t = 0 while its point oscillates along the vertical, z =
    a sin(W t) (N = (m + M)(g - nu a W^2 sin(W t)), 2 % either side of (m + M) g), pushed
    up at C at t_push, lands and rests again.  Pushed at 0.9 s after N's least value
    (m + M)(g - nu a W^2) at t = pi / (2 W), it lands 10 ms later where N is 0.06 %
    above that least value and rising: the summary keeps the first contact's least (as
    sampled, within 1e-5).  Pushed at 0.5 s (N still falling) it lands after 0.3 s just
    past pi / (2 W), where N is below all of the first contact's and then rises: the
    summary's least is the second entry's own N, the closed form's there.  (An entry
    taken only 5 % lower, or up to 5 % higher, would show.)"""
    a, W, nu, g = 0.3, 2.0, 0.2 / 1.2, 9.81

    def N(t):
        return 1.2 * (g - nu * a * W * W * math.sin(W * t))
    doc = ball(e=0.0, z0=0.5, law=("0", "0", f"{a}*sin({W}*t)"), duration=1.2, rtol=1e-10,
               atol=1e-12, method="dopri5", model="general")
    res = run_prepared(prepare(doc), loop=Loop(lambda call: None,
                                               pushes=[[t_push, 0.0, 0.0, 1.2 * v_up,
                                                        0.0, 0.0, 0.0]]))
    assert res.status == "done"
    kinds = [e["kind"] for e in res.events]
    assert kinds == ["impact", "contact", "push", "impact", "contact"]
    second = res.events[-1]
    assert abs(second["value"] - N(second["t"])) < 1e-9
    least = N(math.pi / (2 * W))
    if t_push > math.pi / (2 * W):
        assert least < second["value"] < 1.01 * least
        assert least * (1 - 1e-12) <= res.min_normal < least * (1 + 1e-5)
    else:
        assert second["value"] < min(N(t) for t in np.linspace(0.0, t_push, 501))
        assert res.min_normal == second["value"]


def test_a_push_at_a_samples_time_is_applied_and_the_sample_called_after_it():
    """A push at 0.7 s with samples every 0.02 s: the 35th sample, 0 + 35 * 0.02, rounds to
    an ulp past 0.7 (a new user's trial: the closed loop stopped there, step_underflow,
    the loop asking a step of 1e-16 s): both are due at 0.7, the push first, the sample
    reading the pushed state (the run's row after the push), C's velocity the parabola's
    and the impulse's jump, and the run goes on to its end."""
    T, P = 0.7, np.array([0.2, -0.3, 0.5])
    assert 35 * 0.02 != T                          # the rounding the loop must absorb
    scene, com = _high_flight(0.0, duration=0.8, step=0.01)
    calls = []
    res = run_prepared(prepare(scene), loop=Loop(lambda call: calls.append(call),
                                                 period=0.02,
                                                 pushes=[[T, *P, 0.0, 0.0, 0.0]]))
    assert res.status == "done" and res.stats["pushes"] == 1 and res.t[-1] == 0.8
    at = [c for c in calls if c.reason == "sample" and abs(c.t - T) < 1e-12]
    assert len(at) == 1 and len([c for c in calls if c.reason == "sample"]) == 40
    i = int(np.flatnonzero((res.t == T) & (res.row_kind == 1))[0])
    np.testing.assert_array_equal(at[0].q, res.q[i + 1])
    _, v = com(T)
    np.testing.assert_allclose(res.general[i + 1][G.com_velocity] - v,
                               P / (scene.M + scene.m), rtol=0, atol=1e-12)
