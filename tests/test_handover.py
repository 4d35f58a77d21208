"""A base run that lifts off goes on in the general model (derive/runtime/handover.py),
each check against something computed apart:

* a box pushed straight up by its internal mass (N = (M + m) g + m z'' reaches 0): the
  lift-off time against the closed form asin((M + m) g / (m A W^2)) / W; the flight's C
  against its parabola and the attitude against the free rotation about the vertical
  (R_z(psi_l + w (t - t_l))); the flat landing's time against the root of the face's
  height, Z_C(t) - m z(t)/(M + m) - c, with C on that parabola;
* the hand-over's state against C = O + A OC, V_C = V_O + A (omega x OC + OC') written
  here from the law's formulas; the energy and the momenta on both sides;
* a tilted lift-off (the mass also moving sideways, its sideways acceleration 0 at the
  lift-off so that the face does not tip first) that lands on a corner and goes on:
  against the general model started from the hand-over's state by a scene of its own;
* random boxes and cylinders whose laws lift them off (seeded): the status honest (a flat
  landing's corners within the height resolution, any other first touch not) and the
  state continuous across the hand-over;
* the CLI: one trajectory, one events.csv (the lift-off, then the flight's), one
  summary.json whose status is the run's end.
"""
import dataclasses
import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from derive import layout
from derive.cli import main
from derive.runtime import handover
from derive.runtime.base_report import normal_force
from derive.runtime.driver import simulate
from derive.runtime.motion import motion
from derive.scene import parse_scene

G = layout.GENERAL
g = 9.81
M, m, A_z, W = 1.0, 0.5, 0.0367875, 40.0     # (M + m) g / (m A W^2) = 1/2: t_l = pi/240
SPIN = 3.0

_SCENE = """
name = "{name}"
[body]
mass = {M}
inertia = [0.01, 0.02, 0.025]
shape = "box"
half_extents = [0.1, 0.06, 0.04]
[[point]]
mass = {m}
law = {law}
[plane]
friction = 0.8
restitution = 0.3
[initial]
on_plane = true
carrier_velocity = [0.0, 0.0, 0.0]
omega = [0.0, 0.0, {spin}]
[run]
duration = {duration}
"""
UP = f'["0", "0", "{A_z}*sin({W}*t)"]'
TILT = f'["0.01*sin(25*t - 25*pi/240)", "0.006*sin(30*t - 30*pi/240)", "{A_z}*sin({W}*t)"]'


def _scene(law, spin=SPIN, duration=0.6, name="hop"):
    return parse_scene(_SCENE.format(name=name, M=M, m=m, law=law, spin=spin,
                                     duration=duration))


@pytest.fixture(scope="module")
def up():
    return simulate(_scene(UP))


def _z(t):
    return A_z * np.sin(W * t), A_z * W * np.cos(W * t)


def test_a_box_pushed_straight_up_lifts_off_flies_and_lands_flat(up):
    h = up.handover
    t_l = math.asin((M + m) * g / (m * A_z * W * W)) / W
    assert up.status == "flat_landing" and h is not None and h.base.status == "lift_off"
    assert abs(h.t - t_l) < 1e-9
    # the flight: C on its parabola, the attitude turning uniformly about the vertical
    a, b = np.searchsorted(up.t, h.t, side="right"), len(up.t)
    t, Q = up.t[a:b], up.model_q[a:b]
    Z0, V0 = h.state[G.Z], h.state[G.Zd]
    tau = t - h.t
    assert np.max(np.abs(Q[:, G.Z] - (Z0 + V0 * tau - 0.5 * g * tau ** 2))) < 1e-9
    assert np.max(np.abs(Q[:, G.Zd] - (V0 - g * tau))) < 1e-9
    assert np.max(np.abs(Q[:, G.horizontal] - h.state[G.horizontal])) < 1e-12
    w = h.state[G.omega][2]
    assert 0.0 < w < SPIN and np.max(np.abs(Q[:, G.omega] - [0.0, 0.0, w])) < 1e-9
    A_l = h.state[G.A].reshape(3, 3)
    for tk, qk in zip(tau, Q):
        c, s = math.cos(w * tk), math.sin(w * tk)
        Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        assert np.max(np.abs(qk[G.A].reshape(3, 3) - Rz @ A_l)) < 1e-9
    # the landing: the face's height Z_C - m z/(M + m) - c reaches 0 (C on the parabola)

    def face(tt):
        return Z0 + V0 * (tt - h.t) - 0.5 * g * (tt - h.t) ** 2 - m * _z(tt)[0] / (M + m) - 0.04
    ts = np.linspace(h.t + 1e-6, h.t + 0.5, 50001)
    k = int(np.flatnonzero(face(ts) < 0)[0])
    t_land = brentq(face, ts[k - 1], ts[k], xtol=1e-15)
    assert abs(up.t[-1] - t_land) < 1e-9 and abs(h.landing["t"] - t_land) < 1e-9
    assert h.landing["spread"] <= h.landing["resolution"]
    assert up.events[-1]["kind"] == "flat_landing" and up.stats["impacts"] == 0


