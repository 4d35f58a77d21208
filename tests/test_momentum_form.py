"""Issue 13: the momentum form of the flight (K constant in fixed axes, C on its
parabola, the attitude on SO(3)) is equivalent to E1.2, E1.7 and E1.8, symbolically and
at exact rational points in the style of paper_checks; the exponential chart of
derive/lie.py against matrix exponentials; the generated stage against an independent
NumPy formulation.
"""
from __future__ import annotations

import random

import numpy as np
import pytest
import scipy.linalg
import sympy as sp

from derive import lie
from derive import models as dm
from derive import notation as nt
from derive.emit.numpy_backend import compile_spec
from derive.momentum import (TAU, angular_momentum, centre_of_mass_motion,
                             flight_dynamics, flight_parabola, momentum_form)
from derive.kinematics import poisson_equations
from paper_checks.exact import assert_zero, random_point

LAW = (nt.x, nt.y, nt.z, nt.xd, nt.yd, nt.zd, nt.xdd, nt.ydd, nt.zdd)


def test_momentum_form_gives_E1_7_symbolically():
    """d/dt of ``J omega + own = A^T K`` (K fixed, A' = A skew(omega)) is E1.7: the
    forcing of the derived E1.7 equals the momentum form's, identically in omega and the
    law (the relation is then E1.4 itself, so a solution of one is one of the other)."""
    fd = flight_dynamics()
    mf = momentum_form()
    assert (fd.mass_matrix - mf.J).applyfunc(sp.expand) == sp.zeros(3, 3)
    assert_zero("E1.7 forcing - momentum form", fd.forcing - mf.omega_rate_rhs)


def _rational_rotation(rng) -> sp.Matrix:
    """A rotation with rational entries: the Cayley transform of a rational vector."""
    w = sp.Matrix([sp.Rational(rng.randint(-9, 9), rng.randint(1, 5)) for _ in range(3)])
    Wh = nt.skew(w)
    return (sp.eye(3) - Wh / 2).inv() * (sp.eye(3) + Wh / 2)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_momentum_form_along_E1_7_and_E1_8_at_rational_points(seed):
    """At an exact rational state: omega from E1.4 with a fixed K (the momentum form);
    omega' from E1.7 and A' from E1.8 (the classical form); then d/dt (A (J omega + own))
    vanishes exactly, i.e. the classical flow keeps K fixed and the two forms agree
    along solutions; and |K|^2 (E1.9) is |K_fixed|^2."""
    rng = random.Random(seed)
    am = angular_momentum()
    fd = flight_dynamics()
    point = random_point(set(LAW) | {nt.M, nt.m, nt.J_x, nt.J_y, nt.J_z}, rng)
    point = {k: v for k, v in point.items()}
    point[nt.mu] = point[nt.M] * point[nt.m] / (point[nt.M] + point[nt.m])
    A = _rational_rotation(rng)
    K = sp.Matrix([sp.Rational(rng.randint(-20, 20), rng.randint(1, 7)) for _ in range(3)])
    J = am.J.xreplace(point)
    own = am.own.xreplace(point)
    omega = J.LUsolve(A.T * K - own)                 # the momentum form
    wsub = dict(zip(nt.omega, omega))
    omega_dot = fd.mass_matrix.xreplace(point).LUsolve(fd.forcing.xreplace(point)
                                                       .xreplace(wsub))   # E1.7
    A_dot = poisson_equations().xreplace(dict(zip(nt.a, A))).xreplace(wsub)  # E1.8
    # d/dt of K_fixed = A K_body(omega, law) along the classical flow
    K_body = am.K
    rates = {**dict(zip(nt.omega, omega_dot))}
    chain = [(nt.x, nt.xd), (nt.y, nt.yd), (nt.z, nt.zd), (nt.xd, nt.xdd), (nt.yd, nt.ydd),
             (nt.zd, nt.zdd)]
    dK_body = sum((K_body.diff(w) * rates[w] for w in nt.omega), sp.zeros(3, 1)) + \
        sum((K_body.diff(s) * r for s, r in chain), sp.zeros(3, 1))
    at = {**point, **wsub}
    dK_fixed = A_dot * K_body.xreplace(at) + A * dK_body.xreplace(at).xreplace(point)
    assert dK_fixed.applyfunc(sp.nsimplify) == sp.zeros(3, 1)
    assert (A * K_body.xreplace(at) - K).applyfunc(sp.simplify) == sp.zeros(3, 1)
    assert sp.simplify((K_body.xreplace(at).T * K_body.xreplace(at))[0] - (K.T * K)[0]) == 0


