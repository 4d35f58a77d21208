"""The base model's rules at their edges (crt_base.h, crt_base_flow.h, crt_base_model.h,
crt_face.h): scenes that fall within a few per cent of a threshold on either side, so that
a rule moved by 2 % (derive verify mutants' 1.05 factors, a flipped comparison) changes an
asserted outcome; each outcome against a closed form or the rule's own arithmetic done
apart in Python.

* A start sliding at 0.98 and 1.02 of the slip's end (eps = 1e-11 sqrt(g ell)): below it
  the twist is the start's round-off, taken as rest (no event, O does not move); above it
  the slip runs to its stop at the closed form's v0 / (mu g) (one stick event).
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
