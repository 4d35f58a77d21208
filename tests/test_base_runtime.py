"""The base model's C runtime (model_base.c: crt_base_model.h, crt_base.h, crt_face.h)
against the closed forms of tests/test_base_closed_forms.py and against the reference
integrator written apart (derive/base_reference.py), on scenes read as a user writes them
(a box or a cylinder on its face, [[point]] laws), run by the compiled library alone.

* 1-D stick-slip of a box (x = A (sin W t + 0.4 sin 2 W t), mu_s = 0.35 > mu = 0.3):
  every event's kind and time to 1e-9, X at each stop to 1e-9 (0.478 mm net a period);
* the same box at mu_s = 0.13, mu = 0.12, which slides back at once where it stops:
  every event and X there to 1e-9;
* a disc spinning down: the stop at J w0/((2/3) mu N R) to 1e-9, having turned w0 t*/2;
* lift-off: a point thrown upward so that N = (M + m) g + m z'' reaches 0 at the
  closed-form time;
* random bodies (two points, a tilted rotor) on a face under a vertical other than +z:
  events and the final state against the reference integrator to 1e-8 (the reference
  costs ~15 s of CPU a case: marked slow).
"""
import math

import numpy as np
import pytest

from derive import abi
from derive.runtime import choice
from derive.runtime.build import library
from derive.runtime.driver import simulate
from derive.runtime.session import Session
from derive.scene.parse import parse_scene

import test_base_closed_forms as cf

G = 9.81
_P, _O = abi.PRM, {o.name: k for k, o in enumerate(abi.OPTIONS)}


def _scene(body: str, point: str, mu: float, duration: float, t0: float = 0.0):
    return parse_scene(f"""
[body]
{body}
[[point]]
{point}
[plane]
friction = {mu}
restitution = 0.0
[initial]
on_plane = true
time = {t0!r}
[run]
duration = {duration}
""")


def run_base(scene, q0, mu_s=None, hmax=None, pressure="uniform", output_dt=0.0,
             **options):
    """The base model's run of a scene on its face (n = e_z of the body): its raw result
    (``options``: runtime options by name over the defaults here)."""
    prm = choice.parameters(scene, {})
    prm[_P["n0_z"]] = 1.0
    prm[_P["static_friction"]] = scene.friction if mu_s is None else mu_s
    prm[_P["pressure"]] = abi.names(abi.PRESSURES).index(pressure)
    opt = np.zeros(len(abi.OPTIONS))
    opt[_O["method"]] = 1
    opt[_O["rtol"]], opt[_O["atol"]] = 1e-12, 1e-14
    opt[_O["hmax"]] = hmax or scene.duration / 64
    opt[_O["rk4_step"]] = 1e-3
    opt[_O["time_scale"]] = scene.duration
    opt[_O["event_tol"]] = 1e-15
    opt[_O["output_dt"]] = output_dt
    opt[_O["max_steps"]], opt[_O["max_events"]] = 1e6, 1e4
    for name, value in options.items():
        opt[_O[name]] = value
    session = Session(library("base"))
    session.set_law(scene.runtime_law)
    return session.run(scene.t0, scene.duration, np.asarray(q0, dtype=float), opt, prm)


def _events(raw):
    kinds = abi.names(abi.EVENT_KINDS)
    return [(row[0], kinds[int(row[1])]) for row in raw.events]


def test_a_box_crawls_by_stick_and_slip_as_the_closed_form_says():
    law = (f'law = ["{cf.A}*(sin({cf.W}*t) + {cf.BETA}*sin({2 * cf.W}*t))", "0", '
           f'"{cf.Z0}"]')
    scene = _scene(f'mass = {cf.M}\ninertia = [0.01, 0.02, 0.025]\nshape = "box"\n'
                   'half_extents = [0.1, 0.06, 0.04]', f"mass = {cf.m}\n{law}", cf.MU_K, 1.6)
    raw = run_base(scene, np.zeros(6), mu_s=cf.MU_S)
    closed = cf.closed_form_1d(1.6)
    got = _events(raw)
    assert raw.status == "done"
    assert [k for _, k in got] == [e[1] for e in closed]
    assert np.abs(np.array([t for t, _ in got]) - [e[0] for e in closed]).max() < 1e-9
    # X at each stop: the row after the event (a stick) or before the next slip's start
    after = raw.kinds == abi.ROW_KIND["after_event"]
    before = raw.kinds == abi.ROW_KIND["before_event"]
    stops = [e for e in closed if len(e) == 3]
    X = []
    for t, kind, _ in stops:
        rows = np.flatnonzero((before | after) & (np.abs(raw.t - t) < 1e-12))
        X.append(raw.q[rows[-1 if kind == "stick" else 0], 0])
    assert np.abs(np.array(X) - [e[2] for e in stops]).max() < 1e-9
    sticks = np.array([x for x, e in zip(X, stops) if e[1] == "stick"])
    assert abs((sticks[2:] - sticks[:-2])[0] - 4.7774e-4) < 1e-7