def test_fixed_kinetic_moment_and_momentum_omega_invert_each_other():
    rng = np.random.default_rng(3)
    A = scipy.linalg.expm(hat(rng.normal(size=3)))
    w = rng.normal(size=3)
    u = rng.normal(size=9) * 0.3
    p = np.array([1.0, 0.3, 0.1, 0.12, 0.14, 9.81])
    K = compile_spec(dm.fixed_kinetic_moment())(A.ravel(), w, u, p)[0]
    back = compile_spec(dm.momentum_omega())(A.ravel(), K, u, p)[0]
    np.testing.assert_allclose(back, w, rtol=1e-13, atol=1e-14)


def test_flight_parabola_is_E1_2_integrated():
    pos, vel = flight_parabola()
    _, acc, _ = centre_of_mass_motion()
    assert (pos.diff(TAU) - vel).applyfunc(sp.expand) == sp.zeros(3, 1)
    assert (vel.diff(TAU) - acc).applyfunc(sp.expand) == sp.zeros(3, 1)
    assert pos.xreplace({TAU: 0}) == nt.R_C and vel.xreplace({TAU: 0}) == nt.V_C


# ---- the exponential chart ------------------------------------------------------------------
def hat(v) -> np.ndarray:
    """skew(v): hat(v) x = v x x."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def test_exponential_series_against_closed_forms():
    lie.check()


def _series(name):
    coeffs = [float(c) for c in getattr(lie.exponential_chart(), name)]
    return lambda s: sum(c * s ** j for j, c in enumerate(coeffs))


@pytest.mark.parametrize("theta", [1e-3, 0.3, 1.0, float(lie.THETA_MAX)])
def test_exponential_chart_against_expm(theta):
    """exp(W^) from the series against scipy's expm; the quaternion's matrix; and
    W' = dexpinv(W, omega) makes d/dt (A_n exp(W^)) = A skew(omega) (finite differences)."""
    rng = np.random.default_rng(int(theta * 1000))
    w = rng.normal(size=3)
    w *= theta / np.linalg.norm(w)
    fn = compile_spec(dm.exp_map())
    E, q = (np.asarray(v) for v in fn(w))
    expm = scipy.linalg.expm(hat(w))
    np.testing.assert_allclose(E.reshape(3, 3), expm, atol=2e-16 * 8)
    qw, qv = q[0], q[1:]
    Rq = (qw * qw - qv @ qv) * np.eye(3) + 2 * np.outer(qv, qv) + 2 * qw * hat(qv)
    np.testing.assert_allclose(Rq, expm, atol=1e-15 * 8)
    # dexpinv by finite differences of exp
    omega = rng.normal(size=3)
    a, c = _series("alpha"), _series("c")
    s = w @ w
    wd = omega + a(s) * np.cross(w, omega) + c(s) * np.cross(w, np.cross(w, omega))
    h = 1e-6
    Ep = scipy.linalg.expm(hat(w + h * wd))
    Em = scipy.linalg.expm(hat(w - h * wd))
    body_rate = expm.T @ (Ep - Em) / (2 * h)
    np.testing.assert_allclose(body_rate, hat(omega), atol=1e-8)


def test_lie_stage_against_an_independent_formulation():
    """The generated stage: K in body axes exp(-W^) k, omega from J omega = K - mu r x v
    with J built by hand (the body's J plus mu at P), and dexpinv."""
    rng = np.random.default_rng(7)
    stage = compile_spec(dm.lie_stage())
    M, m = 1.3, 0.4
    Jd = np.array([0.1, 0.12, 0.15])
    p = np.array([M, m, *Jd, 9.81])
    mu = M * m / (M + m)
    for _ in range(5):
        w = rng.normal(size=3) * 0.4
        k = rng.normal(size=3)
        u = rng.normal(size=9) * 0.3
        r, v = u[0:3], u[3:6]
        dW, omega = (np.asarray(x) for x in stage(w, k, u, p))
        R = scipy.linalg.expm(hat(w))
        kb = R.T @ k
        J = np.diag(Jd) + mu * ((r @ r) * np.eye(3) - np.outer(r, r))
        om = np.linalg.solve(J, kb - mu * np.cross(r, v))
        np.testing.assert_allclose(omega, om, rtol=1e-12, atol=1e-13)
        th = np.linalg.norm(w)
        c = (1 - th / 2 / np.tan(th / 2)) / th ** 2
        wd = om + 0.5 * np.cross(w, om) + c * np.cross(w, np.cross(w, om))
        np.testing.assert_allclose(dW, wd, rtol=1e-12, atol=1e-13)
