"""The base model's reference integrator (derive/base_reference.py) against closed forms
derived here, to 1e-9:

* 1-D stick–slip of a box whose point oscillates along x, ``x = A (sin W t + beta sin 2 W
  t)`` (an asymmetric law, so the box crawls), with static friction above kinetic: at rest
  while ``|m x''| <= mu_s (M + m) g``; sliding with ``sigma`` (the sign of -x'' where it
  starts), ``v(t) = -nu (x'(t) - x'(t1)) - sigma mu g (t - t1)`` (nu = m/(M+m)) and
  ``X(t) = X(t1) - nu (x(t) - x(t1) - x'(t1)(t - t1)) - sigma mu g (t - t1)^2/2``, until v
  = 0 (brentq on the closed form), then sticking or sliding back;
* a disc spinning down on its face under uniform pressure: friction's torque is (2/3) mu N
  R, so omega falls linearly and stops at ``J w0 / ((2/3) mu N R)``, having turned
  ``w0 t*/2``;
* Contensou's coupling on a uniform disc sliding and spinning at once: sliding and
  spinning stop at the same instant, with ``v/(R w)`` tending to the root ``eps*`` of
  ``f(eps)/eps = (M R^2/J) t(eps)`` (f, t: the friction's force and torque per mu N, mu N
  R at the ratio eps, computed here by SciPy's dblquad over the disc, apart from the
  integrator's own integrals); for the uniform disc (J = M R^2/2) eps* = 0.6530, the
  value Farkas, Bartels, Unger and Wolf (PRL 90, 248302, 2003) report (0.653).
"""
import math

import numpy as np
import pytest
from scipy.integrate import dblquad, solve_ivp
from scipy.optimize import brentq

from derive import base_reference as br
from derive import face as fc

G = 9.81


# ---- 1-D stick-slip ----------------------------------------------------------------------------
M, m, A, W, BETA, Z0 = 1.0, 0.4, 0.05, 12.0, 0.4, 0.02
MU_K, MU_S = 0.3, 0.35
NU = m / (M + m)


def x_law(t):
    s, c, s2, c2 = math.sin(W * t), math.cos(W * t), math.sin(2 * W * t), math.cos(2 * W * t)
    return (A * (s + BETA * s2), A * W * (c + 2 * BETA * c2), -A * W * W * (s + 4 * BETA * s2))


def point_law(t):
    x, xd, xdd = x_law(t)
    return np.array([x, 0.0, Z0]), np.array([xd, 0.0, 0.0]), np.array([xdd, 0.0, 0.0])


def closed_form_1d(t_end):
    """Events (t, kind) and X at each event, from the closed forms."""
    limit = MU_S * (M + m) * G

    def excess(t):                    # > 0 where the rest would need more than mu_s N
        return abs(m * x_law(t)[2]) - limit

    def first_root(f, a, b, step):
        t = a
        fa = f(a)
        while t < b:
            tb = min(t + step, b)
            fb = f(tb)
            if fa < 0 <= fb or fa > 0 >= fb:
                return brentq(f, t, tb, xtol=1e-15, rtol=1e-15)
            t, fa = tb, fb
        return None
    period = 2 * math.pi / W
    step = period / 4000
    events, X, t = [], 0.0, 0.0
    sliding = None                     # (t1, X1, sigma)
    while t < t_end:
        if sliding is None:
            if excess(t) < 0:          # stick until the rest needs more than mu_s N
                t1 = first_root(excess, t + 1e-12, t_end, step)
                if t1 is None:
                    break
                t = t1
                events.append((t, "slip"))
            sigma = 1.0 if -x_law(t)[2] > 0 else -1.0
            sliding = (t, X, sigma)
        t1, X1, sigma = sliding
        _, xd1, _ = x_law(t1)
        x1 = x_law(t1)[0]

        def v(tt, t1=t1, xd1=xd1, sigma=sigma):
            return -NU * (x_law(tt)[1] - xd1) - sigma * MU_K * G * (tt - t1)
        t2 = first_root(lambda tt: v(tt) * sigma, t1 + 1e-9, t_end, step)
        if t2 is None:
            break
        X = X1 - NU * (x_law(t2)[0] - x1 - xd1 * (t2 - t1)) - sigma * MU_K * G * (t2 - t1) ** 2 / 2
        t = t2
        if excess(t2) <= 0:
            events.append((t2, "stick"))
            sliding = None
        else:
            events.append((t2, "reversal"))
            sliding = (t2, X, -sigma)
        events[-1] = (*events[-1], X)
    return events


