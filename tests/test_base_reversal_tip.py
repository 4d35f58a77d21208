"""No tip at a reversal the rest cannot hold (issue 33's trial): at a slip's stop the body
rests only if the rest holds; else it slips off at once (a reversal), and the centre of
pressure that can reach the face's edge is that slip's, not the rest's.  The runtime had
tested the rest's first (crt_base.h, crt_base_settle) and stopped `tipping` (under linear
pressure `face_lifting`) where the body reverses and runs on.

* the trial's box (tip-repro.toml: 15 x 8 x 6 cm, its point 5 cm above O on 0.03 sin 40t,
  mu 0.25, mu_s 0.3): against the 1-D closed form, the first stop at 0.120637 s needs
  |m x''| = 14.3 N of friction to rest, past mu_s N = 3.24 N, so it reverses; the rest's
  cp is -0.1142 m, off the 0.075 m half-length, the slip's -0.0454 m before and -0.0673 m
  after, inside.  The runtime runs to the end, every slip and reversal at the reference
  integrator's time (derive/base_reference.py) to 1e-9 s;
* the same box under linear pressure, its point at O's height: the reference's events too;
* a real tip at a reversal: O sliding at v0 against a point pushed at a constant k, with
  m k = 1.3 mu N: at the stop the rest cannot hold, and the reversed slip's cp (closed
  form) is off the face while the first slip's is inside: `tipping` at the stop's closed
  form time v0 (M + m)/(m k + mu N), as the reference has it (its events find crossings,
  so it now tests a slip's and a stick's margins where they start);
* Bardin and Panev's cell mu 0.8, beta 0.95 (the mode map's `tipping`):
  tests/test_capsule_modes.py.
"""
import math

import numpy as np

from derive import base_reference as br
from derive.runtime.driver import simulate
from derive.scene import parse_scene
from derive.verify.judges import face_system, judge_face_run

g = 9.81

SCENE = """
name = "reversal"
[body]
mass = 0.8
inertia = [0.000667, 0.001740, 0.001927]
shape = "box"
half_extents = [{a}, 0.04, 0.03]
[[point]]
mass = 0.3
law = [{law}]
[plane]
friction = {mu}
static_friction = {mu_s}
pressure = "{pressure}"
[initial]
on_plane = true
carrier_velocity = [{v0}, 0.0, 0.0]
[run]
duration = {T}
"""


def _scene(a=0.075, law='"0.03*sin(40*t)", "0", "0.05"', mu=0.25, mu_s=0.3,
           pressure="uniform", v0=0.0, T=0.3):
    return parse_scene(SCENE.format(a=a, law=law, mu=mu, mu_s=mu_s, pressure=pressure,
                                    v0=v0, T=T))


def _events(events, kinds=("slip", "stick", "reversal")):
    return [(float(e["t"]), e["kind"]) for e in events if e["kind"] in kinds]


def _against_the_reference(scene):
    """The runtime's run, and its slips, sticks and reversals against the reference's."""
    run = simulate(scene)
    ref = br.Integrator(face_system(scene)).run(run.model_q[0], scene.t0,
                                                scene.t0 + scene.duration)
    ours, theirs = _events(run.events), _events([{"t": t, "kind": k} for t, k in ref.events])
    assert ref.status == "done" and [k for _, k in ours] == [k for _, k in theirs]
    assert max(abs(a - b) for (a, _), (b, _) in zip(ours, theirs)) < 1e-9
    return run, ours


def test_the_trials_box_reverses_and_runs_on():
    M, m, A, W, mu, mu_s = 0.8, 0.3, 0.03, 40.0, 0.25, 0.3
    N = (M + m) * g

    # the 1-D closed form: the rest breaks at ts, the slip of sign s stops at tr
    ts = math.asin(mu_s * N / (m * A * W * W)) / W
    s = 1.0                                   # -m x'' > 0 just after ts: pushed forward
    v = lambda t: (m * A * W * (math.cos(W * ts) - math.cos(W * t))  # noqa: E731
                   - mu * N * s * (t - ts)) / (M + m)
    from scipy.optimize import brentq
    tr = brentq(v, 0.1, 0.13, xtol=1e-15)

    def cp(t, sign):                          # O at 0.03, P at 0.08 above the plane
        a = (m * A * W * W * math.sin(W * t) - mu * N * sign) / (M + m)
        return (m * g * A * math.sin(W * t) - 0.03 * M * a
                - 0.08 * m * (a - A * W * W * math.sin(W * t))) / N
    rest = (m * g * A * math.sin(W * tr) + 0.08 * m * A * W * W * math.sin(W * tr)) / N
    assert m * A * W * W * abs(math.sin(W * tr)) > 4 * mu_s * N      # 14.3 N against 3.24 N
    assert rest < -0.114 and -0.046 < cp(tr, 1.0) < -0.045 and -0.068 < cp(tr, -1.0) < -0.067

    run, ours = _against_the_reference(_scene())
    assert run.status == "done" and run.model == "base"
    assert [k for _, k in ours] == ["slip", "reversal", "reversal", "reversal"]
    assert abs(ours[0][0] - ts) < 1e-9 and abs(ours[1][0] - tr) < 1e-9
    assert judge_face_run(run)[0] == "ok"


