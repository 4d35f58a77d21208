"""Periodic bouncing (reference [5]): the closed-form ball-on-a-vibrating-table results
against an independent numerical impact map, and the carrier's orbits and multipliers
(tilt modes included) against both."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq, fsolve

from derive.scene import SceneError, parse_scene
from derive.stability import bouncing

G, W = 9.81, 30.0


def table_map(state, e: float, A: float):
    """(t_k, v_k) -> (t_k+1, v_k+1) for a ball over s(t) = A sin(W t), by root finding."""
    t, v = state
    s = lambda tt: A * math.sin(W * tt)  # noqa: E731
    gap = lambda tau: s(t) + v * tau - 0.5 * G * tau * tau - s(t + tau)  # noqa: E731
    taus = np.linspace(1e-9, 4 * v / G + 1.0, 20001)
    values = np.array([gap(x) for x in taus])
    k = int(np.argmax(values[1:] < 0))
    tau = brentq(gap, taus[k], taus[k + 1], xtol=1e-15, rtol=1e-15)
    u = A * W * math.cos(W * (t + tau))
    return np.array([t + tau, u - e * (v - G * tau - u)])


def numeric_table_multipliers(e: float, Gamma: float, n: int):
    A = Gamma * G / W**2
    T = 2 * math.pi / W
    guess = bouncing.table_orbit(e, n, Gamma)
    x0 = np.array([guess["phi"] / W, G * n * T / 2])
    fixed = fsolve(lambda x: table_map(x, e, A) - x - np.array([n * T, 0.0]), x0,
                   xtol=1e-14)
    h = 1e-7
    D = np.column_stack([(table_map(fixed + h * d, e, A) - table_map(fixed - h * d, e, A))
                         / (2 * h) for d in np.eye(2)])
    return fixed, np.sort_complex(np.linalg.eigvals(D))


@pytest.mark.parametrize("e,Gamma,n", [(0.5, 1.3, 1), (0.5, 1.9, 1), (0.8, 0.5, 1),
                                       (0.5, 2.6, 2)])
def test_table_closed_form_against_numeric_map(e, Gamma, n):
    fixed, rho = numeric_table_multipliers(e, Gamma, n)
    closed = bouncing.table_orbit(e, n, Gamma)
    assert fixed[0] * W == pytest.approx(closed["phi"], abs=1e-7)
    assert np.max(np.abs(rho - np.sort_complex(closed["multipliers"]))) < 1e-5


def test_period_doubling_threshold():
    """At Gamma_pd one multiplier of the numeric map passes through -1."""
    e = 0.5
    pd = bouncing.period_doubling_threshold(e)
    below = numeric_table_multipliers(e, pd * 0.99, 1)[1]
    above = numeric_table_multipliers(e, pd * 1.01, 1)[1]
    assert np.min(below.real) > -1 > np.min(above.real)
    assert bouncing.existence_threshold(e, 2) == pytest.approx(2 * bouncing.existence_threshold(e))


def _scene(a: float, n: int = 1, **kw):
    return parse_scene(bouncing.bouncing_scene(e=0.5, a=a, W=W, n=n, **kw))


def test_stable_orbit_of_the_carrier():
    """Gamma_n < Gamma < Gamma_pd: the vertical modes decay with |rho| = e, the spin and
    tilt modes sit on the unit circle."""
    a = 0.07                                    # Gamma = 1.28 in (1.05, 1.53)
    b = bouncing.analyse(_scene(a))
    assert all(c["ok"] for c in b.checks().values()), b.checks()
    vert = np.abs(b.vertical_multipliers)
    assert np.allclose(vert, 0.5, atol=1e-9)    # a complex pair: |rho|^2 = det = e^2
    assert np.allclose(np.abs(b.other_multipliers), 1.0, atol=1e-8)
    assert b.verdict().startswith("linearly stable")


def test_unstable_orbit_beyond_period_doubling():
    b = bouncing.analyse(_scene(0.1))           # Gamma = 1.83 > 1.53
    assert all(c["ok"] for c in b.checks().values())
    assert np.min(b.vertical_multipliers.real) < -1
    assert b.verdict().startswith("unstable (vertical")


def test_two_period_orbit():
    b = bouncing.analyse(_scene(0.13, n=2), n=2)  # Gamma = 2.39 in (2.09, 2.61)
    assert all(c["ok"] for c in b.checks().values()), b.checks()
    assert b.period == pytest.approx(2 * 2 * math.pi / W)


def test_below_existence_and_wrong_structure_are_refused():
    doc = bouncing.bouncing_scene(e=0.5, a=0.07, W=W)
    doc["point"]["law"][2] = "0.03*sin(30*t)"   # Gamma = 0.55 < 1.05
    with pytest.raises(SceneError, match=r"\[point\].law\[2\].*existence threshold"):
        bouncing.analyse(parse_scene(doc))
    doc = bouncing.bouncing_scene(e=0.5, a=0.07, W=W, inertia=(0.1, 0.12, 0.15))
    with pytest.raises(SceneError, match=r"\[body\].inertia.*J_x = J_y"):
        bouncing.analyse(parse_scene(doc))
    doc = bouncing.bouncing_scene(e=0.5, a=0.07, W=W)
    doc["point"]["law"][2] = "0.07*cos(30*t)"
    doc["initial"]["com"][2] += 0.2
    with pytest.raises(SceneError, match=r"\[point\].law\[2\].*a\*sin\(W\*t\)"):
        bouncing.analyse(parse_scene(doc))


def test_a_scene_as_users_write_it_runs_the_vertical_model():
    """A scene that leaves [run].model and outputs to their defaults (the pose asked, so a
    plain run takes the general model) gets the same multipliers as the vertical scene;
    a scene that forces another model is refused with what to change."""
    doc = bouncing.bouncing_scene(e=0.5, a=0.07, W=W)
    ref = bouncing.analyse(parse_scene(doc))
    del doc["run"]["model"], doc["run"]["outputs"]
    plain = bouncing.analyse(parse_scene(doc))
    assert np.max(np.abs(np.sort_complex(plain.multipliers)
                         - np.sort_complex(ref.multipliers))) < 1e-12
    doc["run"]["model"] = "general"
    with pytest.raises(SceneError, match=r'\[run\].model.*set it to "vertical".*general'):
        bouncing.analyse(parse_scene(doc))


def test_carrier_doubles_period_at_the_table_threshold():
    """The runtime's orbit of the carrier loses stability through -1 where the closed
    form puts Gamma_pd (1.527 for e = 0.5), within 1 % on each side."""
    nu = 0.25 / 1.25
    pd = bouncing.period_doubling_threshold(0.5)
    rho = {}
    for factor in (0.99, 1.01):
        a = factor * pd * G / (nu * W * W)
        rho[factor] = bouncing.analyse(_scene(a)).vertical_multipliers.real
    assert -1 < np.min(rho[0.99]) < -0.9 and -1.1 < np.min(rho[1.01]) < -1