def test_the_noise_the_hand_over_judges_by_is_the_runtimes(up):
    """The height resolution and the speed noise a landing is judged by are read from the
    C (handover.noise: one source, crt_plane.h): against their formulas written here
    (10 max(atol + rtol (|Z_C| + L), 64 eps (|Z_C| + L)) and 1e3 eps (|Z_C'| + |omega| L
    + sqrt(g L)), L the run's length scale) on every row of the flight, which is no
    constant (Z_C, Z_C' and omega change along it); the flat landing's resolution is the
    one at its row."""
    from derive import abi
    from derive.runtime.driver import options
    flight = up.handover.flight
    s = flight.scene
    L = options(s, flight.model)[abi.index(abi.OPTIONS, "length_scale")]
    eps = np.finfo(float).eps
    got = np.array([handover.noise(flight, i) for i in range(len(flight.t))])
    Q = flight.model_q
    size = np.abs(Q[:, G.Z]) + L
    res = 10.0 * np.maximum(s.atol + s.rtol * size, 64 * eps * size)
    noise = 1e3 * eps * (np.abs(Q[:, G.Zd]) + np.linalg.norm(Q[:, G.omega], axis=1) * L
                         + math.sqrt(g * L))
    assert np.ptp(res) > 0 and np.ptp(noise) > 0
    assert np.max(np.abs(got[:, 0] / res - 1)) < 1e-14
    assert np.max(np.abs(got[:, 1] / noise - 1)) < 1e-14
    assert up.handover.landing["resolution"] == got[-1, 0]


@pytest.mark.parametrize("f, first", [(1.2, "contact"), (1.5, "graze")])
def test_a_touch_at_the_hand_over_instant_is_no_landing(f, first):
    """Pushed up at a peak of f g (f a little above 1), the C may find the face touching
    at the hand-over's instant itself, v_n round-off (a contact it leaves at once, or a
    graze; or, the round-off upward, no touch): that is no landing (it was: a flight of
    0 s, landed flat).  The flat landing is later, at the root of the face's height with
    C on its parabola from the hand-over's state (as for the box pushed up above)."""
    Af = f * (M + m) * g / (m * W * W)
    run = simulate(_scene(f'["0", "0", "{Af!r}*sin({W}*t)"]', duration=0.3))
    h = run.handover
    assert abs(h.t - math.asin(1.0 / f) / W) < 1e-9
    at_once = [ev for ev in h.flight.events if ev["t"] - h.t < 1e-12]
    # v_n at the hand-over is round-off, of either sign: the touch (when found) is the
    # kind the rate says, never a landing
    assert all(ev["kind"] == first and abs(ev["v_minus"]) < 1e-15 for ev in at_once[:1])
    assert not any(ev["kind"] == "flat_landing" for ev in at_once)
    Z0, V0 = h.state[G.Z], h.state[G.Zd]

    def face(tt):
        return Z0 + V0 * (tt - h.t) - 0.5 * g * (tt - h.t) ** 2 \
            - m * Af * np.sin(W * tt) / (M + m) - 0.04
    ts = np.linspace(h.t + 1e-6, h.t + 0.3, 30001)
    k = int(np.flatnonzero(face(ts) < 0)[0])
    t_land = brentq(face, ts[k - 1], ts[k], xtol=1e-15)
    assert run.status == "flat_landing" and abs(h.landing["t"] - t_land) < 1e-9
    assert h.landing["t"] - h.t > 0.05


