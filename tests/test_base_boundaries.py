"""The base model's rules at their edges (crt_base.h, crt_base_flow.h, crt_base_model.h,
crt_face.h): scenes that fall within a few per cent of a threshold on either side, so that
a rule moved by 2 % (derive verify mutants' 1.05 factors, a flipped comparison) changes an
asserted outcome; each outcome against a closed form or the rule's own arithmetic done
apart in Python.

* A start sliding at 0.98 and 1.02 of the slip's end (eps = 1e-11 sqrt(g ell)): below it
  the twist is the start's round-off, taken as rest (no event, O does not move); above it
  the slip runs to its stop at the closed form's v0 / (mu g) (one stick event).
* The run's counts (sticks, slips, reversals, lift-offs) are its events counted apart, in
  runs that end in each way: the crawl and the reversals of tests/test_base_runtime.py, a
  lift-off, a tip and the face lifting (a point walking out at c: the edge at a (M + m) /
  (m c), the kern at a third of it).
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


def _box(mu=0.3, duration=0.05, law='["0", "0", "0"]'):
    return tbr._scene(BOX, f"mass = 0.2\nlaw = {law}", mu, duration)


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
               "liftoffs": "liftoff"}
    seen = set()
    for status, raw, t_end in _runs():
        kinds = [k for _, k in tbr._events(raw)]
        assert raw.status == status
        for stat, kind in counted.items():
            assert raw.stats[stat] == kinds.count(kind), (status, stat)
            seen.add(stat) if raw.stats[stat] else None
        if t_end is not None:                   # the stop: its event last, at its time
            assert kinds[-1] == {"lift_off": "liftoff"}.get(status, status)
            assert abs(tbr._events(raw)[-1][0] - t_end) < 1e-9
    assert seen == set(counted)                 # (every count taken somewhere)
