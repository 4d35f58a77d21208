"""The controller's QP (templates/control/ctl_qp.h, and its NumPy statement
derive/control/qp.py) where its decisions sit within 2 % of their thresholds.

Each QP here is small and built so that one rule decides the answer, and each answer is
checked against its closed form (or qpOASES, through CasADi) in both routes, with the
same iterations in both (the NumPy route states the C's method step for step):

* a row missed at the unconstrained minimum by 0.98 and 1.02 of VIOLATION_TOL (either
  side): let be, or met exactly;
* an equality repeated with a miss of 0.98 and 1.02 of VIOLATION_TOL: implied, or
  infeasible;
* two normals whose w'w / v'v is 0.98 and 1.02 of DEPENDENT_TOL (an equality after an
  equality, an inequality after one): dependent (infeasible, the miss being 1e-6), or
  solved as the closed form says;
* two equalities at an angle below DEPENDENT_TOL and a bound that together leave no
  point: the drift of the skipped one past FINAL_TOL says infeasible, as the closed form;
* a partial step and a full one 2 % apart (the wrong one keeps a negative multiplier in
  the answer), and two active multipliers that reach zero 2 % apart (the wrong one costs
  iterations): the one that comes first is taken, against qpOASES.

Together about a second: one C build (cached by content), no controller set up.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from derive.control.qp import (CDenseQP, DEPENDENT_TOL, DenseQP, FINAL_TOL, INFEASIBLE,
                               SOLVED, VIOLATION_TOL)

INF = math.inf


@pytest.fixture(scope="module")
def solvers():
    """Both routes for each size used here (the C built once per size)."""
    made = {}

    def get(n, m):
        if (n, m) not in made:
            made[(n, m)] = (CDenseQP(n, m), DenseQP(n, m))
        return made[(n, m)]
    return get


def _both(solvers, H, g, A, lba, uba, lbx, ubx):
    """(x, status) of the C, after checking that the NumPy route agrees: the same status
    and iterations, x to rounding."""
    n, m = len(g), len(lba)
    c_qp, py_qp = solvers(n, m)
    qp = tuple(np.asarray(v, dtype=float) for v in (H, g, A, lba, uba, lbx, ubx))
    xc, sc, ic = c_qp.solve(*qp)
    xp, sp_, ip = py_qp.solve(*qp)
    assert (sc, ic) == (sp_, ip), ("C", sc, ic, "NumPy", sp_, ip)
    assert np.max(np.abs(xc - xp)) < 1e-12, (xc, xp)
    return xc, sc


@pytest.mark.parametrize("side", [1, -1])
@pytest.mark.parametrize("share", [0.98, 1.02])
def test_a_row_missed_by_the_violation_tolerance_is_met_and_one_within_it_let_be(
        solvers, side, share):
    """minimise |x|^2/2 + g'x over x0 >= 0.5 (side 1) or x0 <= 0.5 (side -1), the
    unconstrained x0 = 0.5 -+ share * VIOLATION_TOL: beyond the tolerance the row is made
    active (x0 = 0.5 exactly), within it x stays the unconstrained minimum."""
    miss = share * VIOLATION_TOL
    x_free = 0.5 - side * miss
    lba, uba = ([0.5], [INF]) if side > 0 else ([-INF], [0.5])
    x, status = _both(solvers, np.eye(2), [-x_free, 0.0], [[1.0, 0.0]], lba, uba,
                      [-INF, -INF], [INF, INF])
    assert status == SOLVED
    expected = 0.5 if share > 1.0 else x_free
    assert abs(x[0] - expected) < 1e-14 and x[1] == 0.0, (x[0] - 0.5, expected - 0.5)


@pytest.mark.parametrize("side", [1, -1])
@pytest.mark.parametrize("share", [0.98, 1.02])
def test_an_equality_repeated_with_a_miss_is_implied_within_the_tolerance_else_infeasible(
        solvers, side, share):
    """x0 = 0.5 twice, the second 0.5 + side * share * VIOLATION_TOL: its normal is the
    first's (w = 0), so it is implied when it misses by less than the tolerance (x0 =
    0.5), and the QP infeasible when by more."""
    b2 = 0.5 + side * share * VIOLATION_TOL
    x, status = _both(solvers, np.eye(2), [0.0, 0.0], [[1.0, 0.0], [1.0, 0.0]],
                      [0.5, b2], [0.5, b2], [-INF, -INF], [INF, INF])
    if share > 1.0:
        assert status == INFEASIBLE
    else:
        assert status == SOLVED and x[0] == 0.5 and x[1] == 0.0


def _angle(share):
    """delta with w'w / v'v = delta^2 / (1 + delta^2) = share * DEPENDENT_TOL for the
    normals (1, 0) and (1, delta) under H = I."""
    r = share * DEPENDENT_TOL
    return math.sqrt(r / (1.0 - r))


@pytest.mark.parametrize("equality", [True, False])
@pytest.mark.parametrize("share", [0.98, 1.02])
def test_a_normal_at_the_dependence_tolerance_is_dependent_below_and_solved_above(
        solvers, equality, share):
    """x0 = 0.5, then x0 + delta x1 = 0.5 + delta (an equality, or >= as an inequality)
    with w'w / v'v = share * DEPENDENT_TOL: above the tolerance the pair has the closed
    form x = (0.5, 1) (the least |x| with x1 >= 1); below it the second normal counts as
    the first's, and missing by delta (about 1e-6, beyond VIOLATION_TOL) the QP is
    infeasible."""
    d = _angle(share)
    assert d > 1e4 * VIOLATION_TOL
    b2 = 0.5 + d
    x, status = _both(solvers, np.eye(2), [0.0, 0.0], [[1.0, 0.0], [1.0, d]],
                      [0.5, b2], [0.5, b2 if equality else INF], [-INF, -INF], [INF, INF])
    if share < 1.0:
        assert status == INFEASIBLE
    else:
        assert status == SOLVED
        assert abs(x[0] - 0.5) < 1e-15 and abs(x[1] - 1.0) < 1e-9, x


def test_a_skipped_equality_that_drifts_past_the_final_tolerance_is_infeasible(solvers):
    """x0 = 0 and x0 + 5e-7 x1 = 0 (an angle below DEPENDENT_TOL: the second is taken as
    implied at the start, where it holds), then x1 >= 0.1: the equalities force x1 = 0,
    so there is no feasible point (the closed form); the active set leaves the second
    equality missed by 5e-8, past FINAL_TOL, and the answer is infeasible, not solved."""
    d = 5e-7
    assert d * d < DEPENDENT_TOL and FINAL_TOL < 0.1 * d < 10 * FINAL_TOL
    x, status = _both(solvers, np.eye(2), [0.0, 0.0], [[1.0, 0.0], [1.0, d]],
                      [0.0, 0.0], [0.0, 0.0], [-INF, 0.1], [INF, INF])
    assert status == INFEASIBLE
    assert x[1] == pytest.approx(0.1) and abs(x[0] + d * x[1]) > FINAL_TOL


def _qpoases(H, g, A, lba, uba, lbx, ubx):
    import casadi as ca
    n, m = len(g), len(lba)
    S = ca.conic("q", "qpoases", {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(m, n)},
                 {"printLevel": "none", "error_on_fail": False})
    sol = S(h=H, g=g, a=A, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
    assert S.stats()["success"]
    return np.array(sol["x"]).ravel()


@pytest.mark.parametrize("share", [0.98, 1.02])
def test_a_partial_step_and_a_full_step_two_percent_apart(solvers, share):
    """x0 >= 1 active (multiplier 1), then x0 + x1 >= 1 + share: the full step's length
    is share, the step at which x0 >= 1's multiplier reaches 0 is 1 (the row scaled by 0.1,
    which changes no answer, so that x0 >= 1 is the first added).  Below 1 the row is
    added with both active, x = (1, share); above it x0 >= 1 is dropped first and the
    answer is the row's projection (1 + share)/2 (1, 1).  Against the closed form and
    qpOASES."""
    k = 0.1                     # the row scaled: its miss (0.1 (1 + share)) after x0's (1)
    qp = (np.eye(2), np.zeros(2), np.array([[k, k]]), np.array([k * (1.0 + share)]),
          np.array([INF]), np.array([1.0, -INF]), np.array([INF, INF]))
    x, status = _both(solvers, *qp)
    assert status == SOLVED
    closed = np.array([1.0, share]) if share < 1.0 else np.full(2, (1.0 + share) / 2)
    assert np.max(np.abs(x - closed)) < 1e-14, (x, closed)
    assert np.max(np.abs(x - _qpoases(*qp))) < 1e-9


@pytest.mark.parametrize("case", ["later-first", "earlier-first"])
def test_of_two_multipliers_reaching_zero_two_percent_apart_the_first_is_dropped(
        solvers, case):
    """x0 >= 1 and x1 >= 0.98 active (added in that order, the larger miss first), then
    a . x >= beta with a = (a0, 1, 1), whose direction lowers their multipliers (1 and
    0.98) at rates a0 and 1 (the row scaled by 0.1: added after the bounds), and whose
    full step is past both zeros: the one reaching 0 first is dropped, in the NumPy
    route's iterations (dropping the other leaves this one a negative multiplier, which
    costs two more to undo).  a0 = 1: x1's, the later one
    (zeros at 0.98 and 1); a0 = 1.04: x0's, the earlier one (zeros at 0.9615 and 0.98).
    The answers' closed forms (the KKT conditions with the other bound active):
    x = (1, c, c), and x = (a0 lam, 0.98, lam); against qpOASES too."""
    if case == "later-first":
        a0, c = 1.0, 0.995
        closed = np.array([1.0, c, c])
    else:
        a0, lam = 1.04, 0.975
        closed = np.array([a0 * lam, 0.98, lam])
    a = 0.1 * np.array([a0, 1.0, 1.0])     # scaled: its miss (0.3) after the bounds'
    beta = float(a @ closed)
    qp = (np.eye(3), np.zeros(3), a[None, :], np.array([beta]), np.array([INF]),
          np.array([1.0, 0.98, -INF]), np.full(3, INF))
    x, status = _both(solvers, *qp)
    assert status == SOLVED
    assert np.max(np.abs(x - closed)) < 1e-14, (x, closed)
    assert np.max(np.abs(x - _qpoases(*qp))) < 1e-9