def test_the_flights_rows_are_on_the_runs_output_grid():
    """With [run].output_dt the flight's rows are t0 + k output_dt, the run's grid (they
    counted from the lift-off): every step row after the hand-over on it to 1e-12, each
    grid time between the hand-over and the landing there once, and Z_C on those rows
    on its parabola from the hand-over's state (the dense output read at them)."""
    from derive import abi
    dt = 0.01
    run = simulate(dataclasses.replace(_scene(UP, duration=0.6), output_dt=dt))
    h = run.handover
    flight = (run.row_kind == abi.ROW_KIND["step"]) & (run.t > h.t)
    t = run.t[flight]
    k = np.round((t - run.scene.t0) / dt)
    assert np.max(np.abs(t - (run.scene.t0 + k * dt))) < 1e-12
    want = np.arange(math.floor(h.t / dt) + 1, math.ceil(run.t[-1] / dt))
    assert np.array_equal(k, want) and len(k) >= 10
    tau = t - h.t
    Z = h.state[G.Z] + h.state[G.Zd] * tau - 0.5 * g * tau ** 2
    assert np.max(np.abs(run.model_q[flight, G.Z] - Z)) < 1e-9


def _independent_state(scene, base) -> np.ndarray:
    """C's position and velocity and the attitude from the base state at lift-off, here
    from the law's formulas: OC = m OP/(M + m) (the body's centre at O), r_O = (X_O, Y_O,
    h) with h the face's depth below O (c of a box, the half-length of a cylinder),
    A = R_z(psi) (the -z face down)."""
    from derive.runtime.choice import base_face
    Mb, mp, depth = scene.M, scene.m, base_face(scene).height
    t = float(base.t[-1])
    X, Y, psi, VX, VY, w = base.model_q[-1]
    exprs = [str(e) for e in scene.law_text]
    env = {"t": t, "sin": math.sin, "cos": math.cos, "pi": math.pi}
    dt = 1e-6
    P = np.array([eval(e, env) for e in exprs])                     # noqa: S307
    dP = (np.array([eval(e, {**env, "t": t + dt}) for e in exprs])  # noqa: S307
          - np.array([eval(e, {**env, "t": t - dt}) for e in exprs])) / (2 * dt)  # noqa: S307
    c, s = math.cos(psi), math.sin(psi)
    A = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    OC, dOC = mp * P / (Mb + mp), mp * dP / (Mb + mp)
    r_C = np.array([X, Y, depth]) + A @ OC
    V_C = np.array([VX, VY, 0.0]) + A @ (np.cross([0.0, 0.0, w], OC) + dOC)
    return np.concatenate([r_C, V_C, [0.0, 0.0, w], A.ravel()])


@pytest.mark.parametrize("which", ["up", "tilt"])
def test_the_handover_state_is_the_base_state_written_apart(up, tilt, which):
    run = up if which == "up" else tilt
    h = run.handover
    assert np.max(np.abs(h.state - _independent_state(run.scene, h.base))) < 1e-9
    # the rows on both sides are that state (the runtime's start of A and C: round-off);
    # N = 0 there
    i = len(h.base.t)
    assert np.array_equal(run.model_q[i - 1], h.state)
    assert np.max(np.abs(run.model_q[i] - h.state)) <= 1e-15
    assert abs(normal_force(h.base)[-1]) < 1e-9 * (M + m) * g
    # energy and momenta across it: the base run's own motion and the flight's
    mb, mf = motion(h.base), motion(h.flight)
    assert abs(mb.E[-1] - mf.E[0]) <= 1e-12 * max(abs(mb.E[-1]), 1.0)
    Kb, Kf = h.base.momentum["K_fixed"][-1], h.flight.momentum["K_fixed"][0]
    assert np.max(np.abs(Kb - Kf)) <= 1e-12
    assert np.max(np.abs(h.base.general[-1, G.com_velocity]
                         - h.flight.model_q[0, G.com_velocity])) <= 1e-15


@pytest.fixture(scope="module")
def tilt():
    return simulate(_scene(TILT, spin=0.0, duration=0.3, name="tilt"))


