"""The base model's rules at their edges (crt_base.h, crt_base_flow.h, crt_base_model.h,
crt_face.h): scenes that fall within a few per cent of a threshold on either side, so that
a rule moved by 2 % (derive verify mutants' 1.05 factors, a flipped comparison) changes an
asserted outcome; each outcome against a closed form or the rule's own arithmetic done
apart in Python.

* A start sliding at 0.98 and 1.02 of the slip's end (eps = 1e-11 sqrt(g ell)): below it
  the twist is the start's round-off, taken as rest (no event, O does not move); above it
  the slip runs to its stop at the closed form's v0 / (mu g) (one stick event).
* The gauge at the start, gamma0 = 1 -+ 0.98e-12 and 1 -+ 1.02e-12 (a point pushing the box
  with x'' = c + j t, so gamma = m x'' / (mu_s (M + m) g) exactly, rising or falling at
  1e-7 a second): within 1e-12 of 1 the rest holds unless gamma is rising (a slip at once);
  below 1 - 1e-12 it holds and a rising gamma breaks it where the line reaches 1, at the
  closed form's (1 - gamma0) / 1e-7 s; above 1 + 1e-12 the slip event comes at once.
  The rate makes the gauge 1e-6 t_scale later differ from the start's by 1 % of the
  margin, so the rising test is taken within 2 %.
* A break shorter than a stick's sample: 1 - gamma a cubic in t falling slowly at the
  stick's start (its secant allows the whole sample) and dipping to -0.032 inside it, back
  to its start's 0.05 at the sample's end; the parabola through the last three samples has
  its minimum inside, where 1 - gamma is negative: the slip starts at the cubic's first
  root (numpy.roots), not missed, from t0 = 0, 1 s and -1 s (the minimum's place
  tested against the sample's ends at times far from 0).  And one falling fast at the
  start (8 a second from 0.02), dipping to -0.015 and up to 0.18 at the sample's end,
  where that parabola's minimum is at 0.16 of the sample (1 - gamma = +0.004 there): the
  sample shrunk by the secant's rate (to 2 g / r, 0.51 of it) lands inside the break.
* A rest at gamma within 1e-12 of 1 whose gauge falls now and rises after 3e-6 t_scale:
  the rest holds and the slip starts at the quadratic's root (3.3e-7 s), not at once.
* max_steps stops the crawl after exactly that many steps, its rows the full run's; a
  rest whose samples end exactly on the grid writes each grid row once, and the end's.
* A step covers at most hmax of time, in the slip in arc time too (a disc sliding and
  spinning to its one stop, hmax 1 ms): every row of the slip at most hmax after the
  last (the rule hmax means, read from the rows); its stop has one row before it (where
  rho = eps) and one after it, at its time.
* Rows every output_dt in buffers of 8 to 12 rows (a stick's sample and a slip's step hold
  more grid rows than that: the step shrunk to what fits, or taken again once the buffer
  is emptied) are the rows of one large buffer, bit for bit, and on the grid.
* The run's counts (sticks, slips, reversals, lift-offs) are its events counted apart, in
  runs that end in each way: the crawl and the reversals of tests/test_base_runtime.py, a
  lift-off, a tip and the face lifting (a point walking out at c: the edge at a (M + m) /
  (m c), the kern at a third of it); and each stick, slip and reversal has one row before
  it, at its time, and one after it (a stick's at its time, a slip's where its start from
  rest puts it).
* The body's rules at crt_init (crt_base_body_set): the vertical within 0.97e-9 of a face
  normal (1 - n_z / |n| for n = (e, 0, 1), the closed form 1 - 1 / sqrt(1 + e^2)) is taken
  and at 1.03e-9 refused (n0_x); static_friction at 0.98 friction refused, at friction
  taken; a pressure neither uniform nor linear refused; with two faults the first named.
* The grid after a late start ([initial].time = 1 s: the start's row once, then t0 + k dt)
  and on a hand-over's grid (its origin 4 ms after t0: the first grid row there).
"""
import math

