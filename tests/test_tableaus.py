"""The runtime's Butcher tableaus satisfy every order condition up to their order.

Order conditions from rooted trees: for t = [u_1, ..., u_m], g(t) = prod_k (A g(u_k))
(componentwise, g(leaf) = 1) and gamma(t) = |t| prod_k gamma(u_k); a method has order p
iff b . g(t) = 1/gamma(t) for every tree with |t| <= p.  A dense output b(s) of order q
satisfies b(s) . g(t) = s^|t| / gamma(t) for |t| <= q.  These are all 200 trees up to
order 8 for DOP853, and the conditions fail at order p + 1 (so the test can fail).
"""
from __future__ import annotations

from fractions import Fraction
from functools import lru_cache
from itertools import combinations_with_replacement

import numpy as np
import pytest

from derive.emit import tableaus as T


@lru_cache(maxsize=None)
def trees(order: int) -> tuple:
    """All rooted trees with ``order`` vertices, as sorted tuples of children."""
    if order == 1:
        return ((),)
    out = set()
    for parts in _partitions(order - 1):
        pools = [trees(p) for p in parts]
        for combo in _combos(parts, pools):
            out.add(tuple(sorted(combo)))
    return tuple(sorted(out))


def _partitions(n, largest=None):
    largest = largest or n
    if n == 0:
        yield ()
        return
    for k in range(min(n, largest), 0, -1):
        for rest in _partitions(n - k, k):
            yield (k,) + rest


def _combos(parts, pools):
    """Multisets of subtrees for a partition (equal sizes taken with replacement)."""
    groups = {}
    for p, pool in zip(parts, pools):
        groups.setdefault(p, [0, pool])[0] += 1
    result = [()]
    for size, (count, pool) in groups.items():
        result = [r + c for r in result
                  for c in combinations_with_replacement(pool, count)]
    return result


def size(t) -> int:
    return 1 + sum(size(u) for u in t)


def gamma(t) -> int:
    g = size(t)
    for u in t:
        g *= gamma(u)
    return g


def dense_matrix(rows, n):
    A = [[0] * n for _ in range(n)]
    for i, row in enumerate(rows):
        for j, v in row:
            A[i][j] = v
    return np.array(A, dtype=object)


def g_vector(t, A):
    n = A.shape[0]
    v = np.array([1] * n, dtype=object)
    for u in t:
        v = v * A.dot(g_vector(u, A))
    return v


def check_order(b, A, order, scale=lambda k: 1):
    """Largest defect of b . g(t) - scale(|t|)/gamma(t) over trees up to ``order``."""
    worst = 0
    for k in range(1, order + 1):
        for t in trees(k):
            defect = b.dot(g_vector(t, A)) - Fraction(1, gamma(t)) * scale(k)
            worst = max(worst, abs(float(defect)))
    return worst


def test_tree_counts():
    assert [len(trees(k)) for k in range(1, 9)] == [1, 1, 2, 4, 9, 20, 48, 115]


def test_rk4():
    A = dense_matrix(T.RK4_A, 4)
    b = np.array(T.RK4_B, dtype=object)
    assert check_order(b, A, 4) < 1e-15
    assert check_order(b, A, 5) > 1e-3


def test_dopri5_exact():
    A = dense_matrix(T.DOPRI5_A, 7)
    assert check_order(np.array(T.DOPRI5_B, dtype=object), A, 5) == 0
    assert check_order(np.array(T.DOPRI5_B, dtype=object), A, 6) > 1e-4
    assert check_order(np.array(T.DOPRI5_B_HAT, dtype=object), A, 4) == 0
    for i, row in enumerate(T.DOPRI5_A):      # row sums are the nodes
        assert sum((v for _, v in row), Fraction(0)) == T.DOPRI5_C[i]


def dopri5_dense_weights(s):
    """b(s) with y(t0 + s h) = y0 + h b(s) . k from the nested dense formula."""
    b = np.array(T.DOPRI5_B, dtype=object)
    e1 = np.array([1, 0, 0, 0, 0, 0, 0], dtype=object)     # f0 = k1
    e7 = np.array([0, 0, 0, 0, 0, 0, 1], dtype=object)     # f1 = k7 (first same as last)
    r1 = b
    r2 = e1 - r1
    r3 = r1 - e7 - r2
    r4 = np.array(T.DOPRI5_D, dtype=object)
    return s * (r1 + (1 - s) * (r2 + s * (r3 + (1 - s) * r4)))


@pytest.mark.parametrize("s", [Fraction(1, 7), Fraction(1, 2), Fraction(5, 6)])
def test_dopri5_dense_output_has_order_4(s):
    A = dense_matrix(T.DOPRI5_A, 7)
    b = dopri5_dense_weights(s)
    assert check_order(b, A, 4, scale=lambda k: s**k) < 1e-15
    assert check_order(b, A, 5, scale=lambda k: s**k) > 1e-6


def test_dop853_order_8_and_estimators():
    A = np.array([[0.0] * 16 for _ in range(16)])
    for i, row in enumerate(T.DOP853_A):
        for j, v in row:
            A[i, j] = v
    A12 = A[:12, :12]
    b = np.array(T.DOP853_B)
    assert check_order(b, A12, 8) < 1e-13
    assert check_order(b, A12, 9) > 1e-6
    np.testing.assert_allclose(A.sum(axis=1), T.DOP853_C, atol=1e-15)
    # the embedded estimators: b - e5 has order 5, b - e3 order 3 (stage 13 is f(y1))
    A13 = A[:13, :13]
    b13 = np.r_[b, 0.0]
    assert check_order(b13 - np.array(T.DOP853_E5), A13, 5) < 1e-13
    assert check_order(b13 - np.array(T.DOP853_E3), A13, 3) < 1e-13


@pytest.mark.parametrize("s", [0.15, 0.5, 0.9])
def test_dop853_dense_output_has_order_7(s):
    A = np.array([[0.0] * 16 for _ in range(16)])
    for i, row in enumerate(T.DOP853_A):
        for j, v in row:
            A[i, j] = v
    b = np.r_[np.array(T.DOP853_B), np.zeros(4)]
    e1 = np.eye(16)[0]
    e13 = np.eye(16)[12]
    F0 = b
    F1 = e1 - F0
    F2 = 2 * F0 - (e1 + e13)
    D = [np.array(row) for row in T.DOP853_D]
    weights = s * (F0 + (1 - s) * (F1 + s * (F2 + (1 - s) * (D[0] + s * (D[1] + (1 - s)
                   * (D[2] + s * D[3]))))))
    assert check_order(weights, A, 7, scale=lambda k: s**k) < 1e-12
    assert check_order(weights, A, 8, scale=lambda k: s**k) > 1e-8