def test_a_tilted_lift_off_lands_on_a_corner_and_goes_on(tilt):
    h = tilt.handover
    assert abs(h.t - math.pi / 240) < 1e-9 and h.landing is None
    impacts = [ev for ev in tilt.events if ev["kind"] == "impact"]
    assert impacts and impacts[0]["t"] > h.t
    i = int(np.searchsorted(tilt.t, impacts[0]["t"]))
    spread = handover.flat_spread(tilt.scene, tilt.model_q[i, G.A])
    assert spread > 1e-4                          # a corner, well off flat
    # the general model from the hand-over's state, as a scene of its own
    s = h.state
    text = (_SCENE.format(name="alone", M=M, m=m, law=TILT, spin=0.0, duration=0.3 - h.t)
            .replace("on_plane = true\ncarrier_velocity = [0.0, 0.0, 0.0]\n"
                     "omega = [0.0, 0.0, 0.0]",
                     f"com = {s[G.com].tolist()}\ncom_velocity = {s[G.com_velocity].tolist()}\n"
                     f"omega = {s[G.omega].tolist()}\nmatrix = "
                     f"{s[G.A].reshape(3, 3).tolist()}\ntime = {h.t!r}"))
    # (the flight's law proved over the flight alone, as this scene proves it: the
    # whole run's time scale, which bounds the step, parted them 1e-9 in the impacts'
    # accumulation)
    alone = simulate(parse_scene(text))
    assert alone.scene.law_summary == h.flight.scene.law_summary
    assert alone.model == tilt.model and alone.status == tilt.status
    a = len(h.base.t)
    assert len(alone.t) == len(tilt.t) - a
    assert np.max(np.abs(alone.t - tilt.t[a:])) < 1e-12
    assert np.max(np.abs(alone.model_q - tilt.model_q[a:])) < 1e-12
    assert len(alone.events) == len(tilt.events) - len(h.base.events)


@pytest.mark.parametrize("a_x, slips", [(1e-8, False), (1e-6, True)])
def test_a_break_away_just_before_the_lift_off_does_not_step_over_it(a_x, slips):
    """The tilted lift-off with a small constant sideways acceleration a_x added (the
    law's x plus a_x t^2/2): the friction the rest needs at the lift-off is m a_x, so
    gamma reaches 1 where mu N = m a_x, just before N's root.  N does not depend on x:
    the lift-off is still at pi/240.  m a_x / mu below N's resolution (1e-9 of the
    weight; a_x = 1e-8): no slip, the lift-off alone (the break-away's root there is
    N's); above it (1e-6): a slip, then the lift-off at N's root (the slip's start from
    rest stepped over it, 2.1e-6 s late, N -2e-3 there, at every optimisation level;
    without a_x the gauge's root at N's was a round-off's sign, late at -O1 only)."""
    law = TILT.replace('"0.01*sin(25*t - 25*pi/240)"',
                       f'"0.01*sin(25*t - 25*pi/240) + {a_x / 2!r}*t**2"')
    assert law != TILT
    run = simulate(_scene(law, spin=0.0, duration=0.3, name="tilt"))
    h = run.handover
    assert h is not None and h.base.status == "lift_off"
    assert abs(h.t - math.pi / 240) < 1e-9
    assert abs(normal_force(h.base)[-1]) < 1e-9 * (M + m) * g
    kinds = [ev["kind"] for ev in h.base.events]
    assert kinds == (["slip", "lift_off"] if slips else ["lift_off"])
    assert all(ev["t"] < h.t for ev in h.base.events[:-1])


@pytest.mark.parametrize("late, status", [(0.0, "done"), (1e-9, "done"), (1e-6, "done")])
def test_a_lift_off_at_or_just_before_the_end(late, status):
    """A flight of no time is none (the run is the base one); one of 1e-11 s, whose first
    touch has v_n >= 0, lands nowhere."""
    run = simulate(_scene(UP, spin=0.0, duration=math.pi / 240 * (1 + late)))
    assert run.status == status and (run.handover is None) == (late == 0.0)
    assert abs(run.t[-1] - math.pi / 240 * (1 + late)) < 1e-15


def test_without_restitution_the_run_stops_at_lift_off():
    scene = parse_scene(_SCENE.format(name="h", M=M, m=m, law=UP, spin=0.0, duration=0.3)
                        .replace("restitution = 0.3\n", ""))
    run = simulate(scene)
    assert run.status == "lift_off" and run.model == "base" and run.handover is None