def test_on_low_friction_the_box_reverses_as_the_closed_form_says(monkeypatch):
    """mu_s = 0.13 > mu = 0.12: the slip stops where the rest would need more than mu_s N,
    and slides back at once (a reversal: the stop along a line, then a slip the other
    way).  (At mu_s = mu the closed form's slip starts with zero acceleration and its
    root finder takes the start for a stop.)"""
    monkeypatch.setattr(cf, "MU_S", 0.13)
    monkeypatch.setattr(cf, "MU_K", 0.12)
    law = (f'law = ["{cf.A}*(sin({cf.W}*t) + {cf.BETA}*sin({2 * cf.W}*t))", "0", '
           f'"{cf.Z0}"]')
    scene = _scene(f'mass = {cf.M}\ninertia = [0.01, 0.02, 0.025]\nshape = "box"\n'
                   'half_extents = [0.1, 0.06, 0.04]', f"mass = {cf.m}\n{law}", 0.12, 1.2)
    raw = run_base(scene, np.zeros(6), mu_s=0.13)
    closed = cf.closed_form_1d(1.2)
    got = _events(raw)
    kinds = [e[1] for e in closed]
    assert raw.status == "done" and kinds.count("reversal") >= 3
    assert [k for _, k in got] == kinds
    assert np.abs(np.array([t for t, _ in got]) - [e[0] for e in closed]).max() < 1e-9
    stops = [e for e in closed if len(e) == 3]
    X = [raw.q[np.flatnonzero(np.abs(raw.t - t) < 1e-12)[0], 0] for t, _, _ in stops]
    assert np.abs(np.array(X) - [e[2] for e in stops]).max() < 1e-9


def test_a_disc_spins_down_and_stops_when_the_closed_form_says():
    R, L, Mb, mp, Jz, mu, w0 = 0.1, 0.03, 1.2, 0.3, 0.008, 0.4, 6.0
    N = (Mb + mp) * G
    t_star = Jz * w0 / (2 / 3 * mu * N * R)
    scene = _scene(f'mass = {Mb}\ninertia = [0.006, 0.006, {Jz}]\nshape = "cylinder"\n'
                   f'radius = {R}\nhalf_length = {L}', f'mass = {mp}\nlaw = ["0", "0", "0.01"]',
                   mu, 2 * t_star)
    raw = run_base(scene, [0, 0, 0, 0, 0, w0])
    got = _events(raw)
    assert raw.status == "done" and [k for _, k in got] == ["stick"]
    assert abs(got[0][0] - t_star) < 1e-9 * t_star
    assert abs(raw.q[-1, 2] - w0 * t_star / 2) < 1e-9
    assert np.abs(raw.q[-1, [0, 1, 3, 4, 5]]).max() < 1e-12


def test_lift_off_comes_at_its_closed_form_time():
    # z = Z0 + a sin(W t): N = (M + m) g - m a W^2 sin(W t) reaches 0 at asin(...)/W
    Mb, mp, a, W = 0.5, 0.5, 0.02, 40.0
    t_lift = math.asin((Mb + mp) * G / (mp * a * W * W)) / W
    scene = _scene(f'mass = {Mb}\ninertia = [0.01, 0.02, 0.025]\nshape = "box"\n'
                   'half_extents = [0.1, 0.06, 0.04]',
                   f'mass = {mp}\nlaw = ["0", "0", "{a}*sin({W}*t)"]', 0.3, 0.2)
    raw = run_base(scene, np.zeros(6))
    assert raw.status == "lift_off"
    assert abs(_events(raw)[-1][0] - t_lift) < 1e-9
    assert _events(raw)[-1][1] == raw.status            # (one name: the stop and its event)


