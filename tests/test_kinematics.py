"""The relative-derivative operator and the surfaces, against independent constructions."""
from __future__ import annotations

import numpy as np
import sympy as sp
from scipy.optimize import minimize

from derive import notation as nt
from derive.kinematics import absolute_rate_in_body_axes, poisson_equations
from derive.momentum import flight_dynamics, flight_dynamics_structured
from derive.surfaces import center, ellipsoid, radius, semi_axes, sphere


def test_relative_derivative_against_explicit_rotation():
    """A(t) = Rz(psi) Rx(theta) Rz(phi) with arbitrary angle functions: omega from its
    definition A^T A' = skew(omega); then A^T d/dt(A b) equals the operator, and A'
    equals the derived Poisson right-hand sides."""
    t = nt.t
    angles = [sp.Function(n)(t) for n in ("psi", "theta", "phi")]
    cs = sp.symbols("c1:4", real=True)
    sn = sp.symbols("s1:4", real=True)
    rates = sp.symbols("r1:4", real=True)
    b = sp.Matrix([sp.Function(f"b{k}")(t) for k in range(3)])
    bs, bds = sp.symbols("b1:4", real=True), sp.symbols("bd1:4", real=True)

    def Rz(a):
        return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])

    def Rx(a):
        return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])

    def polynomial(expr):
        """sin, cos and angle rates as symbols; zero-tested modulo s^2 + c^2 = 1."""
        table = {sp.Derivative(a, t): r for a, r in zip(angles, rates)}
        table.update({sp.Derivative(f, t): v for f, v in zip(b, bds)})
        table.update(dict(zip(b, bs)))
        table.update({sp.cos(a): c for a, c in zip(angles, cs)})
        table.update({sp.sin(a): s_ for a, s_ in zip(angles, sn)})
        return sp.expand(expr.xreplace(table))

    circle = [s_**2 + c**2 - 1 for s_, c in zip(sn, cs)]

    def is_zero(expr):
        p = polynomial(expr)
        if p == 0:
            return True
        gens = sorted(p.free_symbols, key=sp.default_sort_key)
        return sp.reduced(p, circle, *gens, order="lex")[1] == 0

    A = Rz(angles[0]) * Rx(angles[1]) * Rz(angles[2])
    Om = A.T * A.diff(t)
    omega = sp.Matrix([Om[2, 1], Om[0, 2], Om[1, 0]])
    lhs = A.T * (A * b).diff(t)
    operator = absolute_rate_in_body_axes(b).xreplace(dict(zip(nt.omega_t, omega)))
    assert all(is_zero(v) for v in lhs - operator)
    poisson = poisson_equations().xreplace(
        {**{nt.a[i, j]: A[i, j] for i in range(3) for j in range(3)},
         **dict(zip(nt.omega, omega))})
    assert all(is_zero(v) for v in A.diff(t) - poisson)
    # the test can fail: a wrong sign in the operator is caught
    wrong = (b.diff(t) - nt.cross(nt.omega_vec_t, b)).xreplace(dict(zip(nt.omega_t, omega)))
    assert not all(is_zero(v) for v in lhs - wrong)


def test_structured_flight_equals_expanded():
    a, b = flight_dynamics(), flight_dynamics_structured()
    assert (a.residual - b.residual).applyfunc(sp.expand) == sp.zeros(3, 1)


def _brute_lowest(nv, c, axes):
    """Minimise n . (c + D u(angles)) over the ellipsoid by a numerical optimiser."""
    def height(ang):
        u = np.array([np.sin(ang[0]) * np.cos(ang[1]), np.sin(ang[0]) * np.sin(ang[1]),
                      np.cos(ang[0])])
        return nv @ (c + axes * u)
    best = min((minimize(height, x0, method="Nelder-Mead",
                         options={"xatol": 1e-13, "fatol": 1e-15, "maxiter": 4000})
                for x0 in ([0.3, 0.2], [2.8, 1.0], [1.5, -2.0], [1.2, 3.0])),
               key=lambda r: r.fun)
    return best.fun


def test_lowest_point_is_the_minimum_of_the_height():
    rng = np.random.default_rng(5)
    ell = sp.lambdify([nt.n, center, semi_axes], ellipsoid().point)
    sph = sp.lambdify([nt.n, center, radius], sphere().point)
    for _ in range(20):
        nv = rng.normal(size=3)
        nv /= np.linalg.norm(nv)
        c = rng.uniform(-0.5, 0.5, 3)
        axes = rng.uniform(0.2, 1.0, 3)
        s = np.ravel(ell(nv, c, axes))
        assert abs(np.sum(((s - c) / axes) ** 2) - 1) < 1e-12       # on the surface
        assert abs(nv @ s - _brute_lowest(nv, c, axes)) < 1e-9       # and lowest
        R = axes[0]
        s = np.ravel(sph(nv, c, R))
        assert abs(nv @ s - _brute_lowest(nv, c, np.full(3, R))) < 1e-9


def test_lowest_point_rate_by_finite_differences():
    """ds/dt along Poisson's equations, against a central difference of s(n(t))."""
    rng = np.random.default_rng(6)
    E = ellipsoid()
    s_fn = sp.lambdify([nt.n, center, semi_axes], E.point)
    rate_fn = sp.lambdify([nt.n, nt.omega, center, semi_axes], E.rate)
    for _ in range(10):
        nv = rng.normal(size=3)
        nv /= np.linalg.norm(nv)
        w = rng.normal(size=3)
        c, axes = rng.uniform(-0.5, 0.5, 3), rng.uniform(0.2, 1.0, 3)
        h = 1e-6
        # n' = n x omega (Poisson, row 3); exact rotation of n over +-h for the difference
        def n_at(tau):
            k = w / np.linalg.norm(w)
            ang = -np.linalg.norm(w) * tau      # n rotates by -omega in body axes
            return (nv * np.cos(ang) + np.cross(k, nv) * np.sin(ang)
                    + k * (k @ nv) * (1 - np.cos(ang)))
        fd = (np.ravel(s_fn(n_at(h), c, axes)) - np.ravel(s_fn(n_at(-h), c, axes))) / (2 * h)
        np.testing.assert_allclose(np.ravel(rate_fn(nv, w, c, axes)), fd, rtol=1e-6, atol=1e-8)