import numpy as np
import pytest

from derive import abi

import test_base_runtime as tbr

G = 9.81
A_, B_ = 0.1, 0.06                      # the box's face: half sizes
ELL = math.hypot(A_, B_)                # the face's size (its half-diagonal)
EPS = 1e-11 * math.sqrt(G * ELL)        # the slip's end (crt_contact_start)
BOX = 'mass = 1.0\ninertia = [0.01, 0.02, 0.025]\nshape = "box"\nhalf_extents = [0.1, 0.06, 0.04]'


def _box(mu=0.3, duration=0.05, law='["0", "0", "0"]', t0=0.0):
    return tbr._scene(BOX, f"mass = 0.2\nlaw = {law}", mu, duration, t0)


@pytest.mark.parametrize("f", [0.98, 1.02])
def test_a_start_sliding_at_the_slips_end_is_rest_below_it_and_a_slip_above(f):
    mu, v0 = 0.3, f * EPS
    raw = tbr.run_base(_box(mu), [0.0, 0.0, 0.0, v0, 0.0, 0.0])
    got = tbr._events(raw)
    assert raw.status == "done"
    if f < 1.0:
        assert got == [] and np.all(raw.q[:, :3] == 0.0)
    else:
        (t, kind), = got
        assert kind == "stick" and abs(t - v0 / (mu * G)) < 1e-6 * v0 / (mu * G)
    assert np.all(raw.q[-1, 3:] == 0.0)


@pytest.mark.parametrize("after", [1e-6, 1e-5, -1e-6, -1e-5])
def test_a_slip_stopping_just_before_or_after_the_runs_end(after):
    """The box sliding from 0.3 m/s stops at the closed form's v0 / (mu g), 1 and 10
    microseconds before or after the run's end, inside the slip's last step (the run's end
    and the stop close on the step's fraction): the earlier is taken.  A stop before the
    end: a stick event at its time and O at rest; after it: no event, the run ending at
    its end still sliding at mu g |after|, as the closed form says."""
    mu, v0 = 0.3, 0.3
    t_stop = v0 / (mu * G)
    raw = tbr.run_base(_box(mu, t_stop + after), [0.0, 0.0, 0.0, v0, 0.0, 0.0])
    assert raw.status == "done" and abs(raw.t[-1] - t_stop - after) < 1e-12
    if after > 0:
        (t, kind), = tbr._events(raw)
        assert kind == "stick" and abs(t - t_stop) < 1e-9 and np.all(raw.q[-1, 3:] == 0.0)
    else:
        assert tbr._events(raw) == []
        assert abs(raw.q[-1, 3] - mu * G * -after) < 1e-9 * v0


MU_S, M_, m_ = 0.35, 1.0, 0.2
RATE = 1e-7                             # gamma's rate, 1/s


@pytest.mark.parametrize("margin", [1.02e-12, 0.98e-12, -0.98e-12, -1.02e-12])
@pytest.mark.parametrize("rising", [True, False])
def test_the_rest_at_gamma_within_1e12_of_1_breaks_only_if_gamma_rises(margin, rising):
    scale = MU_S * (M_ + m_) * G / m_   # x'' = scale * gamma
    c, j = (1.0 - margin) * scale, (RATE if rising else -RATE) * scale
    law = f'["{c / 2!r}*t*t + {j / 6!r}*t*t*t", "0", "0"]'
    raw = tbr.run_base(_box(0.3, 3e-5, law), np.zeros(6), mu_s=MU_S)
    got = [(k, t) for t, k in tbr._events(raw)]
    if margin > 1e-12:                  # below 1: rests, breaks where gamma reaches 1
        want = [("slip", margin / RATE)] if rising else []
    elif margin >= -1e-12:              # at 1: breaks at once if rising
        want = [("slip", 0.0)] if rising else []
    else:                               # past 1: the slip event at once
        want = [("slip", 0.0)]
    assert [k for k, _ in got] == [k for k, _ in want]
    assert all(abs(t - tw) < 1e-8 for (_, t), (_, tw) in zip(got, want))


