"""crt_base_flow.h's rules at their edges (issue 36: its mutants), each against a closed
form, derive/base_reference.py or the rule's own arithmetic done apart in Python.

* N's resolution, crt_base_n_res = 1e-9 (M + m) g: a root of the edge's margin located
  where N is at or below it is N's (crt_base_tie), above it a tip.  A box at rest, its
  point c off the axis, pushed up and down (tests/test_base_tip_before_lift.py's closed
  forms): cp reaches the edge -a where N = g c M / (a + c), here 0.98 and 1.02 of N's
  resolution.  Below it the run goes on to the lift-off at N = 0 (the closed form's
  time); above it the run tips at the closed form's time to 1e-13 s (N falls at 1e3 N/s
  there: 5 % of the resolution is 7e-13 s) with the margin ~0 at the event (not the -a a
  margin cut off by N reads).
* The slip's start from rest along its slow manifold (crt_base_onset_far): taken when
  its span ends before the run's end, refused when the end falls inside it; its grid
  rows inside the span and after it against the reference; each start at its seed
  (1e-6 along the manifold to 1e-10, or the Taylor start's 1e-9), under uniform and
  linear pressure and at negative times.
* A break-away 1e-6 s before the lift-off: the Taylor start's span cut at N's root
  (crt_base_onset_span), the lift-off at its closed-form time.
"""
import math

import numpy as np
import pytest

import test_base_runtime as tbr

G = 9.81


def _events(raw):
    return [(row[0], tbr.abi.names(tbr.abi.EVENT_KINDS)[int(row[1])], row[2])
            for row in raw.events]


@pytest.mark.parametrize("f", [0.98, 1.02])
def test_an_edge_reached_at_ns_resolution_is_the_lift_offs_below_it_a_tip_above(f):
    M, m, a, W = 1.0, 0.5, 0.1, 40.0
    A = (M + m) * G / (0.5 * m * W * W)          # N = 0 at sin(W t) = 1/2
    n_tip = f * 1e-9 * (M + m) * G               # N where cp reaches the edge
    c = n_tip * a / (G * M - n_tip)              # N_tip = g c M / (a + c)
    scene = tbr._scene(f'mass = {M}\ninertia = [0.01, 0.02, 0.025]\nshape = "box"\n'
                       f'half_extents = [{a}, 0.06, 0.04]',
                       f'mass = {m}\nlaw = ["{c!r}", "0", "{A!r}*sin({W}*t)"]', 0.5, 0.05)
    raw = tbr.run_base(scene, np.zeros(6))
    t_l = math.asin((M + m) * G / (m * A * W * W)) / W
    t_tip = math.asin(G * (a * (M + m) + c * m) / (m * (a + c) * A * W * W)) / W
    assert 0.0 < t_l - t_tip < 1e-9
    (t, kind, value), = _events(raw)
    if f < 1.0:
        assert raw.status == "lift_off" and kind == "lift_off" and abs(t - t_l) < 1e-12
    else:
        assert raw.status == "tipping" and kind == "tipping" and abs(t - t_tip) < 1e-13
        assert -1e-3 * a < value <= 0.0         # (cp moves at 7e9 a/s there)


def _scene9(duration=None, output_dt=0.0):
    """Robustness scene 9 (derive verify robustness --plane face, seed 11): a box that
    sticks, then slips from rest at t* = 1.1649 s along its slow manifold (the start of
    tests/test_base_runtime.py's slow-manifold test), ``duration`` and ``output_dt`` set."""
    from derive.verify.generators import random_face_scene
    from derive.verify.robustness import FACE_MAX_DURATION, PLANE_SEEDS
    doc = random_face_scene(np.random.default_rng(11 * 1_000_003 + PLANE_SEEDS["face"] + 9),
                            FACE_MAX_DURATION)
    if duration is not None:
        doc["run"]["duration"] = duration
    doc["run"]["output_dt"] = output_dt
    return doc


def _start(run):
    """The slip's time and the row after it: its time and the scaled twist's size there."""
    from derive.runtime import choice
    ell = choice.base_face(run.scene).size
    t_slip = [e["t"] for e in run.events if e["kind"] == "slip"][0]
    after = int(np.flatnonzero((run.row_kind == tbr.abi.ROW_KIND["after_event"])
                               & (run.t >= t_slip))[0])
    q = run.model_q[after]
    return t_slip, run.t[after], math.hypot(math.hypot(q[3], q[4]), ell * q[5]) / math.sqrt(
        run.scene.g * ell)


