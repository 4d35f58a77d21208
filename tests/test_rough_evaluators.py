"""What the rough model's C evaluates for Python, against the reaction computed apart
from it (derive/verify/reaction.py: Newton–Euler under each row's mode).

* ``Session.wrench_rows`` (crt_eval_wrench_rows, what the energy balance and the charts
  read) on rows in every mode, each sliding direction given or taken from the slip, each
  couple held or turning along a given direction or along the angular velocity: the
  wrench (R, T) and the velocities (v_S, A omega); in flight no wrench and the flight's
  right-hand side.
* The run's summary: the least normal reaction in contact (``min_normal``: the entry
  into contact included) and the largest |R_t|/(mu_f N) of the sticking steps
  (``max_friction_ratio``), the extremes of the independent reaction over the rows.
* ``Session.run_in_contact`` (crt_set_contact_mode, the energy balance's resumed contact
  phases): resumed from a row of a run in its mode (sliding along its slip, or sticking)
  it starts with no event, follows the run's own rows and ends sticking as the run
  (``crt_contact_mode``); a sliding start needs a direction, a sticking one none.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from derive import abi
from derive.runtime import choice
from derive.runtime.driver import options, simulate
from derive.verify import reaction as rx

G = 9.81
M, m, RADIUS = 1.0, 0.3, 0.5


def sphere(law, mu, v0=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0), mu_s=0.0, mu_r=0.0,
           duration=0.4, center=(0.0, 0.0, 0.0)) -> dict:
    """A sphere on the plane at t = 0 (its centre O at v0), the point at r(t)."""
    return {"name": "evaluators",
            "body": {"mass": M, "inertia": [0.1, 0.11, 0.12], "shape": "sphere",
                     "radius": RADIUS, "center": list(center)},
            "point": {"mass": m, "law": list(law)},
            "plane": {"restitution": 0.0, "friction": mu, "spin_friction": mu_s,
                      "rolling_resistance": mu_r},
            "initial": {"on_plane": True, "com_velocity": list(v0), "omega": list(omega)},
            "run": {"duration": duration, "method": "dop853", "rtol": 1e-10, "atol": 1e-12}}


def orthonormal(Q):
    """The rows with their attitude projected on the rotations (both sides read it)."""
    Q = np.array(Q, dtype=float)
    U, _, Vt = np.linalg.svd(Q[:, 9:18].reshape(-1, 3, 3))
    Q[:, 9:18] = (U @ Vt).reshape(-1, 9)
    return Q


def unit(v, fallback):
    n = np.linalg.norm(v, axis=1)
    return np.where(n[:, None] > 0, v / np.where(n > 0, n, 1.0)[:, None], fallback)


def test_the_wrench_rows_are_the_independent_reactions_in_every_mode():
    result = simulate(sphere(["0.3*sin(5*t)", "0.1*cos(4*t)", "0.05*sin(7*t)"], mu=0.4,
                             v0=(0.3, 0.1, 0.0), omega=(0.5, -1.0, 2.0), mu_s=0.02,
                             mu_r=0.03, center=(0.05, -0.03, 0.02)))
    s = result.scene
    rng = np.random.default_rng(7)
    n = len(result.t)
    Q = orthonormal(result.model_q)
    mode = rng.choice([abi.MODE["flight"], abi.MODE["sliding"], abi.MODE["sticking"]], n)
    b = rx.Bodies.of(s)
    k = rx.kinematics(b, Q, rx.law_rows(s, result.t))
    # along the slip where it has a direction (a stuck row's is round-off's)
    slips = np.hypot(k.v_S[:, 0], k.v_S[:, 1]) > 1e-6
    given = rng.normal(size=(n, 2)) * ((rng.random(n) < 0.5) | ~slips)[:, None]
    held = rng.integers(0, 4, n)
    cdir = rng.normal(size=(n, 3)) * (rng.random(n) < 0.5)[:, None]
    _, w, u = result.session.wrench_rows(result.t, Q, mode, given, held, cdir)
    assert np.abs(u[:, :3] - k.v_S).max() < 1e-12 and np.abs(u[:, 3:] - k.Omega).max() < 1e-12
    sigma = unit(np.where((np.abs(given) > 0).any(axis=1)[:, None], given, k.v_S[:, :2]),
                 [1.0, 0.0])
    spin = np.where(cdir[:, 0] != 0.0, np.sign(cdir[:, 0]), np.sign(k.Omega[:, 2]))
    roll = unit(np.where((np.abs(cdir[:, 1:]) > 0).any(axis=1)[:, None], cdir[:, 1:],
                         k.Omega[:, :2]), [1.0, 0.0])
    ours = rx.solve(b, k, mode == abi.MODE["sticking"], sigma, (held & 1) != 0,
                    (held & 2) != 0, np.where(spin == 0.0, 1.0, spin), roll)
    contact = mode != abi.MODE["flight"]
    assert contact.sum() > 10 and (~contact).sum() > 10
    scale = b.weight
    assert np.abs(w[contact, :3] - ours.R[contact]).max() < 1e-9 * scale
    assert np.abs(w[contact, 3:] - ours.T[contact]).max() < 1e-9 * scale * RADIUS
    assert not w[~contact].any()
    dq, _, _ = result.session.wrench_rows(result.t, Q, np.zeros(n, dtype=int), given, held,
                                          cdir)
    assert np.array_equal(dq, result.session.rhs_rows(result.t, Q))


@pytest.mark.parametrize("sticks", [True, False])
def test_the_summary_holds_the_extremes_of_the_independent_reaction(sticks):
    """The first scene sticks throughout, N least at its entry into contact (the point's
    z'' largest there) and |R_t|/(mu_f N) rising and falling; the second lands sliding
    and sticks later (its ratio 1 while sliding)."""
    if sticks:
        doc = sphere(["0.04*(1 - cos(9*t))", "0.03*(1 - cos(6*t))", "0.05*cos(10*t)"],
                     mu=0.5, duration=0.55)
    else:
        doc = sphere(["0.3*sin(5*t)", "0.1*cos(4*t)", "0.05*sin(7*t)"], mu=0.4,
                     v0=(1.0, 0.3, 0.0))
    result = simulate(doc)
    s = result.scene
    modes = rx.row_modes(result)
    rows = np.flatnonzero((modes.mode == rx.STICKING) | (modes.mode == rx.SLIDING))
    b = rx.Bodies.of(s)
    k = rx.kinematics(b, result.model_q[rows], rx.law_rows(s, result.t[rows]))
    sticking = modes.mode[rows] == rx.STICKING
    slip = np.hypot(k.v_S[:, 0], k.v_S[:, 1])
    ours = rx.solve(b, k, sticking, k.v_S[:, :2] / np.where(slip > 0, slip, 1.0)[:, None])
    ratio = np.hypot(ours.R[:, 0], ours.R[:, 1]) / (s.friction * ours.N)
    summary = result.summary
    assert summary["min_normal"] == pytest.approx(ours.N.min(), rel=1e-9)
    if sticks:
        assert sticking.all() and int(np.argmin(ours.N)) == 0     # the entry's
        assert summary["max_friction_ratio"] == pytest.approx(ratio.max(), rel=1e-9)
        assert ratio[-1] < 0.9 * ratio.max()           # it rose and fell
    else:
        assert sticking.any() and (~sticking).any()
        assert summary["max_friction_ratio"] == 1.0


def _resume(result, j: int, mode: int, direction):
    s = result.scene
    opt = options(s, result.model)
    prm = choice.parameters(s, result.start.constants)
    span = float(result.t[-1] - result.t[j])
    return result.session.run_in_contact(float(result.t[j]), span, result.model_q[j], opt,
                                         prm, mode, direction)


def test_a_run_resumed_in_contact_follows_the_runs_rows():
    """A sphere landing at 0.3 m/s slides, then sticks: resumed from a sliding row along
    its slip (and from a sticking row, with no direction), the run starts with no event,
    slides (sticks) as the run did and ends where it ended; a sliding start without a
    direction is refused."""
    result = simulate(sphere(["0.3*sin(5*t)", "0.1*cos(4*t)", "0.05*sin(7*t)"], mu=0.4,
                             v0=(1.0, 0.3, 0.0), duration=0.6))
    modes = rx.row_modes(result)
    steps = np.flatnonzero(modes.side == 0)
    for mode in (abi.MODE["sliding"], abi.MODE["sticking"]):
        j = steps[modes.mode[steps] == mode][2]
        v = result.slip[j]
        direction = v / np.hypot(*v) if mode == abi.MODE["sliding"] else (0.0, 0.0)
        raw = _resume(result, j, mode, direction)
        kinds = [abi.EVENT_KINDS[int(e[1])].name for e in raw.events] if len(raw.events) \
            else []
        assert not kinds or kinds[0] not in ("contact", "impact", "graze"), kinds
        # (to 1e-4: the two runs set their slip's resolutions from the velocities where
        # each entered the mode, and a stopping slip's last stretch within them differs
        # by up to 1e-6 of the state; a mode entered wrongly differs by its slip)
        scale = np.abs(result.model_q[-1]).max()
        assert np.abs(raw.q[-1] - result.model_q[-1]).max() < 1e-4 * scale, mode
        first = [e["kind"] for e in result.events if e["t"] > result.t[j]]
        assert kinds[:1] == first[:1], (kinds, first)
        # the C's own word on the mode it ends in (crt_contact_mode, for embedders)
        session = result.session
        assert session.library.lib.crt_contact_mode(session.handle) == abi.MODE["sticking"]
    with pytest.raises(ValueError, match="bad_argument"):
        _resume(result, steps[-1], abi.MODE["sliding"], (0.0, 0.0))
    assert math.isfinite(result.q[-1][0])