def test_the_trials_box_under_linear_pressure_reverses_too():
    run, ours = _against_the_reference(_scene(law='"0.03*sin(40*t)", "0", "0"',
                                              pressure="linear"))
    assert run.status == "done"
    assert [k for _, k in ours] == ["slip", "reversal", "reversal", "reversal"]


def test_a_reversal_whose_own_slip_is_off_the_face_tips():
    M, m, mu, a, v0 = 0.8, 0.3, 0.5, 0.03, 0.2
    N = (M + m) * g
    k = 1.3 * mu * N / m                      # the rest at the stop needs m k > mu N
    x0 = -0.002
    a1, a2 = -(m * k + mu * N) / (M + m), -(m * k - mu * N) / (M + m)
    T = v0 / -a1                              # the first slip's stop

    def cp(t, acc):                           # O at 0.03, P at 0.08 above the plane
        return (m * g * (x0 + k * t * t / 2) - 0.03 * M * acc - 0.08 * m * (acc + k)) / N
    assert max(abs(cp(t, a1)) for t in np.linspace(0.0, T, 50)) < 0.1 * a
    assert cp(T, a2) < -1.4 * a               # the reversed slip's: off the face

    scene = _scene(a=a, law=f'"{x0} + {k / 2!r}*t^2", "0", "0.05"', mu=mu, mu_s=mu, v0=v0,
                   T=0.05)
    run = simulate(scene)
    assert run.status == "tipping"
    assert abs(run.t[-1] - T) < 1e-9
    assert judge_face_run(run)[0] == "ok"
    ref = br.Integrator(face_system(scene)).run(run.model_q[0], 0.0, scene.duration)
    assert ref.status == "tipping" and [k for _, k in ref.events] == ["reversal", "tipping"]
    assert abs(ref.events[-1][0] - run.t[-1]) < 1e-9


def test_a_stop_whose_rest_holds_off_the_face_tips_once_in_the_tables():
    """The body slides to a stop where the rest holds (m k < mu N) but the rest's centre
    of pressure is past the edge (0.08 m k / N > a): `tipping` at the stop's closed-form
    time, v0 (M + m) / (m k + mu N), as the reference says; and the tables show the stop
    once: the stop's row is the tipping's (the stop had written a row of its own before
    crt_base_end wrote another, which events.csv listed as a second, nameless `event`)."""
    from derive.runtime.outputs import event_table, trajectory_table
    M, m, mu, a, v0, x0 = 0.8, 0.3, 0.5, 0.03, 0.2, -0.002
    N = (M + m) * g
    k = 0.45 * N / m                          # the rest needs m k = 0.45 N < mu N: it holds
    T = v0 * (M + m) / (m * k + mu * N)
    assert (m * g * (x0 + k * T * T / 2) - 0.08 * m * k) / N < -a   # the rest's cp: off
    scene = _scene(a=a, law=f'"{x0} + {k / 2!r}*t^2", "0", "0.05"', mu=mu, mu_s=mu, v0=v0,
                   T=0.05)
    run = simulate(scene)
    assert run.status == "tipping" and [e["kind"] for e in run.events] == ["tipping"]
    assert abs(run.t[-1] - T) < 1e-9
    ref = br.Integrator(face_system(scene)).run(run.model_q[0], 0.0, scene.duration)
    assert ref.status == "tipping" and abs(ref.events[-1][0] - run.t[-1]) < 1e-9
    header, table = trajectory_table(run)
    _, text = event_table(run, header, table)
    assert text["event"] == ["tipping", "tipping"]