def test_a_slip_from_rest_near_the_runs_end_starts_along_its_manifold_only_inside_it():
    """The start along the slow manifold (crt_base_onset_far, to a scaled twist of 1e-6)
    is taken when its span tau ends before the run's end: at t* + 0.02 s (t* within 2 % of
    the end, as a time) it is; when the run ends at t* + tau / 2 it is not (the Taylor
    start, to 1e2 eps = 1e-9), and the run ends at its end, no row past it."""
    from derive.runtime.driver import simulate
    from derive.scene.parse import parse_scene
    first = simulate(parse_scene(_scene9(), "random"))
    t_slip = _start(first)[0]
    run = simulate(parse_scene(_scene9(t_slip + 0.02), "random"))
    assert run.status == "done" and t_slip > (t_slip + 0.02) / 1.05
    t_s, t_after, size = _start(run)
    assert abs(t_s - t_slip) < 1e-12 and abs(size / 1e-6 - 1.0) < 1e-9
    tau = t_after - t_slip
    assert 1e-7 < tau < 1e-5
    end = t_slip + tau / 2
    run = simulate(parse_scene(_scene9(end), "random"))
    t_s, t_after, size = _start(run)
    assert run.status == "done" and abs(t_s - t_slip) < 1e-12 and abs(size / 1e-9 - 1.0) < 1e-9
    assert t_slip <= t_after < end and run.t[-1] == end and run.t.max() == end


def test_grid_rows_inside_and_after_a_slips_start_along_its_manifold_are_the_references():
    """A grid row inside the slow manifold's span (t* + tau / 2: the start's series there)
    and the next, 1 ms later (the slip's steps), against derive/base_reference.py
    (Newton-Euler, adaptive quadrature) from the rest just before t*, to 1e-9: the twist
    there is 5e-7 m/s, the start's end or the rest 5e-7 m/s off it (~2 s of CPU)."""
    from derive import base_reference as br
    from derive.runtime.driver import prepare, run_prepared, simulate
    from derive.scene.parse import parse_scene
    from derive.verify.judges import face_system
    t_slip, t_after, _ = _start(simulate(parse_scene(_scene9(), "random")))
    inside = t_slip + (t_after - t_slip) / 2
    doc = _scene9(t_slip + 2e-3, 1e-3)
    run = run_prepared(prepare(doc, output_origin=inside - 1.0))
    step = run.row_kind == tbr.abi.ROW_KIND["step"]
    rows = [int(np.flatnonzero(step & (np.abs(run.t - t) < 1e-12))[0])
            for t in (inside, inside + 1e-3)]
    assert run.status == "done" and t_slip < run.t[rows[0]] < t_after
    rest = int(np.flatnonzero(run.t < t_slip - 1e-4)[-1])
    assert not np.any(run.model_q[rest, 3:])
    marks = [float(run.t[j]) for j in rows]
    ref = br.Integrator(face_system(parse_scene(doc, "random"))).run(
        run.model_q[rest], t_slip - 1e-7, marks[-1], samples=marks)
    assert [k for _, k in ref.events] == ["slip"]
    for sample, j in zip(ref.samples, rows):
        assert sample[0] == run.t[j] and np.abs(sample[1:] - run.model_q[j]).max() < 1e-9
    assert np.abs(run.model_q[rows[0], 3:]).max() > 1e-7


def _face_scene(k):
    """Scene k of derive verify robustness --plane face (seed 11), as it runs it."""
    from derive.verify.generators import random_face_scene
    from derive.verify.robustness import FACE_MAX_DURATION, PLANE_SEEDS
    doc = random_face_scene(np.random.default_rng(11 * 1_000_003 + PLANE_SEEDS["face"] + k),
                            FACE_MAX_DURATION)
    if k % 2:
        doc["plane"]["restitution"] = 0.3
    return doc


@pytest.mark.parametrize("k, far, t0", [(843, 2, None), (422, 0, None), (207, 2, None),
                                         (207, 2, -3.0)])