# ---- random boxes and cylinders that lift off ----------------------------------------------
def _random_scene(rng, k):
    Mb, mp = rng.uniform(0.5, 2.0), rng.uniform(0.2, 1.0)
    Wk = rng.uniform(20.0, 50.0)
    ratio = rng.uniform(0.3, 0.9)                 # (M + m) g / (m A W^2): it lifts off
    Ak = (Mb + mp) * g / (ratio * mp * Wk * Wk)
    law = f'["0", "0", "{Ak!r}*sin({Wk!r}*t)"]'
    if k % 4 == 3:                                # sideways, still at the lift-off
        t_l = math.asin(ratio) / Wk
        law = (f'["{0.01 * rng.uniform(0.2, 1)!r}*sin(25*(t - {t_l!r}))", '
               f'"{0.006 * rng.uniform(0.2, 1)!r}*sin(30*(t - {t_l!r}))", '
               f'"{Ak!r}*sin({Wk!r}*t)"]')
    if k % 2:
        shape = f'shape = "cylinder"\nradius = {rng.uniform(0.04, 0.1)!r}\n' \
                f'half_length = {rng.uniform(0.02, 0.06)!r}'
    else:
        shape = ('shape = "box"\nhalf_extents = '
                 f'{[float(x) for x in rng.uniform(0.03, 0.1, 3)]}')
    v = [float(x) for x in rng.uniform(-0.3, 0.3, 2)]
    text = (_SCENE.format(name=f"r{k}", M=Mb, m=mp, law=law, spin=rng.uniform(-4, 4),
                          duration=0.25)
            .replace('shape = "box"\nhalf_extents = [0.1, 0.06, 0.04]', shape)
            .replace("carrier_velocity = [0.0, 0.0, 0.0]",
                     f"carrier_velocity = [{v[0]!r}, {v[1]!r}, 0.0]")
            .replace("friction = 0.8", f"friction = {rng.uniform(0.2, 1.0)!r}"))
    return parse_scene(text)


HONEST = ("done", "flat_landing", "surface_jump", "lift_off", "tipping")


def test_random_lift_offs_are_handed_over_honestly():
    rng = np.random.default_rng(33)
    handed = flat = 0
    for k in range(100):
        run = simulate(_random_scene(rng, k))
        assert run.status in HONEST, (k, run.status)
        h = run.handover
        if h is None:                              # (it tipped before N reached 0)
            assert run.status in ("tipping", "done"), (k, run.status)
            continue
        handed += 1
        i = len(h.base.t)
        assert np.max(np.abs(run.model_q[i - 1] - run.model_q[i])) <= 1e-15
        assert abs(normal_force(h.base)[-1]) < 1e-8 * (run.scene.M + run.scene.m) * g
        scale = max(np.abs(h.state[:6]).max(), 1.0)
        assert np.max(np.abs(h.state - _independent_state(run.scene, h.base))) \
            < 1e-8 * scale, k
        touches = [ev for ev in h.flight.events if ev["kind"] in ("impact", "flat_landing")]
        if run.status == "flat_landing":
            flat += 1
            assert h.landing["spread"] <= h.landing["resolution"]
            assert h.landing["t"] - h.t > 1e-6, k      # (a flight, not the C's touch at once)
        elif touches:                               # a corner or a rim point: not flat
            j = int(np.searchsorted(h.flight.t, touches[0]["t"]))
            res = handover.noise(h.flight, j)[0]
            assert handover.flat_spread(run.scene, h.flight.model_q[j, G.A]) > res
    # (a sideways law, k % 4 == 3, in a spinning body tips before N reaches 0: the moment
    # 2 mu w z rho'_h does not vanish with N; tests/test_base_tip_before_lift.py)
    assert handed >= 60 and flat >= 40, (handed, flat)