def test_a_rest_at_1_whose_gauge_falls_now_and_rises_later_holds_until_it_crosses():
    """gamma0 = 1 - 0.5e-12 (inside the window) falling now and rising after a minimum at
    t_m = 1.5e-6 t_scale (gamma = gamma0 - r t + b t^2, b = 1e3 /s^2, r = 2 b t_m; t_scale =
    sqrt(ell / g) = 0.109 s): "rising" is gamma's trend 1e-6 t_scale ahead (falling, by
    2e-11 there), not where it turns (10 times further it has risen by 8e-10), so the rest
    holds and the slip starts where gamma reaches 1, at the quadratic's root (3.3e-7 s),
    not at once."""
    scale = MU_S * (M_ + m_) * G / m_   # x'' = scale * gamma
    t_scale = math.sqrt(ELL / G)
    b = 1e3
    r = 2 * b * 1.5e-6 * t_scale
    margin = 0.5e-12
    c, j, k = (1.0 - margin) * scale, -r * scale, b * scale
    law = f'["{c / 2!r}*t*t + {j / 6!r}*t*t*t + {k / 12!r}*t*t*t*t", "0", "0"]'
    raw = tbr.run_base(_box(0.3, 1e-5, law), np.zeros(6), mu_s=MU_S)
    root = max(np.roots([b, -r, -margin]).real)
    (t, kind), *_ = tbr._events(raw)
    assert kind == "slip" and abs(t - root) < 1e-9 and root > 3e-7


@pytest.mark.parametrize("t0", [0.0, 1.0, -1.0])
@pytest.mark.parametrize("g0, r0, p, q", [(0.05, 4.0, -4550.0, 495000.0),
                                          (0.02, 8.0, -1900.0, 430000.0)])
def test_a_break_shorter_than_a_sample_is_found_at_its_start(g0, r0, p, q, t0):
    h = 0.01                                               # 1 - gamma = g0 - r0 t + ...
    scale = MU_S * (M_ + m_) * G / m_                      # x'' = scale * gamma
    t = f"(t - {t0!r})"                                    # (from t0: the sample's times
    x = (f"{scale!r}*({t}*{t}*{(1 - g0) / 2!r} + {t}*{t}*{t}*{r0 / 6!r}"  # far from 0)
         f" - {t}*{t}*{t}*{t}*{p / 12!r} - {t}*{t}*{t}*{t}*{t}*{q / 20!r})")
    raw = tbr.run_base(_box(0.3, 1.15 * h, f'["{x}", "0", "0"]', t0), np.zeros(6), mu_s=MU_S,
                       hmax=8 * h)
    roots = np.roots([q, p, -r0, g0])
    first = min(r.real for r in roots if abs(r.imag) < 1e-12 and 0 < r.real < h)
    t, kind = tbr._events(raw)[0]
    assert kind == "slip" and abs(t - t0 - first) < 1e-9


def test_no_step_of_a_slip_in_arc_time_covers_more_than_hmax():
    R, L, Mb, Jz, mu = 0.1, 0.03, 1.2, 0.008, 0.4
    scene = tbr._scene(f'mass = {Mb}\ninertia = [0.006, 0.006, {Jz}]\nshape = "cylinder"\n'
                       f'radius = {R}\nhalf_length = {L}', 'mass = 0.3\nlaw = ["0", "0", "0.01"]',
                       mu, 0.2)
    hmax = 1e-3
    raw = tbr.run_base(scene, [0, 0, 0, 0.3, 0, 3.0], hmax=hmax)
    (t_stop, kind), = tbr._events(raw)
    assert raw.status == "done" and kind == "stick"
    slip = raw.t[raw.t <= t_stop]
    assert len(slip) > 20 and np.diff(slip).max() <= hmax * (1 + 1e-12)
    before = raw.t[raw.kinds == abi.ROW_KIND["before_event"]]   # the stop's rows: one
    after = raw.t[raw.kinds == abi.ROW_KIND["after_event"]]     # before (at rho = eps),
    assert len(before) == 1 and 0 <= t_stop - before[0] < 1e-9  # one after at its time
    assert list(after) == [t_stop]


