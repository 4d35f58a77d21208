"""Closed-form solves of a symmetric positive definite 3x3 system, on its numeric entries.

One algorithm for every backend: it runs on SymPy symbols (producing the straight-line
steps of the generated C), on CasADi SX (the CasADi functions) and on floats (tests).
``assign(name, value)`` records an intermediate and returns what later steps use: a new
symbol for the C program, the value itself elsewhere.

    A = L D L^T,  L unit lower triangular,  D = diag(d0, d1, d2) > 0
    forward  L y = b;  scale  z = D^-1 y;  back  L^T x = z

Unrolled for 3x3: three reciprocals (one per pivot), 17 multiplications and 12
additions for the factors and one right-hand side; every further right-hand side shares
the factors.  (Computing the pivots from the leading principal minors instead makes the
three reciprocals independent, but costs ten more multiplications; measured on this
project's benchmark it was slower in both throughput and latency.)  No pivoting: A is
positive definite (R1 in paper_checks), so every pivot is positive.

Two alternatives, measured by ``derive bench rhs`` in a latency-bound loop (each call's
state depends on the last output, as in an integrator, while J depends on the point law
and the parameters only):

* ``adjugate``: the six cofactors of the symmetric matrix and one reciprocal of the
  determinant; each right-hand side is multiplied by the cofactors, then by the
  reciprocal (depth three from the right-hand side, against the seven of the forward
  and back substitution; with three or more right-hand sides the inverse's entries are
  formed once instead).  Scaling after the products rather than forming the inverse
  first measured 11% faster for lie_stage in the latency-bound loop (45.8 -> 40.8 ns at
  -O3 -march=native) and the same for the general flight RHS.  Numeric, not symbolic:
  the entries are numbers when it runs.
* ``cholesky``: A = L L^T with three square roots.

:data:`SOLVERS` names them; :data:`DEFAULT_SOLVER` is the one the emitted code uses.
"""
from __future__ import annotations

from typing import Callable, Sequence


def _identity(_name: str, value):
    return value


def ldlt3_factor(A: Sequence, assign: Callable[[str, object], object] = _identity) -> tuple:
    """The factors of ``A`` (lower triangle ``(a00, a10, a11, a20, a21, a22)``):
    ``(inv_d0, l10, l20, inv_d1, l21, inv_d2)``."""
    a00, a10, a11, a20, a21, a22 = A
    inv_d0 = assign("inv_d0", 1 / a00)
    l10 = assign("l10", a10 * inv_d0)
    l20 = assign("l20", a20 * inv_d0)
    d1 = assign("d1", a11 - l10 * a10)
    inv_d1 = assign("inv_d1", 1 / d1)
    c21 = assign("c21", a21 - l20 * a10)          # d1 * l21
    l21 = assign("l21", c21 * inv_d1)
    d2 = assign("d2", a22 - l20 * a20 - l21 * c21)
    inv_d2 = assign("inv_d2", 1 / d2)
    return inv_d0, l10, l20, inv_d1, l21, inv_d2


def ldlt3_apply(factors: Sequence, rhs: Sequence[Sequence],
                assign: Callable[[str, object], object] = _identity) -> list[list]:
    """Forward, scale and back substitution with the factors of :func:`ldlt3_factor`:
    one solution vector per right-hand side."""
    inv_d0, l10, l20, inv_d1, l21, inv_d2 = factors
    solutions = []
    for k, b in enumerate(rhs):
        y0 = b[0]
        y1 = assign(f"y1_{k}", b[1] - l10 * y0)
        y2 = assign(f"y2_{k}", b[2] - l20 * y0 - l21 * y1)
        x2 = assign(f"x2_{k}", y2 * inv_d2)
        x1 = assign(f"x1_{k}", y1 * inv_d1 - l21 * x2)
        x0 = assign(f"x0_{k}", y0 * inv_d0 - l10 * x1 - l20 * x2)
        solutions.append([x0, x1, x2])
    return solutions