def test_the_cli_writes_one_run(tmp_path, capsys):
    path = tmp_path / "hop.toml"
    path.write_text(_SCENE.format(name="hop", M=M, m=m, law=UP, spin=SPIN, duration=0.6))
    out = tmp_path / "out"
    assert main(["simulate", str(path), "-o", str(out), "-q", "--no-plots"]) == 1
    said = capsys.readouterr().out
    assert ": flat_landing;" in said.splitlines()[0] and "lifted off at t = " in said
    events = [line.split(",")[:3] for line in
              (out / "events.csv").read_text().splitlines()[1:]]
    assert [e[:2] for e in events] == [["lift_off", "before"], ["lift_off", "after"],
                                       ["flat_landing", "before"], ["flat_landing", "after"]]
    info = json.loads((out / "summary.json").read_text())
    assert info["status"] == "flat_landing" and info["handover"]["flight_status"] == \
        "flat_landing"
    assert abs(info["handover"]["t"] - float(events[0][2])) == 0.0
    assert info["t_end"] == float(events[-1][2])
    energy = info["energy"]
    assert abs(energy["at_handover"]) <= 1e-12
    assert abs(energy["base"]["residual"]) <= 1e-9 and abs(energy["flight"]["residual"]) \
        <= 1e-9
    assert abs(energy["change"] - energy["base"]["change"] - energy["flight"]["change"]) \
        <= 1e-12
    # |K| of the flight constant (E1.9): the base rows are no flight of its
    assert info["invariants"]["K_norm_relative_drift_between_events"] <= 1e-12
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    traj = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1, ndmin=2)
    assert traj[0, 0] == 0.0 and traj[-1, 0] <= info["t_end"]
    on_face = traj[:, 0] < info["handover"]["t"]
    mode = traj[:, header.index("mode")]
    assert on_face.any() and set(mode[on_face]) <= {2.0, 3.0} and set(mode[~on_face]) == {0.0}


def test_the_robustness_judge_of_a_handover_can_fail(up):
    """derive verify robustness --plane face's judge: the run as it is passes; a state
    that jumps at the hand-over, or a flat landing whose face is tilted by 1e-3 rad, fail."""
    from derive.verify.judges import judge_handover
    h = up.handover
    assert judge_handover(up) == ("ok", "lift_off, then flat_landing")
    q = up.model_q.copy()
    q[len(h.base.t), G.Z] += 1e-6
    assert judge_handover(dataclasses.replace(up, model_q=q))[0] == "handover"
    fq = h.flight.model_q.copy()
    c, s = math.cos(1e-3), math.sin(1e-3)
    fq[-1, G.A] = (fq[-1, G.A].reshape(3, 3) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
                   ).ravel()
    tilted = dataclasses.replace(h, flight=dataclasses.replace(h.flight, model_q=fq))
    assert judge_handover(dataclasses.replace(up, handover=tilted))[0] == "landing"