def _walk(pressure):
    Mb, mp, c = 1.0, 0.5, 0.2
    scene = tbr._scene(BOX, f'mass = {mp}\nlaw = ["{c}*t", "0", "0"]', 0.5, 2.0)
    raw = tbr.run_base(scene, np.zeros(6), pressure=pressure)
    reach = A_ if pressure == "uniform" else A_ / 3
    return raw, reach * (Mb + mp) / (mp * c)


def _runs():
    import test_base_closed_forms as cf
    law = (f'law = ["{cf.A}*(sin({cf.W}*t) + {cf.BETA}*sin({2 * cf.W}*t))", "0", '
           f'"{cf.Z0}"]')
    crawl = tbr._scene(BOX.replace("mass = 1.0", f"mass = {cf.M}"), f"mass = {cf.m}\n{law}",
                       cf.MU_K, 0.8)
    yield "done", tbr.run_base(crawl, np.zeros(6), mu_s=cf.MU_S), None
    back = tbr._scene(BOX.replace("mass = 1.0", f"mass = {cf.M}"), f"mass = {cf.m}\n{law}",
                      0.12, 0.6)
    yield "done", tbr.run_base(back, np.zeros(6), mu_s=0.13), None
    Mb, mp, a, W = 0.5, 0.5, 0.02, 40.0
    lift = tbr._scene(BOX.replace("mass = 1.0", f"mass = {Mb}"),
                      f'mass = {mp}\nlaw = ["0", "0", "{a}*sin({W}*t)"]', 0.3, 0.2)
    yield "lift_off", tbr.run_base(lift, np.zeros(6)), \
        math.asin((Mb + mp) * G / (mp * a * W * W)) / W
    for pressure, status in (("uniform", "tipping"), ("linear", "face_lifting")):
        raw, t_end = _walk(pressure)
        yield status, raw, t_end


def test_the_counts_are_the_runs_events_counted():
    counted = {"sticks": "stick", "slips": "slip", "reversals": "reversal",
               "lift_offs": "lift_off"}
    seen = set()
    for status, raw, t_end in _runs():
        kinds = [k for _, k in tbr._events(raw)]
        assert raw.status == status
        for stat, kind in counted.items():
            assert raw.stats[stat] == kinds.count(kind), (status, stat)
            seen.add(stat) if raw.stats[stat] else None
        before = raw.t[raw.kinds == abi.ROW_KIND["before_event"]]
        after = raw.t[raw.kinds == abi.ROW_KIND["after_event"]]
        changes = [(t, k) for t, k in tbr._events(raw) if k in ("stick", "slip", "reversal")]
        for t, kind in changes:                 # a row before each change, after a stick
            assert (before == t).sum() == 1, (status, kind)
            assert kind != "stick" or (after == t).sum() == 1, status
        assert len(after) == len(changes)       # (after a slip's start: where it starts)
        if t_end is not None:                   # the stop: its event last, at its time
            assert kinds[-1] == status          # (the event named as its status)
            assert abs(tbr._events(raw)[-1][0] - t_end) < 1e-9
    assert seen == set(counted)                 # (every count taken somewhere)


