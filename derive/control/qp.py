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
made triangular again by Givens rotations when one is dropped), which is simpler than
the paper's QR updates and as accurate at these sizes (n about 100, up to n active).

**Soft rows** (exact L1 penalties, as acados and HPIPM soften constraints): a row i given
weights z1_i > 0 and z2_i > 0 gets a slack for each finite side, s_l and s_u >= 0,

    lba_i <= a_i x + s_l - s_u <= uba_i,   the objective plus, for each slack s,
                                           z1_i s + 1/2 z2_i s^2,

so that the QP always has a solution whatever its soft rows ask (the hard rows and the
bounds permitting).  Where the hard problem is feasible and z1_i exceeds the magnitude
of row i's multiplier, the solution is the hard one, slacks 0 (the penalty is exact);
where it is not, the soft rows are missed by as little as the weights say.  The slacks
are variables of the method like x: the factor of the objective's Hessian is
blockdiag(L, sqrt(z2)), a soft row's normal is (a_i, e_l, -e_u), and a soft equality stays
an equality (its slacks are what make it always reachable; a slack apiece for each side,
rather than one for both, keeps the normals of a row met with its slacks at 0
independent).

Statuses: 0 solved, 1 infeasible (a violated constraint that no step can satisfy),
2 the iteration limit, 3 H not positive definite (or a soft row's z2 not positive).
"""
from __future__ import annotations

import math

import numpy as np

SOLVED, INFEASIBLE, MAX_ITER, NOT_CONVEX, TOO_MANY_SLACKS = 0, 1, 2, 3, 4
STATUS = ("solved", "infeasible", "iteration limit", "H not positive definite",
          "more soft sides than slacks")
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


class DenseQP:
    """A solver for one size (n, m); ``solve`` returns (x, status, iterations) and leaves
    the soft rows' slacks in ``slack`` (m entries: s_l + s_u, 0 on the hard rows)."""

    def __init__(self, n: int, m: int, max_iter: int | None = None,
                 slacks: int | None = None):
        self.n, self.m = n, m
        self.max_iter = max_iter or 4 * (n + m) + 20
        self.slacks = slacks               # the slacks at most (None: any number)
        self.slack = np.zeros(m)

    def solve(self, H, g, A, lba, uba, lbx, ubx, z1=None, z2=None):
        """``z1``, ``z2``: the rows' L1 and quadratic weights (m each; z1 = 0: a hard
        row; None: every row hard)."""
        n, m = self.n, self.m
        H = np.asarray(H, dtype=float)
        A = np.asarray(A, dtype=float).reshape(m, n)
        z1 = np.zeros(m) if z1 is None else np.asarray(z1, dtype=float)
        z2 = np.zeros(m) if z2 is None else np.asarray(z2, dtype=float)
        # the slacks: for each soft row, one per finite side (lower +1, upper -1)
        slacks = [(i, sd) for i in range(m) if z1[i] > 0.0
                  for sd, bound in ((1.0, lba[i]), (-1.0, uba[i])) if math.isfinite(bound)]
        ns = len(slacks)
        nv = n + ns                        # the method's variables: y = (x, s)
        mc = m + n + ns                    # constraints: rows, x's bounds, s >= 0
        of_row = {}                        # row -> [(slot, sign)]
        for j, (i, sd) in enumerate(slacks):
            of_row.setdefault(i, []).append((n + j, sd))
        self.slack = np.zeros(m)
        it = 0
        if any(not z2[i] > 0.0 for i, _ in slacks):
            return np.zeros(n), NOT_CONVEX, 0
        if self.slacks is not None and ns > self.slacks:
            return np.zeros(n), TOO_MANY_SLACKS, 0
        L = _chol(H)
        if L is None:
            return np.zeros(n), NOT_CONVEX, 0
        if ns:
            L = np.block([[L, np.zeros((n, ns))],
                          [np.zeros((ns, n)), np.diag([math.sqrt(z2[i]) for i, _ in slacks])]])
            g = np.r_[g, [z1[i] for i, _ in slacks]]
        y = -_backward_t(L, _forward(L, g))
        V = np.zeros((nv, 0))              # L^-1 of the active normals
        R = np.zeros((0, 0))               # S = R' R
        act: list = []                     # (constraint, side, equality)
        u = np.zeros(0)

        def bounds(i):
            if i < m:
                return lba[i], uba[i]
            if i < m + n:
                return lbx[i - m], ubx[i - m]
            return 0.0, math.inf

        def normal(i, side):
            row = np.zeros(nv)
            if i < m:
                row[:n] = A[i]
                for j, sd in of_row.get(i, ()):
                    row[j] = sd
                return side * row
            row[i - m] = side
            return row

        def slack(i, side):
            """side +1: a y - lb; side -1: ub - a y (positive when satisfied)."""
            if i < m:
                ay = A[i] @ y[:n] + sum(sd * y[j] for j, sd in of_row.get(i, ()))
            else:
                ay = y[i - m]
            lo, hi = bounds(i)
            return ay - lo if side > 0 else hi - ay

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
            """V and R lose column j; Givens rotations of R's rows j.. make it
            triangular again (R'R = V'V still)."""
            nonlocal V, R, u
            keep = [k for k in range(len(act)) if k != j]
            del act[j]
            V = V[:, keep]
            u = u[keep]
            R = R[:, keep]
            k = len(act)
            for i in range(j, k):
                a, b = R[i, i], R[i + 1, i]
                h = math.sqrt(a * a + b * b)
                if not h > 0.0:
                    return False
                c, sn = a / h, b / h
                R[i, i], R[i + 1, i] = h, 0.0
                x, z = R[i, i + 1:k].copy(), R[i + 1, i + 1:k].copy()
                R[i, i + 1:k] = c * x + sn * z
                R[i + 1, i + 1:k] = c * z - sn * x
            R = R[:k, :k]
            return True

        def holds():
            """Every constraint within FINAL_TOL (a last check: an active set made of
            nearly dependent normals can drift)."""
            return all(slack(i, side) >= -FINAL_TOL for i in range(mc)
                       for side, bound in zip((1.0, -1.0), bounds(i))
                       if math.isfinite(bound))

        def done(status):
            for j, (i, _) in enumerate(slacks):
                self.slack[i] += y[n + j]
            return y[:n].copy(), status, it

        # the equalities first: each added with its full step (free multipliers)
        for i in range(mc):
            lo, hi = bounds(i)
            if lo != hi:
                continue
            side = 1.0 if slack(i, 1.0) <= 0.0 else -1.0
            npv = normal(i, side)
            v, s, r, wv, d2, vv = directions(npv)
            sp = slack(i, side)
            if d2 <= DEPENDENT_TOL * vv:
                if sp < -VIOLATION_TOL:
                    return done(INFEASIBLE)
                continue                     # implied by the others
            t = -sp / d2
            y = y + t * _backward_t(L, wv)
            u = np.r_[u - t * r, t]
            add(i, side, True, v, s, d2)
            it += 1
        # then the inequalities, the most violated first; but the slacks' bounds s >= 0
        # before any other (from the unconstrained s = -z1/z2 < 0: the rows held with
        # their slacks at 0, the hard problem, unless a multiplier passes z1)
        while True:
            worst, p, p_side = -VIOLATION_TOL, -1, 0.0
            active = {a[0] for a in act}
            for k in range(mc):
                i = (k + m + n) % mc         # the slacks' bounds, then the rest
                if i == 0 and p >= 0:
                    break                    # a slack's bound is violated: it comes first
                lo, hi = bounds(i)
                if lo == hi or i in active:
                    continue
                for side, bound in ((1.0, lo), (-1.0, hi)):
                    if not math.isfinite(bound):
                        continue
                    sv = slack(i, side)
                    if sv < worst:
                        worst, p, p_side = sv, i, side
            if p < 0:
                return done(SOLVED if holds() else INFEASIBLE)
            up = 0.0
            npv = normal(p, p_side)
            while True:
                it += 1
                if it > self.max_iter:
                    return done(MAX_ITER)
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
                    return done(INFEASIBLE)
                if not dependent:
                    y = y + t * _backward_t(L, wv)
                u = u - t * r
                up += t
                if t == t2:
                    u = np.r_[u, up]
                    add(p, p_side, False, v, s, d2)
                    break
                if not drop(k1):
                    return done(NOT_CONVEX)


class CDenseQP:
    """The C solver (``templates/control/ctl_qp.h``) for one size, compiled with the
    runtime's flags and loaded: ``solve`` as :meth:`DenseQP.solve` (for the checks and
    ``derive bench control``; the controller includes the header itself)."""

    def __init__(self, n: int, m: int, max_iter: int | None = None, slacks: int = 0):
        import ctypes
        from ..cbuild import build_shared, runtime_flags
        from ..paths import c_sources
        self.n, self.m, self.slacks = n, m, slacks
        self.max_iter = max_iter or 4 * (n + m) + 20
        shim = (f"#define CTL_QP_N {n}\n#define CTL_QP_M {m}\n#define CTL_QP_NS {slacks}\n"
                "#include \"ctl_qp.h\"\n"
                "int ctl_qp_shim(ctl_qp *q, const double *H, const double *g, "
                "const double *A, const double *lba, const double *uba, const double *lbx, "
                "const double *ubx, const double *z1, const double *z2, double *x, "
                "int max_iter, int *iterations, double *slack)\n{\n"
                "  int j;\n"
                "  const int r = ctl_qp_solve(q, H, g, A, lba, uba, lbx, ubx, z1, z2, x, "
                "max_iter);\n"
                "  *iterations = q->iterations;\n"
                "  for (j = 0; j < CTL_QP_M; ++j) slack[j] = 0.0;\n"
                "  for (j = 0; j < q->nv - CTL_QP_N; ++j) slack[q->row_of[j]] += q->s[j];\n"
                "  return r;\n}\n"
                "int ctl_qp_shim_size(void) { return (int)sizeof(ctl_qp); }\n")
        header = (c_sources("control") / "ctl_qp.h").read_text(encoding="utf-8")
        path = build_shared({"shim.c": shim, "ctl_qp.h": header}, flags=runtime_flags(),
                            name="qpshim")
        self.lib = ctypes.CDLL(str(path))
        self.mem = ctypes.create_string_buffer(self.lib.ctl_qp_shim_size() + 64)
        self._dp = ctypes.POINTER(ctypes.c_double)
        self._int = ctypes.c_int(0)
        self.slack = np.zeros(m)

    def solve(self, H, g, A, lba, uba, lbx, ubx, z1=None, z2=None):
        """(x, status, iterations); H and A as matrices (passed column-major)."""
        import ctypes
        n, m = self.n, self.m
        arrs = [np.ascontiguousarray(np.asarray(H, dtype=float).reshape(n, n).ravel("F")),
                np.ascontiguousarray(g, dtype=float),
                np.ascontiguousarray(np.asarray(A, dtype=float).reshape(m, n).ravel("F")),
                *(np.ascontiguousarray(v, dtype=float) for v in (lba, uba, lbx, ubx))]
        weights = [None if z is None else np.ascontiguousarray(z, dtype=float)
                   for z in (z1, z2)]
        x = np.zeros(n)
        self.slack = np.zeros(m)
        dp = self._dp
        status = self.lib.ctl_qp_shim(self.mem, *(a.ctypes.data_as(dp) for a in arrs),
                                      *(None if z is None else z.ctypes.data_as(dp)
                                        for z in weights),
                                      x.ctypes.data_as(dp), self.max_iter,
                                      ctypes.byref(self._int), self.slack.ctypes.data_as(dp))
        return x, int(status), int(self._int.value)