def test_a_box_crawls_by_stick_and_slip_as_the_closed_form_says():
    face = fc.face_on("box", (0.1, 0.06, 0.04), (0, 0, 0), (0, 0, 1))
    system = br.System(M=M, J=(0.01, 0.02, 0.025), face=face,
                       points=(br.Point(m, point_law),), mu=MU_K, mu_static=MU_S)
    t_end = 1.6
    run = br.Integrator(system).run(np.zeros(6), 0.0, t_end)
    closed = closed_form_1d(t_end)
    assert run.status == "done"
    got = [(t, k) for t, k in run.events]
    assert [k for _, k in got] == [e[1] for e in closed]
    assert len(got) >= 8 and {"stick", "slip"} <= {k for _, k in got}
    assert np.abs(np.array([t for t, _ in got]) - [e[0] for e in closed]).max() < 1e-9
    # X at each stop (stick or reversal)
    stops = [(e, y) for e, y in zip(closed, run.states) if len(e) == 3]
    assert np.abs(np.array([y[0] for _, y in stops]) - [e[2] for e, _ in stops]).max() < 1e-9
    # it crawls: forward 8.5 mm, back 8.0 mm, each period the same 0.478 mm net (+x)
    sticks = np.array([e[2] for e, _ in stops if e[1] == "stick"])
    per_period = sticks[2:] - sticks[:-2]
    assert len(per_period) >= 3 and np.ptp(per_period) < 1e-12
    assert abs(per_period[0] - 4.7774e-4) < 1e-7 and abs(sticks[0] - 8.5188e-3) < 1e-6


# ---- a disc spinning down ------------------------------------------------------------------
def test_a_disc_spins_down_linearly_and_stops_when_the_closed_form_says():
    R, L, Mb, mp, Jz, mu, w0 = 0.1, 0.03, 1.2, 0.3, 0.008, 0.4, 6.0
    face = fc.face_on("cylinder", (R, L), (0, 0, 0), (0, 0, 1))
    still = br.Point(mp, lambda t: (np.array([0.0, 0.0, 0.01]), np.zeros(3), np.zeros(3)))
    system = br.System(M=Mb, J=(0.006, 0.006, Jz), face=face, points=(still,), mu=mu)
    N = (Mb + mp) * G
    t_star = Jz * w0 / (2 / 3 * mu * N * R)
    run = br.Integrator(system).run([0, 0, 0, 0, 0, w0], 0.0, 2 * t_star,
                                    samples=[t_star / 2])
    assert run.status == "done"
    assert [k for _, k in run.events] == ["stick"]
    assert abs(run.events[0][0] - t_star) < 1e-9 * t_star
    half = run.samples[0]
    assert abs(half[6] - w0 / 2) < 1e-9 * w0                   # omega linear in t
    assert abs(half[3] - (w0 * t_star / 2 - w0 * t_star / 8)) < 1e-9
    end = run.samples[-1]
    assert abs(end[3] - w0 * t_star / 2) < 1e-9 and np.abs(end[1:3]).max() < 1e-12
    # the product rule integrates pure spin about a disc's centre exactly
    fr = fc.Friction(face, N, mu=mu, n=8, product=True)
    assert abs(fr((0.0, 0.0, w0))[0][2] + 2 / 3 * mu * N * R) < 1e-13 * mu * N * R


# ---- Contensou: a disc sliding and spinning ----------------------------------------------------
def _disc_force_torque(eps):
    """f, t: the friction force (along -v) per mu N and torque per mu N R of a uniform
    disc (R = 1) sliding at v = eps, spinning at w = 1, by dblquad in polar coordinates
    about the centre."""
    def unit(r, th):
        ux, uy = eps - r * math.sin(th), r * math.cos(th)
        n = math.hypot(ux, uy)
        return ux / n, uy / n

    def integral(fn):
        val, _ = dblquad(lambda r, th: fn(r, th) * r, 0, 2 * math.pi, 0, 1,
                         epsabs=1e-13, epsrel=1e-12)
        return val / math.pi
    f = integral(lambda r, th: unit(r, th)[0])
    t = integral(lambda r, th: r * math.cos(th) * unit(r, th)[1]
                 - r * math.sin(th) * unit(r, th)[0])
    return f, t


