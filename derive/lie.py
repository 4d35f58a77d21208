"""Local coordinates on the rotation group for the attitude: the Cayley map and the
inverse of its differential, derived from their definitions.

A Lie-group integrator (Runge–Kutta–Munthe-Kaas; Hairer, Lubich & Wanner, *Geometric
Numerical Integration*, IV.8) writes the attitude over one step as

    A(t) = A_n cay(W(t)),   W(t_n) = 0,

with ``W`` in R^3 (the Lie algebra so(3) through the hat map ``W -> skew(W)``), and
integrates an ordinary differential equation for ``W`` with any Runge–Kutta method:
whatever ``W`` the method produces, ``A`` is a rotation, to rounding.

* ``cay(W) = (1 - skew(W)/2)^-1 (1 + skew(W)/2)`` (the definition); solved here in the
  form ``1 + s (skew(W) + skew(W)^2/2)``, ``s = 4/(4 + |W|^2)`` (one division), by
  matching the two coefficients against the definition.
* Poisson's equations (E1.8) say ``A' = A skew(omega)`` (row i of A is the fixed axis i in
  body axes, constant in space).  With ``A = A_n cay(W)`` this is
  ``skew(omega) = cay(W)^T d/dt cay(W)``, linear in ``W'``: ``omega = D(W) W'``.  Its
  inverse ``W' = dcayinv(W, omega)`` is a polynomial, ``omega + a W x omega +
  b (W . omega) W``, with ``a``, ``b`` found by matching ``D(W) dcayinv = omega``.
* In quaternions (for the session's attitude), ``cay(W)`` is the rotation of the
  quaternion ``(2, W)/|(2, W)|``: checked here against the matrix.

Nothing here is specific to the carrier; :mod:`derive.momentum` supplies omega.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp

from .notation import skew

W = sp.Matrix(sp.symbols("W_x W_y W_z", real=True))          # Cayley coordinates
W_dot = sp.Matrix(sp.symbols("W_x' W_y' W_z'", real=True))
CAYLEY_SCALE = sp.Symbol("s_W", positive=True)                # 4/(4 + |W|^2)


def vee(m: sp.Matrix) -> sp.Matrix:
    """Inverse of the hat map for a skew-symmetric matrix."""
    return sp.Matrix([m[2, 1], m[0, 2], m[1, 0]])


def quaternion_matrix(q) -> sp.Matrix:
    """The rotation of a unit quaternion ``(w, x, y, z)`` (Hamilton's product, so that
    ``R(p q) = R(p) R(q)``)."""
    w, x, y, z = q
    return sp.Matrix([
        [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]])


@dataclass(frozen=True)
class Cayley:
    matrix: sp.Matrix         # cay(W) in the one-division form, with CAYLEY_SCALE
    scale: sp.Expr            # the value of CAYLEY_SCALE
    definition: sp.Matrix     # (1 - W^/2)^-1 (1 + W^/2), rational in W
    differential: sp.Matrix   # D(W): omega = D(W) W'
    inverse_differential: sp.Matrix   # dcayinv(W, omega) for omega = OMEGA
    omega: sp.Matrix          # the symbols omega stands for in inverse_differential


OMEGA = sp.Matrix(sp.symbols("Omega_x Omega_y Omega_z", real=True))


@lru_cache(maxsize=None)
def cayley() -> Cayley:
    Wh = skew(W)
    eye = sp.eye(3)
    definition = ((eye - Wh / 2).inv() * (eye + Wh / 2)).applyfunc(sp.factor)
    scale = 4 / (4 + (W.T * W)[0])
    # the form 1 + alpha W^ + beta W^2: two unknown scalars matched on two entries
    alpha, beta = sp.symbols("alpha beta")
    ansatz = eye + alpha * Wh + beta * Wh * Wh
    sol = sp.solve([sp.together(ansatz[0, 1] - definition[0, 1]),
                    sp.together(ansatz[0, 0] - definition[0, 0])], [alpha, beta], dict=True)[0]
    form = eye + sp.factor(sol[alpha]) * Wh + sp.factor(sol[beta]) * Wh * Wh
    if (form - definition).applyfunc(sp.cancel) != sp.zeros(3, 3):
        raise AssertionError("the one-division form of cay(W) differs from its definition")
    a_s, b_s = sp.cancel(sol[alpha] / scale), sp.cancel(sol[beta] / scale)
    if a_s.free_symbols or b_s.free_symbols:
        raise AssertionError("cay(W) is not 1 + s (a W^ + b W^2) with s = 4/(4 + |W|^2)")
    matrix = eye + CAYLEY_SCALE * (a_s * Wh + b_s * Wh * Wh)
    # D(W): cay^T d/dt cay = skew(D W'), differentiated through the rational form
    dcay_dt = sum((definition.diff(W[k]) * W_dot[k] for k in range(3)), sp.zeros(3, 3))
    body_rate = (definition.T * dcay_dt).applyfunc(sp.cancel)
    if (body_rate + body_rate.T).applyfunc(sp.cancel) != sp.zeros(3, 3):
        raise AssertionError("cay(W)^T d/dt cay(W) is not skew-symmetric")
    D = vee(body_rate).jacobian(W_dot).applyfunc(sp.factor)
    # its inverse as omega + a W x omega + b (W . omega) W, matched against D
    a, b = sp.symbols("a b")
    cand = OMEGA + a * skew(W) * OMEGA + b * (W.T * OMEGA)[0] * W
    residual = (D * cand - OMEGA).applyfunc(lambda e: sp.numer(sp.together(e)).expand())
    equations = []
    for e in residual:
        equations += sp.Poly(e, *W, *OMEGA).coeffs()
    ab = sp.solve(equations, [a, b], dict=True)
    if len(ab) != 1:
        raise AssertionError("dcayinv is not of the form omega + a W x omega + b (W.omega) W")
    inverse = cand.xreplace(ab[0])
    return Cayley(matrix=matrix, scale=scale, definition=definition, differential=D,
                  inverse_differential=inverse, omega=OMEGA)


def cayley_quaternion(w) -> tuple:
    """The unit quaternion of ``cay(W)``: ``(2, W)/|(2, W)|``."""
    norm = sp.sqrt(4 + sum(c * c for c in w))
    return (2 / norm, w[0] / norm, w[1] / norm, w[2] / norm)


def check_quaternion_form() -> None:
    """``quaternion_matrix(cayley_quaternion(W)) == cay(W)`` (raises otherwise)."""
    c = cayley()
    R = quaternion_matrix(cayley_quaternion(list(W)))
    if (R - c.definition).applyfunc(sp.cancel) != sp.zeros(3, 3):
        raise AssertionError("the quaternion (2, W)/|(2, W)| is not cay(W)")