def test_each_slip_from_rest_starts_at_its_seed(k, far, t0):
    """A slip from rest starts along its slow manifold at a scaled twist of R = 1e-6
    exactly (crt_base_onset_far: tau solves r(tau) = R by Newton's method to 1e-9 tau, and
    the twist there is r(tau)), else by its Taylor series at the seed 1e2 eps = 1e-9 along
    the start's direction (the twist's size that or a little more, with the part across).
    Robustness scenes 843 (two starts along the manifold where the quadratic's first guess
    of tau is 40 % off r = R) and 422 (a start at t0 where the manifold's start is
    refused: the Taylor start), to 1 s; and 207, under linear pressure (the kern's margin
    held positive at the manifold's nodes: two starts along it), and 207 from t0 = -3 s
    (a run at negative times, its starts along the manifold ending before its end)."""
    from derive.runtime import choice
    from derive.runtime.driver import prepare, run_prepared
    from derive.scene.parse import parse_scene
    doc = _face_scene(k)
    doc["run"]["duration"] = min(doc["run"]["duration"], 1.0)
    if t0 is not None:
        doc["initial"]["time"] = t0
    scene = parse_scene(doc, "random")
    run = run_prepared(prepare(scene))
    ell = choice.base_face(scene).size
    slips = [e["t"] for e in run.events if e["kind"] == "slip"]
    after = np.flatnonzero(run.row_kind == tbr.abi.ROW_KIND["after_event"])
    first = [after[run.t[after] >= t][0] for t in slips]      # (the row after each slip)
    sizes = [math.hypot(math.hypot(q[3], q[4]), ell * q[5]) / math.sqrt(scene.g * ell)
             for q in run.model_q[first]]
    assert run.status == "done" and len(sizes) == len(slips) >= 1
    assert sum(abs(s / 1e-6 - 1.0) < 1e-10 for s in sizes) == far
    assert all(abs(s / 1e-6 - 1.0) < 1e-10 or 1e-9 * (1 - 1e-12) < s < 2e-9 for s in sizes)


def test_a_break_away_just_before_the_lift_off_ends_at_the_lift_off():
    """A box at rest, its point pushed sideways at x'' = c = 1e-3 m/s^2 and up and down so
    that N = (M + m) g + m z'' falls through 0 at 1e3 N/s: the push breaks the rest where
    mu_s N = m c, 1e-6 s before N = 0 (the closed forms' times), and the slip's Taylor
    start (its span ~1.5e-6 s, the seed 1e2 eps over the along rate's growth) is cut at
    N's root (crt_base_onset_span): the lift-off at the closed form's time to 1e-12, not a
    span late.  (The point moves on the face's plane at N = 0: no moment, no tip.)"""
    M, m, a, W, mu, c = 1.0, 0.5, 0.1, 40.0, 0.5, 1e-3
    A = (M + m) * G / (0.5 * m * W * W)          # N = 0 at sin(W t) = 1/2
    law = f'["{c / 2!r}*t*t", "0", "-0.04 + {A!r}*(sin({W}*t) - 0.5)"]'
    scene = tbr._scene(f'mass = {M}\ninertia = [0.01, 0.02, 0.025]\nshape = "box"\n'
                       f'half_extents = [{a}, 0.06, 0.04]', f'mass = {m}\nlaw = {law}', mu, 0.05)
    raw = tbr.run_base(scene, np.zeros(6))
    t_l = math.asin((M + m) * G / (m * A * W * W)) / W
    t_b = math.asin(((M + m) * G - m * c / mu) / (m * A * W * W)) / W
    assert 5e-7 < t_l - t_b < 1.5e-6
    assert raw.status == "lift_off" and [k for _, k, _ in _events(raw)] == ["slip", "lift_off"]
    assert np.abs([t for t, _, _ in _events(raw)] - np.array([t_b, t_l])).max() < 1e-12


def _shifted(doc, T):
    """``doc`` T seconds earlier: from t0 - T, each law of t read at t + T (the same motion
    at other times)."""
    import copy
    import re
    out = copy.deepcopy(doc)
    def later(expr):
        return re.sub(r"\bt\b", f"(t + {T!r})", expr)
    for point in out.get("point", []):
        point["law"] = [later(x) for x in point["law"]]
    for rotor in out.get("rotor", []):
        rotor["law"] = later(rotor["law"])
    out["initial"]["time"] = out["initial"].get("time", 0.0) - T
    return out