@pytest.mark.parametrize("dt, chunks", [(1e-3, (9, 12, 16)), (1e-4, (30,))])
def test_rows_in_small_buffers_are_one_buffers_on_the_grid(dt, chunks):
    """The capsule crawler, a period: its sticks and slips on a grid of 1e-3 s (a stick's
    sample, hmax/8, is 6.5 ms: seven rows).  In buffers of 9 to 16 rows a step is shrunk
    to the rows that fit (more step rows than one buffer's run has); the grid's rows are
    the same to 1e-9 (the run's rtol is 1e-10: 1.6e-12 measured).  On a grid of 1e-4 s in
    buffers of 30 rows a slip's step holding 23 rows or more is shrunk by 22/23 or less,
    within 5 % of 1.  (Buffers of CRT_MIN_ROWS = 8, where an empty buffer holds a step's
    own rows and one grid row: tests/test_base_flow_boundaries.py.)"""
    import tomllib
    from derive.paths import ROOT
    from derive.runtime.driver import prepare, run_prepared, simulate
    from derive.runtime.session import Session
    doc = tomllib.loads((ROOT / "derive/scene/examples/capsule-crawler.toml").read_text())
    doc["run"].update(duration=2 * math.pi / 12, output_dt=dt)
    one = simulate(doc, progress=False)
    kinds = [e["kind"] for e in one.events]
    assert one.status == "done" and one.model == "base" and "stick" in kinds
    grid = np.arange(1, int(doc["run"]["duration"] / dt) + 1) * dt  # (each row once)

    def on_grid(run):
        step = np.flatnonzero(run.row_kind == abi.ROW_KIND["step"])
        at = step[np.isin(run.t[step], grid)]
        assert np.array_equal(run.t[at], grid)
        return run.model_q[at]
    q = on_grid(one)
    prep = prepare(doc)
    for chunk in chunks:
        run = run_prepared(prep, session=Session(prep.library, chunk=chunk))
        assert run.status == "done" and [e["kind"] for e in run.events] == kinds
        assert np.abs(on_grid(run) - q).max() < 1e-9


def _fault(dev=0.0, mu_s=0.3, pressure=0.0):
    """crt_init's verdict on the box with its vertical ``dev`` off e_z (1 - n_z / |n|):
    the parameter it names, None when it is taken."""
    e = math.sqrt((1.0 / (1.0 - dev)) ** 2 - 1.0)
    assert abs(1.0 - 1.0 / math.sqrt(1.0 + e * e) - dev) <= 1e-6 * dev
    scene = _box(0.3)
    prm = tbr.choice.parameters(scene, {})
    prm[tbr._P["n0_x"]], prm[tbr._P["n0_y"]], prm[tbr._P["n0_z"]] = e, 0.0, 1.0
    prm[tbr._P["static_friction"]], prm[tbr._P["pressure"]] = mu_s, pressure
    session = tbr.Session(tbr.library("base"))
    session.set_law(scene.runtime_law)
    opt = np.ones(len(abi.OPTIONS))
    opt[tbr._O["method"]] = 1
    status = session.init_status(opt, prm, 0.0, np.zeros(6))
    if status == abi.STATUS["ok"]:
        return None
    assert status == abi.STATUS["bad_parameters"]
    return {k: n for n, k in abi.PRM.items()}[session.library.lib.crt_bad_parameter(session.handle)]


def test_the_body_is_taken_just_inside_its_rules_and_refused_just_past_them():
    assert _fault(0.97e-9) is None and _fault(1.03e-9) == "n0_x"
    assert _fault(mu_s=0.3 * 0.98) == "static_friction" and _fault(mu_s=0.3 * 1.02) is None
    assert _fault(pressure=2.0) == "pressure" and _fault(pressure=1.0) is None
    assert _fault(1.03e-9, 0.3 * 0.98) == "n0_x" and _fault(1.03e-9, pressure=2.0) == "n0_x"