@pytest.mark.parametrize("J_ratio", [0.5])
def test_a_sliding_spinning_disc_stops_sliding_and_spinning_together(J_ratio):
    """J = J_ratio M R^2 (0.5: the uniform disc)."""
    R, mu = 0.1, 0.3
    face = fc.face_on("cylinder", (R, 0.02), (0, 0, 0), (0, 0, 1))
    Mb = 1.0
    system = br.System(M=Mb, J=(0.3, 0.3, J_ratio * Mb * R * R), face=face, mu=mu)
    kappa = 1.0 / J_ratio
    unit = fc.face_on("cylinder", (1.0, 0.02), (0, 0, 0), (0, 0, 1))

    def f_t(e):                      # derive/face.py's instant-centre rule (not the
        w_, _ = fc.centre_wrench(unit, 1.0, None, "uniform", 1.0, (e, 0.0, 1.0))
        return -w_[0], -w_[2]        # reference integrator's integrals)
    eps_star = brentq(lambda e: f_t(e)[0] / e - kappa * f_t(e)[1], 0.2, 2.0, xtol=1e-14)
    f, tq = _disc_force_torque(eps_star)        # dblquad: the same root, apart
    assert abs(f / eps_star - kappa * tq) < 1e-9
    if J_ratio == 0.5:
        assert abs(eps_star - 0.653) < 5e-4                   # Farkas et al. (2003)
    integ = br.Integrator(system)

    def slope(x, e):                 # d eps / d ln(R w) along the symmetric path
        f, tq = f_t(e[0])
        return [(f - e[0] * kappa * tq) / (kappa * tq)]
    for v0, w0 in ((0.5, 3.0),):
        run = integ.run([0, 0, 0, v0, 0, w0], 0.0, 5.0, samples=[])
        assert [k for _, k in run.events] == ["stick"], run.events
        # as the slip ends (|(v, R w)| at 1e-11 of sqrt(g R)) both still move, their ratio
        # on its way to eps* (slowly: eps - eps* ~ (R w)^lambda, lambda = 0.615)
        vx, vy, Rw = run.approaches[0]           # (face frame: v turns as the disc does)
        eps_end = math.hypot(vx, vy) / Rw
        assert Rw > 0 and abs(eps_end - eps_star) < 1e-3
        assert (eps_end - eps_star) * (v0 / (R * w0) - eps_star) > 0
        # the same ratio from the scalar law of eps along ln(R w), integrated apart
        x_end = math.log(integ.eps * Rw)
        sol = solve_ivp(slope, (math.log(R * w0), x_end), [v0 / (R * w0)], method="DOP853",
                        rtol=1e-12, atol=1e-14)
        assert abs(sol.y[0, -1] - eps_end) < 5e-8


# ---- the honest ends: lift-off, tipping, the face lifting at an edge ---------------------------
def test_lift_off_tipping_and_the_kern_come_at_their_closed_form_times():
    face = fc.face_on("box", (0.1, 0.06, 0.04), (0, 0, 0), (0, 0, 1))
    Mb, mp = 1.0, 0.5
    # a point bobbing vertically: N = (M + m) g + m z'' reaches 0 where sin(W t) = (M+m) g /
    # (m A W^2)
    Az, Wz = 0.05, 30.0

    def bob(t):
        s = math.sin(Wz * t)
        return (np.array([0.0, 0.0, Az * s]),
                np.array([0.0, 0.0, Az * Wz * math.cos(Wz * t)]),
                np.array([0.0, 0.0, -Az * Wz * Wz * s]))
    system = br.System(M=Mb, J=(0.01, 0.01, 0.01), face=face, points=(br.Point(mp, bob),),
                       mu=0.5)
    run = br.Integrator(system).run(np.zeros(6), 0.0, 1.0)
    t_lift = math.asin((Mb + mp) * G / (mp * Az * Wz * Wz)) / Wz
    assert run.status == "lift_off" and abs(run.events[-1][0] - t_lift) < 1e-9
    # a point walking out at a constant speed c: cp = m x/(M + m) below C reaches the edge
    # a at t = a (M + m)/(m c), and (linear pressure) the kern's a/3 at a third of that
    c = 0.2

    def walk(t):
        return np.array([c * t, 0.0, 0.0]), np.array([c, 0.0, 0.0]), np.zeros(3)
    for pressure, reach in (("uniform", 0.1), ("linear", 0.1 / 3)):
        system = br.System(M=Mb, J=(0.01, 0.01, 0.01), face=face,
                           points=(br.Point(mp, walk),), mu=0.5, pressure=pressure)
        run = br.Integrator(system).run(np.zeros(6), 0.0, 2.0)
        assert run.status == ("tipping" if pressure == "uniform" else "face_lifting")
        assert abs(run.events[-1][0] - reach * (Mb + mp) / (mp * c)) < 1e-9
