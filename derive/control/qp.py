"""The re-planner's QP, solved by the dual active-set method of Goldfarb and Idnani.

This is the NumPy statement of the solver in ``templates/control/ctl_qp.h``, step for
step (the Python route of the controller runs it; the C controller runs the C): the
same iterations, the same choices, the same arithmetic up to the order of sums, so that
the two routes return the same law to rounding.

The problem (dense, n variables, m rows)::

    minimise 1/2 x' H x + g' x   subject to   lba <= A x <= uba,   lbx <= x <= ubx

with H symmetric positive definite (the caller regularises it) and equality rows where
lba = uba.  The method (D. Goldfarb and A. Idnani, "A numerically stable dual method for
solving strictly convex quadratic programs", Math. Programming 27, 1983) starts at the
unconstrained minimum -H^-1 g, which is dual feasible, adds the equalities, then adds
the most violated inequality at a time, dropping an active one whenever its multiplier
would turn negative, until no constraint is violated: every iterate is the optimum of a
sub-problem, so it needs no feasible start and no phase one.  Written here with a
Cholesky factor H = L L' and the Schur complement S = N' H^-1 N of the active normals N
(S = R' R, R upper triangular, extended by one column when a constraint is added and
factored again when one is dropped), which is simpler than the paper's QR updates and as
accurate at these sizes (n about 100, at most a few tens active).

Statuses: 0 solved, 1 infeasible (a violated constraint that no step can satisfy),
2 the iteration limit, 3 H not positive definite.
"""
from __future__ import annotations

import math

import numpy as np

SOLVED, INFEASIBLE, MAX_ITER, NOT_CONVEX = 0, 1, 2, 3
STATUS = ("solved", "infeasible", "iteration limit", "H not positive definite")
VIOLATION_TOL = 1e-11        # a constraint counts as violated below -tol (its own units)
DEPENDENT_TOL = 1e-12        # |w|^2 <= tol |v|^2: the new normal depends on the active ones
FINAL_TOL = 1e-8             # the answer's constraints hold to this, else it is infeasible


def _chol(H: np.ndarray):
    """Lower L with H = L L' (column by column, as the C), or None."""
    n = H.shape[0]
    L = np.zeros_like(H)
    for j in range(n):
        d = H[j, j] - L[j, :j] @ L[j, :j]
        if not d > 0.0:
            return None
        L[j, j] = math.sqrt(d)
        L[j + 1:, j] = (H[j + 1:, j] - L[j + 1:, :j] @ L[j, :j]) / L[j, j]
    return L


def _forward(L, b):
    """Solve L y = b (L lower)."""
    y = np.array(b, dtype=float)
    for i in range(len(y)):
        y[i] = (y[i] - L[i, :i] @ y[:i]) / L[i, i]
    return y


def _backward_t(L, b):
    """Solve L' y = b (L lower)."""
    y = np.array(b, dtype=float)
    for i in range(len(y) - 1, -1, -1):
        y[i] = (y[i] - L[i + 1:, i] @ y[i + 1:]) / L[i, i]
    return y


def _holds(A, x, lba, uba, lbx, ubx) -> bool:
    """Every constraint within FINAL_TOL (a last check: an active set made of nearly
    dependent normals can drift)."""
    ax = A @ x
    return bool(np.all(ax >= lba - FINAL_TOL) and np.all(ax <= uba + FINAL_TOL)
                and np.all(x >= lbx - FINAL_TOL) and np.all(x <= ubx + FINAL_TOL))