@pytest.mark.parametrize("phase", [0.0, 0.004])
def test_the_grid_starts_after_a_late_start_and_at_its_origin(phase):
    """The capsule crawler from [initial].time = 1 s on a grid of 10 ms: the start's row
    once, then the grid's rows t0 + k dt (k >= 1, none at t0 again); on a grid carried
    over from another run (a hand-over's: its origin 4 ms after t0) the first grid row is
    the origin itself, then origin + k dt."""
    import tomllib
    from derive.paths import ROOT
    from derive.runtime.driver import prepare, run_prepared
    doc = tomllib.loads((ROOT / "derive/scene/examples/capsule-crawler.toml").read_text())
    t0, dt = 1.0, 0.01
    doc["initial"]["time"] = t0
    doc["run"].update(duration=0.03, output_dt=dt)
    prep = prepare(doc, output_origin=t0 + phase - 7 * dt if phase else None)
    run = run_prepared(prep)
    assert run.status == "done" and run.model == "base"
    step = run.t[run.row_kind == abi.ROW_KIND["step"]]
    origin = t0 + phase if phase else t0 + dt
    grid = origin + dt * np.arange(0, 4)
    grid = grid[grid <= t0 + 0.03 + 1e-12]
    assert np.sum(step == t0) == 1 and step[0] == t0
    on = [s for s in step if np.min(np.abs(grid - s)) < 1e-12]
    assert len(on) == len(grid) and np.allclose(on, grid, rtol=0.0, atol=1e-12)
    assert np.all(step[step < grid[0] - 1e-12] == t0)  # no grid row before the first


def test_max_steps_stops_the_base_model_after_exactly_that_many_steps():
    """The crawl of _runs() (sticks and slips) with max_steps = 40, far fewer than it
    takes: status max_steps with exactly 40 steps counted, its rows and events those of
    the run without the limit up to there, bit for bit (the limit's rule against the
    steps counted apart; 5 % either way stops a step early or late)."""
    import test_base_closed_forms as cf
    law = (f'law = ["{cf.A}*(sin({cf.W}*t) + {cf.BETA}*sin({2 * cf.W}*t))", "0", '
           f'"{cf.Z0}"]')
    crawl = tbr._scene(BOX.replace("mass = 1.0", f"mass = {cf.M}"), f"mass = {cf.m}\n{law}",
                       cf.MU_K, 0.8)
    full = tbr.run_base(crawl, np.zeros(6), mu_s=cf.MU_S)
    cut = tbr.run_base(crawl, np.zeros(6), mu_s=cf.MU_S, max_steps=40)
    assert full.status == "done" and full.stats["steps"] > 100
    assert cut.status == "max_steps" and cut.stats["steps"] == 40
    n, ne = len(cut.t), len(cut.events)
    assert n > 20 and ne >= 1 and cut.t[-1] < full.t[-1]
    assert np.array_equal(cut.t, full.t[:n]) and np.array_equal(cut.q, full.q[:n])
    assert np.array_equal(cut.events, full.events[:ne])


@pytest.mark.parametrize("t0", [1.0, -1.0])
def test_a_rests_samples_ending_on_the_grid_write_its_rows_once(t0):
    """The box at rest from t0 = 1 s or -1 s with hmax = 1/16 s: each stick sample (hmax/8
    = 1/128 s, the gauge constant) ends exactly on a grid time t0 + k/128 s of output_dt =
    1/128 s (binary fractions: no round-off), where the grid's row is the step's own
    (crt_base_step_row, the grid's last time against the step's end); the run ends half a
    sample past the last, off the grid.  The rows are the grid t0 + k/128, k = 0..32,
    each once, then the end, at rest (a row at a grid time lost, or written twice, or
    the end's lost, is seen)."""
    dt = 1.0 / 128.0
    raw = tbr.run_base(_box(0.3, 32.5 * dt, t0=t0), np.zeros(6), hmax=8 * dt, output_dt=dt)
    assert raw.status == "done" and tbr._events(raw) == []
    assert np.all(raw.kinds == abi.ROW_KIND["step"]) and np.all(raw.q == 0.0)
    assert np.array_equal(raw.t, t0 + dt * np.append(np.arange(33), 32.5))
    assert raw.stats["steps"] == 33