@pytest.mark.parametrize("which", ["n0_x", "static_friction"])
def test_a_body_not_on_a_face_or_mu_s_below_mu_is_refused(which):
    scene = _scene('mass = 1\ninertia = [0.01, 0.02, 0.025]\nshape = "box"\n'
                   'half_extents = [0.1, 0.06, 0.04]', 'mass = 0.1\nlaw = ["0", "0", "0"]',
                   0.3, 0.1)
    prm = choice.parameters(scene, {})
    prm[_P["n0_x"]], prm[_P["n0_z"]] = (0.3, 1.0) if which == "n0_x" else (0.0, 1.0)
    prm[_P["static_friction"]] = 0.1 if which == "static_friction" else 0.3
    session = Session(library("base"))
    session.set_law(scene.runtime_law)
    opt = np.ones(len(abi.OPTIONS))
    opt[_O["method"]] = 1
    assert session.init_status(opt, prm, 0.0, np.zeros(6)) == abi.STATUS["bad_parameters"]
    assert session.library.lib.crt_bad_parameter(session.handle) == _P[which]


@pytest.mark.slow
@pytest.mark.parametrize("seed, shape, n, pressure, duration", [
    (1, "box", (0.0, -1.0, 0.0), "uniform", 0.25),
    (2, "cylinder", (0.0, 0.0, -1.0), "uniform", 0.25)])
def test_random_bodies_as_the_reference_integrator_runs_them(seed, shape, n, pressure,
                                                            duration):
    """Two points on harmonic laws and a tilted rotor, the face under a vertical other than
    +z (the moments turned into the face frame): the C's events and final state against
    derive/base_reference.py (Newton-Euler of every body, adaptive quadrature), 1e-8.
    (Under linear pressure the reference iterates its centre at every evaluation, minutes
    a run: tests/test_base_edges.py holds the C's slip rates to it instead.)"""
    from derive import base_reference as br
    from derive import face as fc
    import base_cases as bc
    rng = np.random.default_rng(seed)
    size = (0.1, 0.06, 0.04) if shape == "box" else (0.08, 0.03)
    center = (0.005, -0.004, 0.003)
    J = tuple(float(x) for x in rng.uniform(0.01, 0.03, 3))
    face = fc.face_on(shape, size, center, n)
    Q = face.frame
    points, lines = [], []
    for _ in range(2):
        mass = float(rng.uniform(0.1, 0.3))
        A, W, P = rng.uniform(-0.03, 0.03, 3), rng.uniform(2, 8, 3), rng.uniform(0, 6, 3)
        law = [f"{a:.17g}*sin({w:.17g}*t + {p:.17g})" for a, w, p in zip(A, W, P)]
        lines.append(f'[[point]]\nmass = {mass!r}\nlaw = {law!r}'.replace("'", '"'))
        body_law = bc.harmonic(A, W, P)
        points.append(br.Point(mass, lambda t, f=body_law: tuple(Q @ x for x in f(t))))
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    amp, rate, inertia = float(rng.uniform(5, 15)), float(rng.uniform(2, 5)), 0.004
    lines.append(f'[[rotor]]\naxis = {[float(x) for x in axis]!r}\ninertia = {inertia}\n'
                 f'law = "{-amp / rate!r}*cos({rate!r}*t)"')
    sizes = ("half_extents = " + repr(list(size)) if shape == "box"
             else f"radius = {size[0]}\nhalf_length = {size[1]}")
    body = (f'mass = 1.0\ninertia = {list(J)!r}\nshape = "{shape}"\n{sizes}\n'
            f'center = {list(center)!r}')
    scene = parse_scene(f"[body]\n{body}\n" + "\n".join(lines) + """
[plane]
friction = 0.4
restitution = 0.0
[initial]
on_plane = true
[run]
duration = {duration}
""".format(duration=duration))
    q0 = np.array([0.01, -0.02, 0.3, 0.15, -0.1, 1.5])
    prm = choice.parameters(scene, {})
    prm[_P["pressure"]] = abi.names(abi.PRESSURES).index(pressure)
    raw = _run_prm(scene, q0, prm, n)
    system = br.System(M=1.0, J=tuple(np.diag(Q @ np.diag(J) @ Q.T)), face=face,
                       points=tuple(points),
                       rotors=(br.Rotor(inertia, tuple(Q @ axis), bc.spinning(amp, rate)),),
                       mu=0.4, pressure=pressure)
    ref = br.Integrator(system).run(q0, 0.0, duration)
    got = _events(raw)
    assert raw.status == ref.status == "done"
    want = [("stick" if k == "stick" else k, t) for t, k in ref.events]
    assert [k for _, k in got] == [k for k, _ in want] and len(got) >= 1
    assert np.abs(np.array([t for t, _ in got]) - [t for _, t in want]).max() < 1e-8
    assert np.abs(raw.q[-1] - ref.samples[-1][1:]).max() < 1e-8