def ldlt3_solve(A: Sequence, rhs: Sequence[Sequence],
                assign: Callable[[str, object], object] = _identity) -> list[list]:
    """``A``: lower triangle as ``(a00, a10, a11, a20, a21, a22)``; ``rhs``: vectors.

    Returns one solution vector per right-hand side.
    """
    return ldlt3_apply(ldlt3_factor(A, assign), rhs, assign)


def lower_triangle(matrix) -> tuple:
    """``(a00, a10, a11, a20, a21, a22)`` of a 3x3 matrix-like object."""
    return (matrix[0, 0], matrix[1, 0], matrix[1, 1], matrix[2, 0], matrix[2, 1],
            matrix[2, 2])


def adjugate3_factor(A: Sequence, assign: Callable[[str, object], object] = _identity) -> tuple:
    """The six cofactors of the symmetric ``A`` and one reciprocal of its determinant:
    ``(c00, c10, c20, c11, c21, c22, inv_det)`` (the inverse is the cofactors times
    ``inv_det``)."""
    a00, a10, a11, a20, a21, a22 = A
    c00 = assign("c00", a11 * a22 - a21 * a21)
    c10 = assign("c10", a20 * a21 - a10 * a22)
    c20 = assign("c20", a10 * a21 - a11 * a20)
    c11 = assign("c11", a00 * a22 - a20 * a20)
    c21 = assign("c21", a10 * a20 - a00 * a21)
    c22 = assign("c22", a00 * a11 - a10 * a10)
    inv_det = assign("inv_det", 1 / (a00 * c00 + a10 * c10 + a20 * c20))
    return c00, c10, c20, c11, c21, c22, inv_det


def adjugate3_apply(factors: Sequence, rhs: Sequence[Sequence],
                    assign: Callable[[str, object], object] = _identity) -> list[list]:
    """One or two right-hand sides: the cofactors times each, then one product with the
    reciprocal (whose latency overlaps the products: 3 multiplications per right-hand
    side).  More: the six entries of the inverse once, then products with it."""
    c00, c10, c20, c11, c21, c22, inv_det = factors
    if len(rhs) <= 2:
        return [[assign(f"x0_{k}", (c00 * b[0] + c10 * b[1] + c20 * b[2]) * inv_det),
                 assign(f"x1_{k}", (c10 * b[0] + c11 * b[1] + c21 * b[2]) * inv_det),
                 assign(f"x2_{k}", (c20 * b[0] + c21 * b[1] + c22 * b[2]) * inv_det)]
                for k, b in enumerate(rhs)]
    i00, i10, i20, i11, i21, i22 = (assign(name, c * inv_det) for name, c in (
        ("i00", c00), ("i10", c10), ("i20", c20), ("i11", c11), ("i21", c21), ("i22", c22)))
    return [[assign(f"x0_{k}", i00 * b[0] + i10 * b[1] + i20 * b[2]),
             assign(f"x1_{k}", i10 * b[0] + i11 * b[1] + i21 * b[2]),
             assign(f"x2_{k}", i20 * b[0] + i21 * b[1] + i22 * b[2])]
            for k, b in enumerate(rhs)]


def adjugate3_solve(A: Sequence, rhs: Sequence[Sequence],
                    assign: Callable[[str, object], object] = _identity) -> list[list]:
    return adjugate3_apply(adjugate3_factor(A, assign), rhs, assign)


def _sqrt(x):
    """sqrt of a SymPy expression, a float or a CasADi SX."""
    import math
    import sympy as sp
    if isinstance(x, sp.Basic):
        return sp.sqrt(x)
    try:
        return math.sqrt(x)
    except TypeError:
        import casadi as ca
        return ca.sqrt(x)