def test_grid_rows_at_negative_times_and_in_small_buffers_are_those_3_s_later():
    """Robustness scene 9 (two sticks and two slips from rest, the slips' steps in arc
    time) on a grid of 1 ms, and the same scene 3 s earlier (from t0 = -3 s, its laws read
    at t + 3): the same events and each grid row's state to 1e-9 (4e-11 measured), in one
    buffer and in buffers of 12 rows and of CRT_MIN_ROWS = 8 (an empty buffer holds a grid
    row and a step's own rows: crt_base_rows_fit), each run ending, each grid row once.
    At negative times a grid row inside a step is found on the step's dense output (a
    row 5 % of its time past the step's start read the start: 6e-3 off); the rows that fit
    a buffer are counted from the grid's origin -3 s (counted from 0, none: the rows past
    the buffer lost); a buffer of 8 rows whose room were 0 retried its step forever (each
    run here in a forked process: no answer in 20 s fails)."""
    from derive.runtime.driver import prepare, run_prepared, simulate
    from derive.runtime.session import Session
    from derive.scene.parse import parse_scene
    doc = _scene9(1.5, 1e-3)
    late = simulate(parse_scene(doc, "random"))
    kinds = [e["kind"] for e in late.events]
    assert late.status == "done" and kinds == ["stick", "slip", "stick", "slip"]
    grid = late.row_kind == tbr.abi.ROW_KIND["step"]
    assert grid.sum() == 1501 and np.abs(late.t[grid] - 1e-3 * np.arange(1501)).max() < 1e-12
    prep = prepare(parse_scene(_shifted(doc, 3.0), "random"))

    def early(chunk):
        run = run_prepared(prep, session=chunk and Session(prep.library, chunk=chunk))
        step = run.row_kind == tbr.abi.ROW_KIND["step"]
        return (run.status, [(e["kind"], e["t"]) for e in run.events], run.t[step],
                run.model_q[step])
    for chunk in (None, 12, tbr.abi.MIN_ROWS):
        status, events, t, q = _in_child(early, chunk)
        assert status == "done" and [k for k, _ in events] == kinds
        assert np.abs(np.array([t for _, t in events]) + 3.0
                      - [e["t"] for e in late.events]).max() < 1e-12
        assert np.abs(t + 3.0 - late.t[grid]).max() < 1e-12
        assert np.abs(q - late.model_q[grid]).max() < 1e-9


def _in_child(fn, *args, limit=20.0):
    """fn(*args) in a forked process, its answer back through a pipe: a run that never
    ends (a loop inside one C call, which no Python signal interrupts) fails here after
    ``limit`` seconds (it takes 0.05 s)."""
    import multiprocessing
    ctx = multiprocessing.get_context("fork")
    here, there = ctx.Pipe(duplex=False)
    child = ctx.Process(target=lambda: there.send(fn(*args)), daemon=True)
    child.start()
    try:
        assert here.poll(limit), f"{fn.__name__}{args}: no answer in {limit} s (a hang)"
        return here.recv()
    finally:
        child.kill()
        child.join()


def test_a_tip_inside_the_manifolds_span_refuses_the_start_along_it():
    """Scene 9's slip from rest starts along its slow manifold (R = 1e-6, tau = 2.3e-6 s);
    the start is taken only where N and the edge's margin are positive at the Gauss rule's
    nodes t* + (0.113, 0.5, 0.887) tau and at its end.  A rotor about the body's x axis
    (horizontal here) turned by a pulse psi = A exp(-((t - t* - tau / 2) / (0.11 tau))^2)
    is a pure moment about a horizontal axis, -I psi'': N and the slip's rates (uniform
    pressure) are the same, the centre of pressure moves by I psi'' / N, 0.46 m at the
    middle node (past every edge: the box's half extents are 0.11 m and 0.072 m), 4.5e-5 m
    at the outer nodes and 2e-8 m at t* and at the end.  So the start is refused (the
    Taylor start at 1e2 eps = 1e-9) at the same break-away time to the bit; the margins
    tested at the end alone take it (the slip's steps from the Taylor start step over the
    0.5 microsecond tip, as they step over any event shorter than a step)."""
    from derive.runtime.driver import simulate
    from derive.scene.parse import parse_scene
    doc = _scene9(1.2)
    t_slip, t_after, size = _start(simulate(parse_scene(doc, "random")))
    tau = float(t_after - t_slip)
    assert abs(size / 1e-6 - 1.0) < 1e-9 and 2e-6 < tau < 2.6e-6
    inertia, A, w = 1e-4, 1e-8, 0.11 * tau
    doc["rotor"] = [{"axis": [1.0, 0.0, 0.0], "inertia": inertia,
                     "law": f"{A!r}*exp(-((t - {t_slip + tau / 2!r})/{w!r})**2)"}]
    run = simulate(parse_scene(doc, "random"))
    N = sum([doc["body"]["mass"]] + [p["mass"] for p in doc["point"]]) * run.scene.g
    def shift(x):                            # I psi''(x tau after t*) / N
        u = (x - 0.5) * tau / w
        return inertia * A * abs(4 * u * u - 2) * math.exp(-u * u) / (w * w) / N
    assert shift(0.5) > 0.35 and shift(0.1127) < 1e-4 and shift(1.0) < 1e-7
    t_s, _, size = _start(run)
    assert run.status == "done" and abs(t_s - t_slip) < 1e-12 and 1e-9 * (1 - 1e-12) < size < 2e-9


