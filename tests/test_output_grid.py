"""The rows of a run (crt_step.h's crt_flush_outputs, crt_events.h's step cut after an
impact) against a grid and flights computed apart from the runtime.

The scene is the classical ball (tests/test_runtime.py's ``ball``), whose flights are a
closed form: dropped from H it lands at sqrt(2 H / g) with v1 = sqrt(2 g H), and after
its k-th impact it leaves at e^k v1 and flies 2 e^k v1 / g.

* Rows every output_dt: their times are t0 + k output_dt below the end, then the end
  itself, t0 + duration exactly; the heights and speeds in them are the parabolas'.
  output_dt = 0.047 puts a row within 5 % of time after the first impact (0.470 against
  0.4515) and one within 5 % before the second (1.128 against 1.174), and 48 output_dt
  falls 4e-16 s past the duration of 2.256 s (the end's row is the end, not the grid's
  round-off past it); a duration of 2.25 s ends 6 ms short of it (the end's row
  follows the grid's last); started at t0 = -30 s, the run ends at a negative time
  (a bound scaled by 5 % there moves by more than output_dt).  The same run in buffers
  of the runtime's least size (a flush left pending at every few rows) gives the same
  rows.
* Rows at every step: after each impact the runtime cuts the step to a quarter of the
  hop that follows (crt_collide), so the first step row after it is at most 2 e^k v1 /
  (4 g) later: the ball's flights are parabolas that the methods integrate exactly, so
  without the cut its steps would grow past whole hops.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from derive import abi
from derive.runtime.driver import prepare, run_prepared, simulate
from derive.runtime.loop import Loop
from derive.runtime.session import Session, session_for
from test_runtime import ball

G, R, E, Z0 = 9.81, 0.5, 0.8, 1.5
DT, T = 0.047, 2.256
STEP, BEFORE, AFTER = (abi.ROW_KIND[k] for k in ("step", "before_event", "after_event"))


def flights(until: float):
    """The closed form: impact times and the speeds the ball leaves them with."""
    H = Z0 - R
    v1 = math.sqrt(2 * G * H)
    times, speeds = [math.sqrt(2 * H / G)], [E * v1]
    while times[-1] + 2 * speeds[-1] / G < until:
        times.append(times[-1] + 2 * speeds[-1] / G)
        speeds.append(E * speeds[-1])
    return np.array(times), np.array(speeds)


def closed_form(t: np.ndarray):
    """(Z_C, Z_C') of the ball at times t (not at an impact)."""
    times, speeds = flights(t[-1])
    k = np.searchsorted(times, t) - 1
    s = t - np.where(k >= 0, times[np.maximum(k, 0)], 0.0)
    v0 = np.where(k >= 0, speeds[np.maximum(k, 0)], 0.0)
    z0 = np.where(k >= 0, R, Z0)
    return z0 + v0 * s - 0.5 * G * s * s, v0 - G * s


def check_rows(t, q, kinds, t0, T, dt=DT):
    grid = t0 + np.arange(0, 60) * dt
    end = t0 + T
    expected = np.append(grid[grid < end], end)
    step = kinds == STEP
    assert len(t[step]) == len(expected)
    np.testing.assert_allclose(t[step], expected, rtol=0, atol=1e-13)
    assert t[step][-1] == end                            # the end, exactly
    t = t - t0
    z, v = closed_form(t[step])
    np.testing.assert_allclose(q[step, 0], z, rtol=0, atol=1e-8)
    np.testing.assert_allclose(q[step, 1], v, rtol=0, atol=1e-8)
    times, _ = flights(T)
    np.testing.assert_allclose(t[kinds == BEFORE], times, rtol=0, atol=1e-10)
    assert np.all(np.diff(t) >= 0.0)


@pytest.mark.parametrize("t0, T", [(0.0, T), (0.0, 2.25), (-30.0, T)])
def test_rows_every_output_dt_are_the_grid_and_the_closed_form_flights(t0, T):
    doc = ball(e=E, z0=Z0, duration=T, output_dt=DT, rtol=1e-10, atol=1e-12)
    doc["initial"]["time"] = t0
    res = simulate(doc, progress=False)
    assert res.status == "done" and res.model == "translational"
    assert len(flights(T)[0]) == 4
    check_rows(res.t, res.model_q, res.row_kind, t0, T)
    # buffers of the least size the runtime takes: rows left pending, flushed next call
    prep = prepare(doc)
    small = Session(prep.library, chunk=max(abi.MIN_ROWS, abi.MIN_EVENTS))
    chunked = run_prepared(prep, session=small)
    assert chunked.status == "done"
    assert np.array_equal(chunked.t, res.t) and np.array_equal(chunked.row_kind, res.row_kind)
    np.testing.assert_array_equal(chunked.model_q, res.model_q)
    session_for(prep.kind)                               # the thread's own is untouched


@pytest.mark.parametrize("t0, shift", [(30.0, 0.0), (30.0, 0.3), (-30.0, 0.3)])
def test_rows_after_a_late_start_and_on_another_runs_grid(t0, shift):
    """Started at t0 = 30 s (crt_loop_begin's first grid point is t0 + output_dt, the
    initial row being t0's: a bound scaled by 5 % there put a second row at t0), and on
    the grid of another run whose origin is shift output_dt before t0 (the flight after a
    lift-off: driver.grid_phase puts the first grid point (1 - shift) output_dt after t0,
    a row there, not one output_dt later)."""
    doc = ball(e=E, z0=Z0, duration=T, output_dt=DT, rtol=1e-10, atol=1e-12)
    doc["initial"]["time"] = t0
    origin = t0 - shift * DT if shift else None
    res = run_prepared(prepare(doc, output_origin=origin))
    assert res.status == "done"
    first = t0 + (1.0 - shift) * DT if shift else t0 + DT
    grid = first + np.arange(0, 60) * DT
    expected = np.concatenate(([t0], grid[grid < t0 + T], [t0 + T]))
    steps = res.t[res.row_kind == STEP]
    assert len(steps) == len(expected)
    np.testing.assert_allclose(steps, expected, rtol=0, atol=1e-12)
    z, v = closed_form(steps - t0)
    np.testing.assert_allclose(res.model_q[res.row_kind == STEP, 0], z, rtol=0, atol=1e-8)


@pytest.mark.parametrize("t0", [0.0, -30.0])
def test_rows_left_pending_at_an_impact_are_the_grids(t0):
    """A grid point 1e-12 s after the first impact (within the last flush's slack of
    1e-9 output_dt, but not the end), the impact in the last 5 % of the run: in
    buffers of 8 to 19 rows the flush at the impact is left pending at some size, and
    the next call writes the rows before the impact only, the row after it from the
    flight that follows (its time the grid's, its speed upward, the closed form's), as
    the run in one buffer does."""
    t1 = math.sqrt(2 * (Z0 - R) / G)
    dt = (t1 + 1e-12) / 40                    # the impact step holds many rows
    duration = t1 / 0.97
    doc = ball(e=E, z0=Z0, duration=duration, output_dt=dt, rtol=1e-10, atol=1e-12)
    doc["initial"]["time"] = t0
    res = simulate(doc, progress=False)
    assert res.status == "done" and len(res.impacts) == 1
    check_rows(res.t, res.model_q, res.row_kind, t0, duration, dt)
    prep = prepare(doc)
    for chunk in range(8, 20):
        run = run_prepared(prep, session=Session(prep.library, chunk=chunk))
        assert np.array_equal(run.t, res.t) and np.array_equal(run.row_kind, res.row_kind)
        np.testing.assert_array_equal(run.model_q, res.model_q)


def test_the_step_after_an_impact_is_at_most_a_quarter_of_the_hop():
    res = simulate(ball(e=E, z0=Z0, duration=T, output_dt=0.0, rtol=1e-10, atol=1e-12),
                   progress=False)
    assert res.status == "done"
    times, speeds = flights(T)
    assert res.stats["rejected"] == 0
    for t_k, v_k in zip(times, speeds):
        after = res.t[(res.row_kind == STEP) & (res.t > t_k)]
        if len(after) == 0 or after[0] >= T:
            continue
        assert after[0] - t_k <= 0.25 * (2 * v_k / G) * (1 + 1e-9), (t_k, after[0] - t_k)


_FACE = """
name = "slide"
[body]
mass = 1.0
inertia = [0.01, 0.02, 0.025]
shape = "box"
half_extents = [0.1, 0.06, 0.04]
[[point]]
mass = 0.5
law = ["0.02*sin(20*t)", "0", "0"]
[plane]
friction = 0.2
[initial]
on_plane = true
carrier_velocity = [0.0, 0.0, 0.0]
[run]
duration = 0.5
"""


def test_a_base_runs_rows_every_output_dt_are_the_grids_as_the_balls():
    """A box on its face (the base model, crt_base.h) slipping and sticking three times
    under a sideways drive, rows every output_dt: its step rows are the grid t0 + k
    output_dt below the end, then the end, the same times as the ball's (the general
    loop's crt_flush_outputs) with the same output_dt and duration, and no step's own
    row beside them (it had written both); its events and end state are those of the run
    at every step, and the run in buffers of the least size gives the same rows."""
    from derive.scene import parse_scene
    dt, T = 0.047, 0.5
    face = simulate(parse_scene(_FACE + f"output_dt = {dt}\n"), progress=False)
    steps = simulate(parse_scene(_FACE), progress=False)
    ball_run = simulate(ball(e=E, z0=Z0, duration=T, output_dt=dt), progress=False)
    assert face.model == "base" and face.status == steps.status == "done"
    kinds = [e["kind"] for e in face.events]
    assert kinds == ["slip", "stick"] * 3 == [e["kind"] for e in steps.events]
    np.testing.assert_allclose([e["t"] for e in face.events], [e["t"] for e in steps.events],
                               rtol=0, atol=1e-12)
    grid = np.arange(0, 20) * dt
    expected = np.append(grid[grid < T], T)
    mine, its = face.t[face.row_kind == STEP], ball_run.t[ball_run.row_kind == STEP]
    np.testing.assert_allclose(mine, expected, rtol=0, atol=1e-13)
    assert np.array_equal(mine, its) and mine[-1] == T
    assert np.all(np.diff(face.t) >= 0.0)
    np.testing.assert_allclose(face.model_q[-1], steps.model_q[-1], rtol=0, atol=1e-9)
    prep = prepare(parse_scene(_FACE + f"output_dt = {dt}\n"))
    small = run_prepared(prep, session=Session(prep.library,
                                               chunk=max(abi.MIN_ROWS, abi.MIN_EVENTS)))
    assert np.array_equal(small.t, face.t) and np.array_equal(small.row_kind, face.row_kind)
    np.testing.assert_array_equal(small.model_q, face.model_q)


@pytest.mark.parametrize("t0", [0.0, -2.0])
def test_a_step_ending_just_short_of_a_grid_point_leaves_its_row_to_the_grid(t0):
    """A loop's sample (a stop every step ends on) 1e-12 s before the grid point one
    output_dt before the end: within a flush's slack of 1e-9 output_dt, in the last 5 %
    of a run that ends at 1 s or at -1 s.  Only the end's flush takes the slack; this
    one leaves the row to the next step's, which writes it at the grid's own time: the
    rows are the grid and the closed form's flights (written at the step's end, the row
    would be 1e-12 s early: crt_loop.h's flush made inclusive before the end, or 5 %
    early on either side of t = 0)."""
    dt = 0.02
    doc = ball(e=E, z0=Z0, duration=1.0, output_dt=dt, rtol=1e-10, atol=1e-12)
    doc["initial"]["time"] = t0
    calls = []
    res = run_prepared(prepare(doc), loop=Loop(lambda call: calls.append(call.t),
                                               period=49 * dt - 1e-12))
    assert res.status == "done"
    sample = t0 + 49 * dt - 1e-12
    assert sample in calls and sample not in res.t       # the step ended there, no row
    check_rows(res.t, res.model_q, res.row_kind, t0, 1.0, dt)