class DenseQP:
    """A solver for one size (n, m); ``solve`` returns (x, status, iterations)."""

    def __init__(self, n: int, m: int, max_iter: int | None = None):
        self.n, self.m = n, m
        self.max_iter = max_iter or 4 * (n + m) + 20

    def solve(self, H, g, A, lba, uba, lbx, ubx):
        n, m = self.n, self.m
        H = np.asarray(H, dtype=float)
        A = np.asarray(A, dtype=float).reshape(m, n)
        L = _chol(H)
        if L is None:
            return np.zeros(n), NOT_CONVEX, 0
        x = -_backward_t(L, _forward(L, g))
        V = np.zeros((n, 0))               # L^-1 of the active normals
        R = np.zeros((0, 0))               # S = R' R
        act: list = []                     # (constraint, side, equality)
        u = np.zeros(0)

        def normal(i, side):
            row = A[i] if i < m else np.eye(n)[i - m]
            return side * row

        def slack(i, side):
            """side +1: a x - lb; side -1: ub - a x (positive when satisfied)."""
            ax = A[i] @ x if i < m else x[i - m]
            lo, hi = (lba[i], uba[i]) if i < m else (lbx[i - m], ubx[i - m])
            return ax - lo if side > 0 else hi - ax

        def directions(npv):
            v = _forward(L, npv)
            k = V.shape[1]
            s = np.zeros(k)
            Vv = V.T @ v
            for i in range(k):               # R' s = V' v
                s[i] = (Vv[i] - R[:i, i] @ s[:i]) / R[i, i]
            r = np.zeros(k)
            for i in range(k - 1, -1, -1):   # R r = s
                r[i] = (s[i] - R[i, i + 1:] @ r[i + 1:]) / R[i, i]
            wv = v - V @ r
            return v, s, r, wv, float(wv @ wv), float(v @ v)

        def add(i, side, eq, v, s, d2):
            nonlocal V, R, u
            k = V.shape[1]
            V = np.column_stack([V, v])
            R2 = np.zeros((k + 1, k + 1))
            R2[:k, :k] = R
            R2[:k, k] = s
            R2[k, k] = math.sqrt(d2)
            R = R2
            act.append((i, side, eq))

        def drop(j):
            nonlocal V, R, u
            keep = [k for k in range(len(act)) if k != j]
            del act[j]
            V = V[:, keep]
            u = u[keep]
            L2 = _chol(V.T @ V) if V.shape[1] else np.zeros((0, 0))
            if L2 is None:
                return False
            R = L2.T
            return True

        it = 0
        # the equalities first: each added with its full step (their multipliers are free)
        for i in range(m + n):
            lo, hi = (lba[i], uba[i]) if i < m else (lbx[i - m], ubx[i - m])
            if lo != hi:
                continue
            side = 1.0 if slack(i, 1.0) <= 0.0 else -1.0
            npv = normal(i, side)
            v, s, r, wv, d2, vv = directions(npv)
            sp = slack(i, side)
            if d2 <= DEPENDENT_TOL * vv:
                if sp < -VIOLATION_TOL:
                    return x, INFEASIBLE, it
                continue                     # implied by the others
            t = -sp / d2
            z = _backward_t(L, wv)
            x = x + t * z
            u = np.r_[u - t * r, t]
            add(i, side, True, v, s, d2)
            it += 1
        # then the inequalities, the most violated first
        while True:
            worst, p, p_side = -VIOLATION_TOL, -1, 0.0
            active = {a[0] for a in act}
            for i in range(m + n):
                if i in active:
                    continue
                lo, hi = (lba[i], uba[i]) if i < m else (lbx[i - m], ubx[i - m])
                if lo == hi:
                    continue
                for side, bound in ((1.0, lo), (-1.0, hi)):
                    if not math.isfinite(bound):
                        continue
                    sv = slack(i, side)
                    if sv < worst:
                        worst, p, p_side = sv, i, side
            if p < 0:
                return x, (SOLVED if _holds(A, x, lba, uba, lbx, ubx) else INFEASIBLE), it
            up = 0.0
            npv = normal(p, p_side)
            while True:
                it += 1
                if it > self.max_iter:
                    return x, MAX_ITER, it
                v, s, r, wv, d2, vv = directions(npv)
                # the partial step: the first active inequality whose multiplier reaches 0
                t1, k1 = math.inf, -1
                for j, (_, _, eq) in enumerate(act):
                    if not eq and r[j] > 0.0:
                        tj = u[j] / r[j]
                        if tj < t1:
                            t1, k1 = tj, j
                dependent = d2 <= DEPENDENT_TOL * vv
                t2 = math.inf if dependent else -slack(p, p_side) / d2
                t = min(t1, t2)
                if not math.isfinite(t):
                    return x, INFEASIBLE, it
                if not dependent:
                    x = x + t * _backward_t(L, wv)
                u = u - t * r
                up += t
                if t == t2:
                    u = np.r_[u, up]
                    add(p, p_side, False, v, s, d2)
                    break
                if not drop(k1):
                    return x, NOT_CONVEX, it


class CDenseQP:
    """The C solver (``templates/control/ctl_qp.h``) for one size, compiled with the
    runtime's flags and loaded: ``solve`` as :meth:`DenseQP.solve` (for the checks and
    ``derive bench control``; the controller includes the header itself)."""

    def __init__(self, n: int, m: int, max_iter: int | None = None):
        import ctypes
        from ..cbuild import build_shared, runtime_flags
        from ..paths import c_sources
        self.n, self.m = n, m
        self.max_iter = max_iter or 4 * (n + m) + 20
        shim = (f"#define CTL_QP_N {n}\n#define CTL_QP_M {m}\n#include \"ctl_qp.h\"\n"
                "int ctl_qp_shim(ctl_qp *q, const double *H, const double *g, "
                "const double *A, const double *lba, const double *uba, const double *lbx, "
                "const double *ubx, double *x, int max_iter, int *iterations)\n{\n"
                "  const int r = ctl_qp_solve(q, H, g, A, lba, uba, lbx, ubx, x, max_iter);\n"
                "  *iterations = q->iterations;\n  return r;\n}\n"
                "int ctl_qp_shim_size(void) { return (int)sizeof(ctl_qp); }\n")
        header = (c_sources("control") / "ctl_qp.h").read_text(encoding="utf-8")
        path = build_shared({"shim.c": shim, "ctl_qp.h": header}, flags=runtime_flags(),
                            name="qpshim")
        self.lib = ctypes.CDLL(str(path))
        self.mem = ctypes.create_string_buffer(self.lib.ctl_qp_shim_size() + 64)
        self._dp = ctypes.POINTER(ctypes.c_double)
        self._int = ctypes.c_int(0)

    def solve(self, H, g, A, lba, uba, lbx, ubx):
        """(x, status, iterations); H and A as matrices (passed column-major)."""
        import ctypes
        n, m = self.n, self.m
        arrs = [np.ascontiguousarray(np.asarray(H, dtype=float).reshape(n, n).ravel("F")),
                np.ascontiguousarray(g, dtype=float),
                np.ascontiguousarray(np.asarray(A, dtype=float).reshape(m, n).ravel("F")),
                *(np.ascontiguousarray(v, dtype=float) for v in (lba, uba, lbx, ubx))]
        x = np.zeros(n)
        status = self.lib.ctl_qp_shim(self.mem, *(a.ctypes.data_as(self._dp) for a in arrs),
                                      x.ctypes.data_as(self._dp), self.max_iter,
                                      ctypes.byref(self._int))
        return x, int(status), int(self._int.value)
