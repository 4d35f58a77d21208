"""E1.7 in Euler's form with J as a diagonal minus a rank-one term (derive.momentum.
flight_dynamics_euler), the form the flight right-hand sides are emitted from: equal to
E1.7 as derived from the expanded E1.6 (flight_dynamics), symbolically; the system times
m + M likewise; and the emitted C against a 30-digit evaluation of E1.7 itself."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from derive import notation as nt
from derive.momentum import (MU_OP_V, flight_dynamics, flight_dynamics_euler,
                             flight_dynamics_euler_scaled)


def _residual(form) -> sp.Matrix:
    """``matrix omega' - forcing`` with the named quantities substituted."""
    return form.inline(form.matrix * nt.omega_dot - form.forcing)


def _differs_from_E1_7(residual: sp.Matrix, scale=1) -> bool:
    reference = flight_dynamics().residual * scale
    diff = (residual - reference).applyfunc(lambda e: sp.expand(nt.from_paper_notation(e)))
    return diff.applyfunc(sp.cancel) != sp.zeros(3, 1)


def test_euler_form_is_E1_7():
    """J omega' - F of the Euler form is E1.7's residual (from E1.6 expanded), identically
    in omega, omega', the law and the parameters."""
    assert not _differs_from_E1_7(_residual(flight_dynamics_euler()))


def test_euler_form_times_m_plus_M_is_E1_7_times_m_plus_M():
    assert not _differs_from_E1_7(_residual(flight_dynamics_euler_scaled()), nt.M + nt.m)


def test_the_matrix_is_a_diagonal_minus_a_rank_one_term():
    """The stated structure diag(J_i + mu |OP|^2) - mu OP OP^T is E1.5's J (the
    Jacobian of E1.7's residual by omega')."""
    form = flight_dynamics_euler()
    J = flight_dynamics().mass_matrix
    structured = sp.diag(*form.diagonal) - form.rank * form.vector * form.vector.T
    assert (form.inline(form.matrix) - J).applyfunc(sp.expand) == sp.zeros(3, 3)
    assert (structured - J).applyfunc(sp.expand) == sp.zeros(3, 3)


@pytest.mark.parametrize("mutation", ["euler_sign", "coriolis_factor", "spin_sign"])
def test_the_check_can_fail(mutation):
    """A wrong Euler form is caught: the carrier's term with the wrong sign, the factor 2
    of 2 mu OP.V_r dropped, or the sign of mu (OP.omega) omega x OP flipped."""
    form = flight_dynamics_euler()
    w = nt.omega
    F = form.forcing
    if mutation == "euler_sign":
        F = F + 2 * (-nt.skew(w) * sp.diag(nt.J_x, nt.J_y, nt.J_z) * w)
    elif mutation == "coriolis_factor":
        F = F + MU_OP_V / 2 * w
    else:
        F = F - 2 * nt.dot(nt.OP, w) * nt.cross(w, nt.mu * nt.OP)
    wrong = form.inline(form.matrix * nt.omega_dot - F)
    assert _differs_from_E1_7(wrong)


def test_emitted_flight_rhs_against_30_digits():
    """The committed general_flight_rhs (E1.7 in Euler form, times m + M, J solved as a
    diagonal minus a rank-one term) at 200 physical states against E1.7 from E1.6 at 30
    digits: within 48 units of 2^-53 of each output block's largest entry (position
    rates, omega', A'); `derive bench rhs` reports the same on 1000 states."""
    from derive.bench.rhs import _exact_flight_rhs, physical_inputs
    from derive.clib import load_generated
    rhs = load_generated()["general_flight_rhs"]
    states = physical_inputs(200)
    exact = _exact_flight_rhs(states)
    worst = 0.0
    for (q, u, p), ref in zip(states, exact):
        (got,) = rhs(q, u, p)
        for block in (slice(0, 6), slice(6, 9), slice(9, 18)):
            scale = np.max(np.abs(ref[block]))
            worst = max(worst, np.max(np.abs(got[block] - ref[block])) / scale / 2.0 ** -53)
    assert worst < 48, worst