# ---- drawing a cylinder ---------------------------------------------------------------------
@pytest.mark.filterwarnings("error")
def test_a_cylinder_is_drawn_with_no_invalid_value(tmp_path):
    """The principal sections drawing.body_pictures draws meet directions 1e-16 off the
    cylinder's axis (cos(pi/2)), where (rr + 1) - 1 was 0 and R/0 times 0 NaN ("invalid
    value encountered in matmul"): the support points of those directions against the
    closed form (the rim at R (x, y)/|(x, y)| on the end face z = L sign(d_z), its centre
    along the axis), then a cylinder's hop drawn as an overview, warnings as errors."""
    from derive.runtime.plots import overview
    from derive.shapes import SHAPES
    R, L = 0.08, 0.03
    ang = np.linspace(0.0, 2.0 * np.pi, 73)
    d = np.column_stack([np.zeros(73), np.cos(ang), np.sin(ang)])     # the (y, z) section
    d = np.vstack([d, [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1e-150, 0.0, 1.0]]])
    got = SHAPES["cylinder"].support_rows(d, (R, L))
    rho = np.hypot(d[:, 0], d[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        rim = np.where(rho[:, None] > 0, R * d[:, :2] / rho[:, None], 0.0)
    want = np.column_stack([rim, L * np.sign(d[:, 2])])
    assert np.isfinite(got).all() and np.max(np.abs(got - want)) < 1e-15
    text = _SCENE.format(name="cyl", M=M, m=m, law=UP, spin=SPIN, duration=0.1).replace(
        'shape = "box"\nhalf_extents = [0.1, 0.06, 0.04]',
        f'shape = "cylinder"\nradius = {R}\nhalf_length = {L}')
    run = simulate(parse_scene(text))
    assert run.handover is not None
    assert overview(run, motion(run), tmp_path / "overview.png", dpi=30).stat().st_size > 0


# ---- studies hand over too ------------------------------------------------------------------
def test_a_study_hands_over_as_simulate_does(tmp_path):
    """derive.simulate_many (derive simulate --sweep) of variants either side of lift-off
    (the push's peak m A W^2/(M + m) at 0.8 g and 1.5 g: one stays on its face, one lifts
    off and lands flat) and the tilted one that lands on a corner and goes on (its whole
    flight in the general model's batch): each row equals summary_row of derive.simulate
    of that variant, bit for bit but the time it took, and keep = "result" gives that
    Result's status and end.  A handed-over row's slips, sticks and reversals are its
    face's (base_report.contact of the base phase) plus its flight's, summary.json's
    counts, read as columns unmasked and written in sweep.csv, with handover_t the
    lift-off's time."""
    import csv
    import tomllib

    import derive
    from derive.runtime import base_report
    from derive.runtime.study import FRICTION_COLUMNS, summary_row
    from derive.scene.overrides import apply_to_doc
    doc = tomllib.loads(_SCENE.format(name="hop", M=M, m=m, law=UP, spin=SPIN, duration=0.3))
    laws = [["0", "0", f"{f * (M + m) * g / (m * W * W)!r}*sin({W}*t)"] for f in (0.8, 1.5)]
    variants = [{"point.law": law} for law in laws] + [
        {"point.law": json.loads(TILT), "initial.omega": [0.0, 0.0, 0.0]}]
    rng = np.random.default_rng(36)        # and 12 seeded ones, as the random runs above
    for k in range(12):
        Wk, ratio = rng.uniform(20.0, 50.0), rng.uniform(0.3, 0.9)
        Ak = (M + m) * g / (ratio * m * Wk * Wk)
        side = ["0", "0"] if k % 3 else [
            f"{0.01 * rng.uniform(0.2, 1)!r}*sin(25*(t - {math.asin(ratio) / Wk!r}))", "0"]
        variants.append({"point.law": [*side, f"{Ak!r}*sin({Wk!r}*t)"],
                         "initial.omega": [0.0, 0.0, float(rng.uniform(-4, 4))],
                         "initial.carrier_velocity": [*map(float, rng.uniform(-0.3, 0.3, 2)),
                                                      0.0],
                         "plane.friction": float(rng.uniform(0.2, 1.0))})
    batch = derive.simulate_many(doc, variants, workers=1)
    kept = derive.simulate_many(doc, variants, workers=1, keep="result").results
    statuses, handed = [], []
    for v, row, res in zip(variants, batch.rows, kept):
        d = json.loads(json.dumps(doc))
        for name, value in v.items():
            apply_to_doc(d, name, value)
        run = derive.simulate(d)
        want = summary_row(run)
        same = {k: row[k] == want[k] or (row[k] != row[k] and want[k] != want[k])
                for k in want if k != "run_ms"}               # (NaN: no contact)
        assert all(same.values()), (v, {k: (row[k], want[k]) for k in same if not same[k]})
        assert (res.status, res.t[-1]) == (run.status, run.t[-1])
        statuses.append((row["status"], row["model"], run.handover is not None))
        if run.handover is not None:     # the face's counts, then the flight's (summary.json's
            h = run.handover             # counts are run.stats; its contact.face the face's)
            face = base_report.contact(h.base)
            assert row["handover_t"] == h.t
            for name in FRICTION_COLUMNS:
                assert row[name] == face[name] + h.flight.stats[name] == run.stats[name]
            handed.append(row)
    assert statuses[:3] == [("done", "base", False), ("flat_landing", "rough", True),
                            ("surface_jump", "rough", True)]
    assert sum(handed for _, _, handed in statuses[3:]) >= 8, statuses
    # read as columns and written as sweep.csv: the face's counts there, not masked or blank
    on = np.array([h for _, _, h in statuses])
    assert sum(r["slips"] + r["sticks"] for r in handed) > 0
    for name in FRICTION_COLUMNS:
        col = batch.column(name)
        assert not col.mask.any() and col.tolist() == [r[name] for r in batch.rows]
    batch.to_csv(tmp_path / "sweep.csv")
    table = list(csv.DictReader(open(tmp_path / "sweep.csv", encoding="utf-8")))
    assert all((r["slips"] != "") == (r["model"] == "base" or o) for r, o in zip(table, on))
    assert [float(r["handover_t"]) == row["handover_t"] or not o
            for r, row, o in zip(table, batch.rows, on)] == [True] * len(on)
