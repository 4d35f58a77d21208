"""crt_base_flow.h's rules at their edges (issue 36: its mutants), each against a closed
form or the rule's own arithmetic done apart in Python.

* N's resolution, crt_base_n_res = 1e-9 (M + m) g: a root of the edge's margin located
  where N is at or below it is N's (crt_base_tie), above it a tip.  A box at rest, its
  point on the axis but c off it and pushed up and down (tests/test_base_tip_before_lift.py's
  closed forms): cp reaches the edge -a where N = g c M / (a + c), here 0.98 and 1.02 of
  N's resolution.  Below it the run goes on to the lift-off at N = 0 (the closed form's
  time); above it the run tips at the closed form's time to 1e-13 s (N falls at 1e3 N/s
  there: 5 % of the resolution is 7e-13 s) with the margin ~0 at the event (not the -a a
  margin cut off by N reads).
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