def _run_prm(scene, q0, prm, n):
    prm[_P["n0_x"]], prm[_P["n0_y"]], prm[_P["n0_z"]] = n
    prm[_P["static_friction"]] = scene.friction
    opt = np.zeros(len(abi.OPTIONS))
    opt[_O["method"]] = 1
    opt[_O["rtol"]], opt[_O["atol"]] = 1e-12, 1e-14
    opt[_O["hmax"]] = scene.duration / 64
    opt[_O["rk4_step"]] = 1e-3
    opt[_O["time_scale"]] = scene.duration
    opt[_O["event_tol"]] = 1e-15
    opt[_O["max_steps"]], opt[_O["max_events"]] = 1e6, 1e4
    session = Session(library("base"))
    session.set_law(scene.runtime_law)
    return session.run(scene.t0, scene.duration, q0, opt, prm)


def test_a_slip_from_rest_started_along_its_slow_manifold_is_the_references():
    """Robustness scene 9 (derive verify robustness --plane face: a box under uniform
    pressure, mu 0.14) sticks, then slips from rest at t* = 1.1649 s with its twist's
    direction and size free.  crt_base.h starts such a slip along its slow manifold to a
    scaled twist of 1e-6 sqrt(g ell) (the direction at the flow's stable direction, the
    size the integral of its along rate) where explicit steps from 1e2 eps take up to
    thousands (a stiff phase: the direction relaxes at a rate ~ mu g / |xi|); its rows
    from 1 ms before t* to 10 ms after against derive/base_reference.py (Newton-Euler,
    adaptive quadrature) run from the same rest, 1e-9 (the test costs ~2 s of CPU)."""
    from derive import base_reference as br
    from derive.verify.generators import random_face_scene
    from derive.verify.judges import face_system
    from derive.verify.robustness import FACE_MAX_DURATION, PLANE_SEEDS
    k = 9
    doc = random_face_scene(np.random.default_rng(11 * 1_000_003 + PLANE_SEEDS["face"] + k),
                            FACE_MAX_DURATION)
    doc["run"]["output_dt"] = 0.005
    scene = parse_scene(doc, "random")
    r = simulate(scene)
    t_slip = [e["t"] for e in r.events if e["kind"] == "slip"][0]
    # the start taken is the slow manifold's: the first row after the slip at 1e-6 v_scale
    ell = choice.base_face(scene).size
    after = int(np.flatnonzero((r.row_kind == abi.ROW_KIND["after_event"])
                               & (np.abs(r.t - t_slip) < 0.01))[0])
    q = r.model_q[after]
    size = np.hypot(np.hypot(q[3], q[4]), ell * q[5]) / np.sqrt(scene.g * ell)
    assert abs(size / 1e-6 - 1.0) < 1e-9 and r.t[after] > t_slip
    i0 = int(np.flatnonzero(r.t < t_slip - 1e-3)[-1])
    i1 = int(np.flatnonzero(r.t > t_slip + 0.01)[0])
    assert not np.any(r.model_q[i0, 3:])
    ref = br.Integrator(face_system(scene)).run(r.model_q[i0], float(r.t[i0]), float(r.t[i1]))
    assert [k for _, k in ref.events] == ["slip"] and abs(ref.events[0][0] - t_slip) < 1e-9
    assert np.abs(ref.samples[-1][1:] - r.model_q[i1]).max() < 1e-9
