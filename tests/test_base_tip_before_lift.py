"""A lift-off the face cannot make: where the moment the face must give does not vanish with
N, the centre of pressure runs off the face before N reaches 0, and the base model must stop
with ``tipping`` there, not hand a lift-off to the flight (derive/runtime/handover.py).

* a cylinder on its end, spinning, its internal mass moving sideways as N falls to 0 (scene
  43 of tests/test_handover.py's random lift-offs): a point moving at rho'_h in a body
  spinning at w needs a horizontal moment of about 2 mu w z rho'_h at N = 0, so cp = moment /
  N leaves the face some 0.2 ms before.  The runtime once missed it (its step ended past the
  lift-off, where cp = moment / N had come back into the face: the margin positive at both
  ends) and handed the flight a state whose rim went below the plane at once (step_underflow
  in the flight).  Against the Newton–Euler reference integrator (derive/base_reference.py,
  SciPy's DOP853 on the carrier and the point, without the moments): the same tipping time
  and state; and cp far off the face just before N = 0;
* a box sticking at rest, its point off the axis by c, pushed up and down: cp = c m (z'' + g)
  / N reaches the edge -a where sin(W t) = g (a (M + m) + c m) / (m (a + c) A W^2), before N
  = 0 at sin(W t) = (M + m) g / (m A W^2): the closed forms; with c = 0.002 the tip comes
  0.19 ms (1.4 % of t) before N = 0, both in one stick sample: the earlier of the two
  events is the one taken.
"""
import math

import numpy as np
import pytest

from derive import base_reference as br
from derive.runtime.choice import base_face
from derive.runtime.driver import simulate
from derive.scene import parse_scene

g = 9.81

SPIN = """
name = "r43"
[body]
mass = 1.973829851082122
inertia = [0.01, 0.02, 0.025]
shape = "cylinder"
radius = 0.09031780799116759
half_length = 0.030285985440940785
[[point]]
mass = 0.720913612317378
law = ["{a1}*sin(25*(t - {tl}))", "{a2}*sin(30*(t - {tl}))", "{a3}*sin({W}*t)"]
[plane]
friction = 0.8393480097763826
restitution = 0.3
[initial]
on_plane = true
carrier_velocity = [0.16902549844307052, -0.13472851054804882, 0.0]
omega = [0.0, 0.0, -2.5838348892447565]
[run]
duration = 0.25
"""
A1, A2, A3, W3 = 0.006054344526118645, 0.0020318056417170005, 0.11666645242922603, \
    24.048731159837857
T_L = 0.023891545403996555          # N = 0 there: sin(W t) = (M + m) g / (m A W^2)


def _law(t):
    u = t - T_L
    return (np.array([A1 * math.sin(25 * u), A2 * math.sin(30 * u), A3 * math.sin(W3 * t)]),
            np.array([25 * A1 * math.cos(25 * u), 30 * A2 * math.cos(30 * u),
                      W3 * A3 * math.cos(W3 * t)]),
            np.array([-625 * A1 * math.sin(25 * u), -900 * A2 * math.sin(30 * u),
                      -W3 * W3 * A3 * math.sin(W3 * t)]))


def test_a_spinning_cylinder_tips_before_its_n_reaches_0():
    scene = parse_scene(SPIN.format(a1=A1, a2=A2, a3=A3, W=W3, tl=T_L))
    run = simulate(scene)
    assert run.status == "tipping" and run.handover is None and run.model == "base"
    t_tip = float(run.t[-1])
    assert 1e-4 < T_L - t_tip < 5e-4
    # the reference, from the same start
    system = br.System(M=scene.M, J=scene.J, face=base_face(scene),
                       points=(br.Point(scene.m, _law),), mu=scene.friction)
    ref = br.Integrator(system).run(run.model_q[0], 0.0, scene.duration)
    assert ref.status == "tipping" and len(ref.events) == 1
    assert abs(ref.events[0][0] - t_tip) < 1e-12
    assert np.max(np.abs(ref.states[0] - run.model_q[-1])) < 1e-10
    # there N > 0 and cp on the rim; just before N = 0, cp far outside (the moment at N = 0
    # is not 0: no lift-off with cp in the face)
    integ = br.Integrator(system)
    _, at = integ.rates(t_tip, run.model_q[-1])
    R = scene.size[0]
    assert at.N > 1e-3 * (scene.M + scene.m) * g and abs(math.hypot(*at.cp) - R) < 1e-9 * R
    _, late = integ.rates(T_L - 1e-6, run.model_q[-1])
    assert 0.0 < late.N < 1e-4 * (scene.M + scene.m) * g and math.hypot(*late.cp) > 10 * R


STICK = """
name = "stick"
[body]
mass = {M}
inertia = [0.01, 0.02, 0.025]
shape = "box"
half_extents = [{a}, 0.06, 0.04]
[[point]]
mass = {m}
law = ["{c}", "0", "{A}*sin({W}*t)"]
[plane]
friction = 0.5
[initial]
on_plane = true
carrier_velocity = [0.0, 0.0, 0.0]
[run]
duration = 0.2
"""


@pytest.mark.parametrize("c", [0.02, 0.002])
def test_a_box_at_rest_tips_where_the_closed_form_says(c):
    M, m, a, W = 1.0, 0.5, 0.1, 40.0
    A = (M + m) * g / (0.5 * m * W * W)          # N = 0 at sin(W t) = 1/2
    run = simulate(parse_scene(STICK.format(M=M, m=m, a=a, c=c, A=A, W=W)))
    t_tip = math.asin(g * (a * (M + m) + c * m) / (m * (a + c) * A * W * W)) / W
    t_l = math.asin((M + m) * g / (m * A * W * W)) / W
    assert t_tip < t_l - 1e-4
    assert run.status == "tipping" and run.handover is None
    assert abs(run.t[-1] - t_tip) < 1e-12
