"""The rough model against a soft peer that converges to it: the penalty formulation of
tests/penalty_friction.py (a spring, a damper and a regularised Coulomb friction at S on
the Newton-Euler laws of tests/newton_euler_friction.py), integrated by SciPy (DOP853, or
LSODA where friction sticks), at stiffnesses k = 1e4, 1e5, 1e6 N/m (the regularisation eps
shrinking as 1/sqrt(k)).

The soft contact lasts tau ~ sqrt(m/k), so the peer differs from the event-driven run by
O(tau) ~ k^-1/2: the differences must fall by about sqrt(10) per decade of k, and
Richardson's extrapolation in k^-1/2 of the last two must fall further (a limit other
than the runtime's would leave it at that other limit's distance).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import newton_euler_friction as ne
from penalty_friction import Penalty, height_of_S, lowest_point
from derive.runtime.driver import simulate
from derive.scene import parse_scene

R = 0.3
CENTER = [0.06, -0.04, 0.05]          # C off the sphere's centre: W_tn != 0, the slip and
STIFFNESS = (1e4, 1e5, 1e6)           # the normal impulse couple


def _scene(mu, e, law, com, V, omega, quat, duration):
    return {"body": {"mass": 1.0, "inertia": [0.05, 0.06, 0.07], "shape": "sphere",
                     "radius": R, "center": CENTER},
            "point": {"mass": 0.3, "law": law},
            "plane": {"restitution": e, "friction": mu},
            "initial": {"com": com, "com_velocity": V, "omega": omega, "quaternion": quat},
            "run": {"duration": duration, "method": "dop853", "rtol": 1e-12, "atol": 1e-14}}


def _state(q):
    """V_C and R omega (fixed axes): what is compared."""
    A = q[9:18].reshape(3, 3)
    return np.r_[q[3:6], R * (A @ q[6:9])]


def _converges(errors, extrapolated):
    ratios = [a / b for a, b in zip(errors[:-1], errors[1:])]
    assert all(2.5 < r < 4.5 for r in ratios), ratios                 # ~ sqrt(10)
    assert extrapolated < 0.25 * errors[-1], (extrapolated, errors)


@pytest.mark.parametrize("mu, stage, method", [(0.05, "slip", "DOP853"),
                                               (1.5, "stick", "LSODA")])
def test_an_elastic_penalty_impact_converges_to_the_energetic_impact(mu, stage, method):
    """e = 1, energetic: an undamped spring gives back in restitution the work of
    compression.  From the state at the runtime's impact, the peer runs to separation; the
    runtime's state at that time (its impact, then flight) is compared.  (Sticking makes
    the regularised friction stiff: LSODA there.)"""
    law = ["0.1", "0.05", "-0.05"]
    doc = _scene(mu, 1.0, law, [0, 0, 0.5], [1.5, -0.5, -1.0], [2.0, -3.0, 4.0],
                 [0.9, 0.2, -0.3, 0.1], 0.3)
    run = simulate(doc)
    hit = next(ev for ev in run.events if ev["kind"] == "impact")
    assert hit["stage"] == stage
    i = int(np.flatnonzero(run.row_kind == 1)[0])
    t0, q0 = run.t[i], run.model_q[i]
    sc = run.scene
    params = np.array([sc.M, sc.m, *sc.J, sc.g])
    u = np.array([0.1, 0.05, -0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])

    def apart(_t, q):
        s = lowest_point(q[9:18].reshape(3, 3)[2], (R, R, R), CENTER)
        return height_of_S(q, u, s, params) + 1e-15
    apart.terminal, apart.direction = True, 1
    errors, states = [], []
    for k in STIFFNESS:
        peer = Penalty(lambda _t: u, params, (R, R, R), CENTER, mu, k, 0.0,
                       1e-3 * np.sqrt(1e4 / k))
        sol = solve_ivp(peer.rates, (t0, t0 + 0.2), q0, method=method, rtol=1e-10,
                        atol=1e-12, max_step=0.05 / np.sqrt(k), events=[apart])
        t_sep, q_sep = sol.t_events[0][0], sol.y_events[0][0]
        doc["run"]["duration"] = float(t_sep)
        ours = _state(simulate(doc).model_q[-1])
        states.append((_state(q_sep), ours))
        errors.append(float(np.abs(states[-1][0] - ours).max()))
    f = np.sqrt(10.0)
    (p1, r1), (p2, r2) = states[-2:]
    extrapolated = np.abs((p2 + (p2 - p1) / (f - 1)) - (r2 + (r2 - r1) / (f - 1))).max()
    print(f"{stage}: {['%.2e' % e for e in errors]}, extrapolated {extrapolated:.1e}")
    _converges(errors, extrapolated)


@pytest.mark.slow
def test_a_damped_penalty_contact_converges_to_sliding_then_sticking():
    """On the plane from rest in the normal direction, sliding and spinning, the point
    moving: the runtime slides, sticks (an event) and rolls; the peer (damped at the
    critical rate, from its static deflection) is compared at t = 1 s."""
    mu = 0.3
    law = ["0.1*sin(4*t)", "0.05*cos(3*t)", "-0.05"]

    def law_u(t):
        return np.array([0.1 * np.sin(4 * t), 0.05 * np.cos(3 * t), -0.05,
                         0.4 * np.cos(4 * t), -0.15 * np.sin(3 * t), 0.0,
                         -1.6 * np.sin(4 * t), -0.45 * np.cos(3 * t), 0.0])
    doc = _scene(mu, 0.0, law, [0.0, 0.0, 1.0], [1.0, -0.3, 0.0], [0.0, 0.0, 2.0],
                 [1.0, 0.0, 0.0, 0.0], 1.0)
    sc = parse_scene(doc)
    params = np.array([sc.M, sc.m, *sc.J, sc.g])
    q = np.r_[0.0, 0.0, 1.0, 1.0, -0.3, 0.0, 0.0, 0.0, 2.0, sc.A0.ravel()]
    s0 = lowest_point(sc.A0[2], (R, R, R), CENTER)
    q[2] -= height_of_S(q, law_u(0.0), s0, params)             # S on the plane
    q[5] -= ne.velocity_of_S(q, law_u(0.0), s0, params)[2]     # not moving normally
    doc["initial"]["com"][2], doc["initial"]["com_velocity"][2] = float(q[2]), float(q[5])
    run = simulate(doc)
    assert [ev["kind"] for ev in run.events][-1] == "stick"
    ours = np.r_[run.model_q[-1][:3], _state(run.model_q[-1])]
    errors, states = [], []
    for k in STIFFNESS:
        weight = (sc.M + sc.m) * sc.g
        peer = Penalty(law_u, params, (R, R, R), CENTER, mu, k,
                       2.0 * np.sqrt(k * (sc.M + sc.m)), 1e-3 * np.sqrt(1e4 / k))
        q0 = q.copy()
        q0[2] -= weight / k                                    # the static deflection
        sol = solve_ivp(peer.rates, (0.0, 1.0), q0, method="LSODA", rtol=1e-10, atol=1e-12,
                        max_step=0.01)
        theirs = np.r_[sol.y[:3, -1], _state(sol.y[:, -1])]
        theirs[2] += weight / k
        states.append(theirs)
        errors.append(float(np.abs(theirs - ours).max()))
    f = np.sqrt(10.0)
    extrapolated = np.abs(states[-1] + (states[-1] - states[-2]) / (f - 1) - ours).max()
    print(f"{['%.2e' % e for e in errors]}, extrapolated {extrapolated:.1e}")
    _converges(errors, extrapolated)