@pytest.mark.parametrize("T", [0.0, 3.0])
def test_a_grid_row_inside_a_taylor_start_reads_the_start_not_the_next_step(T):
    """Scene 9 ending at t* + tau / 2 (inside the slow manifold's span: its slip starts by
    the Taylor series, to the seed 1e2 eps = 1e-9 in delta ~ 2e-9 s, no row inside) on a
    grid whose origin is t* + delta / 2: that row, at or before the first slip step's
    start, reads the step's start (crt_base_rows: 1e-9 s at most), the rest's pose to
    1e-12 and a twist of at most the seed, as the slip from rest has in delta / 2 (read at
    the step's end, it has the twist grown over that step, 1.2e-9).  At t* and 3 s
    earlier (the scene from t0 = -3 s, its laws read at t + 3: a test 5 % off the step's
    end reads differently at negative times)."""
    from derive.runtime import choice
    from derive.runtime.driver import prepare, run_prepared, simulate
    from derive.scene.parse import parse_scene
    t_slip, t_after, _ = _start(simulate(parse_scene(_scene9(), "random")))
    end = float(t_slip + (t_after - t_slip) / 2)
    doc = _shifted(_scene9(end, 1e-3), T)
    t_s, t_after, size = _start(simulate(parse_scene(doc, "random")))
    delta = float(t_after - t_s)
    assert abs(size / 1e-9 - 1.0) < 1e-9 and 0.0 < delta < 1e-7 and abs(t_s + T - t_slip) < 1e-12
    inside = t_s + delta / 2
    run = run_prepared(prepare(parse_scene(doc, "random"), output_origin=inside - 1.0))
    row = int(np.flatnonzero((run.row_kind == tbr.abi.ROW_KIND["step"])
                             & (np.abs(run.t - inside) < 1e-12))[0])
    rest = int(np.flatnonzero(run.t < t_s)[-1])
    q, ell = run.model_q[row], choice.base_face(run.scene).size
    assert t_s < run.t[row] < t_s + delta and not np.any(run.model_q[rest, 3:])
    assert np.abs(q[:3] - run.model_q[rest, :3]).max() < 1e-12
    twist = math.hypot(math.hypot(q[3], q[4]), ell * q[5]) / math.sqrt(run.scene.g * ell)
    assert twist <= 1e-9 * (1 + 1e-9)


@pytest.mark.parametrize("axis", [0, 1])
def test_a_box_sliding_along_either_axis_of_its_face_stops_at_the_closed_form(axis):
    """A box on its face sliding from v0 = 0.3 m/s along the face's x or y axis (a slip
    along a line: its stop is where the signed speed xi.d along the line reaches 0):
    it stops at v0 / (mu g) having slid v0^2 / (2 mu g), the other axis and the yaw
    untouched, a stick event at the stop.  (The speed without its y term is 0 all along
    a slide along y.)"""
    M, mu, v0 = 1.0, 0.3, 0.3
    t_stop, dist = v0 / (mu * G), v0 * v0 / (2 * mu * G)
    scene = tbr._scene(f'mass = {M}\ninertia = [0.01, 0.02, 0.025]\nshape = "box"\n'
                       'half_extents = [0.1, 0.06, 0.04]', 'mass = 0.2\nlaw = ["0", "0", "0"]',
                       mu, t_stop + 0.01)
    q0 = np.zeros(6)
    q0[3 + axis] = v0
    raw = tbr.run_base(scene, q0)
    (t, kind, _), = _events(raw)
    assert raw.status == "done" and kind == "stick" and abs(t - t_stop) < 1e-9
    want = np.zeros(6)
    want[axis] = dist
    assert np.abs(raw.q[-1] - want).max() < 1e-9