def cholesky3_factor(A: Sequence, assign: Callable[[str, object], object] = _identity) -> tuple:
    """``A = L L^T`` (three square roots, their reciprocals): ``(r0, l10, l20, r1, l21,
    r2)``."""
    a00, a10, a11, a20, a21, a22 = A
    r0 = assign("r0", 1 / _sqrt(a00))
    l10 = assign("l10", a10 * r0)
    l20 = assign("l20", a20 * r0)
    r1 = assign("r1", 1 / _sqrt(a11 - l10 * l10))
    l21 = assign("l21", (a21 - l20 * l10) * r1)
    r2 = assign("r2", 1 / _sqrt(a22 - l20 * l20 - l21 * l21))
    return r0, l10, l20, r1, l21, r2


def cholesky3_apply(factors: Sequence, rhs: Sequence[Sequence],
                    assign: Callable[[str, object], object] = _identity) -> list[list]:
    r0, l10, l20, r1, l21, r2 = factors
    solutions = []
    for k, b in enumerate(rhs):
        y0 = assign(f"y0_{k}", b[0] * r0)
        y1 = assign(f"y1_{k}", (b[1] - l10 * y0) * r1)
        y2 = assign(f"y2_{k}", (b[2] - l20 * y0 - l21 * y1) * r2)
        x2 = assign(f"x2_{k}", y2 * r2)
        x1 = assign(f"x1_{k}", (y1 - l21 * x2) * r1)
        x0 = assign(f"x0_{k}", (y0 - l10 * x1 - l20 * x2) * r0)
        solutions.append([x0, x1, x2])
    return solutions


def cholesky3_solve(A: Sequence, rhs: Sequence[Sequence],
                    assign: Callable[[str, object], object] = _identity) -> list[list]:
    return cholesky3_apply(cholesky3_factor(A, assign), rhs, assign)


def rank_one3_factor(S: Sequence, assign: Callable[[str, object], object] = _identity) -> tuple:
    """``A = diag(d) - a v^T`` (``a`` a multiple of ``v``) from ``S = (d0, d1, d2, a0, a1,
    a2, v0, v1, v2)`` (E1.5's J: the diagonal ``J_i + mu |OP|^2``, ``a = mu OP``, ``v =
    OP``), solved by Sherman and Morrison's formula with one division:

        A^-1 b = D^-1 b + D^-1 a (v^T D^-1 b) / (1 - v^T D^-1 a)

    With ``e_i = d_j d_k`` (the other two), ``P = d0 d1 d2`` and ``z = P D^-1 v =
    (e_i v_i)``, the determinant is ``det = P - a.z`` and ``A^-1 b = alpha o b + beta
    (z.b)`` with ``alpha_i = e_i det / (P det) = 1/d_i`` and ``beta_i = e_i a_i / (P
    det)``: one reciprocal, of ``P det``.  Returns ``(alpha0..2, beta0..2, z0..2)``."""
    d0, d1, d2, a0, a1, a2, v0, v1, v2 = S
    e = [assign("e0", d1 * d2), assign("e1", d0 * d2), assign("e2", d0 * d1)]
    big_p = assign("P", d0 * e[0])
    z = [assign(f"z{i}", ei * vi) for i, (ei, vi) in enumerate(zip(e, (v0, v1, v2)))]
    det = assign("det", big_p - (a0 * z[0] + a1 * z[1] + a2 * z[2]))
    inv = assign("inv", 1 / (big_p * det))
    scale = assign("det_inv", det * inv)
    alpha = [assign(f"alpha{i}", ei * scale) for i, ei in enumerate(e)]
    beta = [assign(f"beta{i}", ai * assign(f"e_inv{i}", ei * inv))
            for i, (ai, ei) in enumerate(zip((a0, a1, a2), e))]
    return (*alpha, *beta, *z)


def rank_one3_solve(S: Sequence, rhs: Sequence[Sequence],
                    assign: Callable[[str, object], object] = _identity) -> list[list]:
    return rank_one3_apply(rank_one3_factor(S, assign), rhs, assign)


def adjugate_rank_one3_solve(S: Sequence, rhs: Sequence[Sequence],
                             assign: Callable[[str, object], object] = _identity) -> list[list]:
    return adjugate3_apply(adjugate_rank_one3_factor(S, assign), rhs, assign)


