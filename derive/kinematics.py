"""Kinematics of the carrier: the relative derivative (E1.3's operator), Poisson's
equations (E1.8) and the position of the carrier's centre O (E1.8a).

The angular velocity is *defined* by the direction-cosine matrix: with ``A`` mapping body
components to fixed ones (``a_ij = cos(fixed i, body j)``), ``A^T dA/dt = skew(omega)``.
For a vector with body components ``b(t)`` the fixed components are ``A b``, so

    A^T d/dt (A b) = A^T A' b + A^T A b' = omega x b + b'          (A^T A = 1)

which is :func:`absolute_rate_in_body_axes`.  ``tests/test_kinematics.py`` checks this
operator against an explicit rotation built from Euler angles.
"""
from __future__ import annotations

from functools import lru_cache

import sympy as sp

from .notation import OP_t, a_t, cross, freeze, nu, omega_vec_t, t


def absolute_rate_in_body_axes(b_t: sp.Matrix) -> sp.Matrix:
    """Body components of the absolute time derivative of a vector given in body axes."""
    return b_t.diff(t) + cross(omega_vec_t, b_t)


@lru_cache(maxsize=None)
def poisson_equations() -> sp.Matrix:
    """E1.8: the 3x3 matrix of the rates ``a_ij'``.

    Row ``i`` of ``A`` holds the body components of the fixed unit vector of axis ``i``;
    that vector is constant in space, so its absolute rate vanishes.  Solving
    ``absolute_rate_in_body_axes(row_i) = 0`` for the rates gives the equations.
    """
    rates = sp.zeros(3, 3)
    for i in range(3):
        row_t = a_t[i, :].T
        rate_syms = sp.Matrix([sp.Derivative(a_t[i, j], t) for j in range(3)])
        condition = absolute_rate_in_body_axes(row_t)
        solution = sp.solve(list(condition), list(rate_syms), dict=True)[0]
        for j in range(3):
            rates[i, j] = freeze(solution[rate_syms[j]])
    return rates


@lru_cache(maxsize=None)
def carrier_centre_position():
    """E1.8a: ``O_aO`` in fixed axes from the definition of the centre of mass C.

    ``(m + M) O_aC = M O_aO + m O_aP`` and ``O_aP = O_aO + A OP`` give ``O_aO``.
    Returns ``(r_O, r_C, A, OP)`` with ``r_O`` expressed through the other three.
    """
    from .notation import M, m, a, OP, R_C
    r_O = sp.Matrix(sp.symbols("X_O Y_O Z_O", real=True))
    r_P = r_O + a * OP
    definition = (m + M) * R_C - (M * r_O + m * r_P)
    solution = sp.solve(list(definition), list(r_O), dict=True)[0]
    # group as O_aC + (offset): the offset is what the equation is about
    offset = sp.Matrix([sp.factor(sp.expand(solution[c] - R_C[k])) for k, c in enumerate(r_O)])
    return r_O, R_C + offset


def centre_of_mass_offset_t() -> sp.Matrix:
    """``OC = nu OP`` in body axes, as time functions, with ``nu = m/(m+M)`` (the
    definition of C; ``notation.MASS_FRACTION``)."""
    return nu * OP_t