def adjugate_rank_one3_factor(S: Sequence,
                              assign: Callable[[str, object], object] = _identity) -> tuple:
    """:func:`adjugate3_factor` of ``A = diag(d) - a v^T`` from ``S`` as in
    :func:`rank_one3_factor`: the entries ``d_i - a_i v_i`` and ``-a_i v_j``, and the
    cofactors off the diagonal as ``a_i v_j d_k`` (k the third index: the terms of
    second order in ``a`` cancel, so one product each, without that cancellation)."""
    d0, d1, d2, a0, a1, a2, v0, v1, v2 = S
    a00 = assign("a00", d0 - a0 * v0)
    a11 = assign("a11", d1 - a1 * v1)
    a22 = assign("a22", d2 - a2 * v2)
    p10 = assign("p10", a1 * v0)            # -a10
    p20 = assign("p20", a2 * v0)            # -a20
    p21 = assign("p21", a2 * v1)            # -a21
    c00 = assign("c00", a11 * a22 - p21 * p21)
    c11 = assign("c11", a00 * a22 - p20 * p20)
    c22 = assign("c22", a00 * a11 - p10 * p10)
    c10 = assign("c10", p10 * d2)
    c20 = assign("c20", p20 * d1)
    c21 = assign("c21", p21 * d0)
    inv_det = assign("inv_det", 1 / (a00 * c00 - p10 * c10 - p20 * c20))
    return c00, c10, c20, c11, c21, c22, inv_det


def rank_one3_apply(factors: Sequence, rhs: Sequence[Sequence],
                    assign: Callable[[str, object], object] = _identity) -> list[list]:
    """Per right-hand side ``b``: ``s = z.b`` (3 multiplications), then ``x_i = beta_i s +
    alpha_i b_i``."""
    alpha, beta, z = factors[0:3], factors[3:6], factors[6:9]
    solutions = []
    for k, b in enumerate(rhs):
        s = assign(f"s_{k}", z[0] * b[0] + z[1] * b[1] + z[2] * b[2])
        solutions.append([assign(f"x{i}_{k}", beta[i] * s + alpha[i] * b[i])
                          for i in range(3)])
    return solutions


# each solver as (factor, apply): a solve with the matrix of an earlier one reuses its
# factors (the derivatives of a solve's unknowns, derive.jacobians)
FACTORED = {"ldlt": (ldlt3_factor, ldlt3_apply),
            "adjugate": (adjugate3_factor, adjugate3_apply),
            "cholesky": (cholesky3_factor, cholesky3_apply),
            "rank1-sm": (rank_one3_factor, rank_one3_apply),
            "rank1-adjugate": (adjugate_rank_one3_factor, adjugate3_apply)}
SOLVERS = {"ldlt": ldlt3_solve, "adjugate": adjugate3_solve, "cholesky": cholesky3_solve,
           "rank1-sm": rank_one3_solve, "rank1-adjugate": adjugate_rank_one3_solve}
# solvers that read a solve's structure diag(d) - a v^T (LinearSolve.structure), not the
# matrix's entries; a solve without that structure takes FALLBACK_SOLVER instead
STRUCTURED = ("rank1-sm", "rank1-adjugate")
DEFAULT_SOLVER = "rank1-adjugate"
FALLBACK_SOLVER = "adjugate"


def solver_for(solve, requested: str | None = None) -> str:
    """The solver a :class:`~derive.models.LinearSolve` is emitted with: ``requested`` (or
    :data:`DEFAULT_SOLVER`), unless it needs a structure the solve does not have."""
    name = requested or DEFAULT_SOLVER
    if name in STRUCTURED and solve.structure is None:
        return FALLBACK_SOLVER
    return name


def solve_values(solve, solver: str) -> tuple:
    """What ``solver`` factors: the lower triangle of the matrix, or its structure."""
    return solve.structure if solver in STRUCTURED else lower_triangle(solve.matrix)
