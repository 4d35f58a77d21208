/*
 * ctl_qp.h: a dense, strictly convex QP solved by the dual active-set method of
 * Goldfarb and Idnani, with soft rows (exact L1 penalties) -- the re-planning
 * controller's QP (controller.c includes it).
 *
 * Hand-written C: this file is templates/control/ctl_qp.h, copied verbatim into the
 * folder `derive control` writes.  derive/control/qp.py states the same method in NumPy,
 * step for step (the Python route runs it); tests compare both with qpOASES.
 *
 *     minimise 1/2 x'Hx + g'x   subject to   lba <= A x <= uba,   lbx <= x <= ubx
 *
 * H (n x n, column-major, symmetric positive definite), A (m x n, column-major); rows with
 * lba = uba are equalities; infinite bounds are absent.  The method (D. Goldfarb and
 * A. Idnani, Math. Programming 27, 1983) starts at the unconstrained minimum -H^-1 g,
 * adds the equalities, then the most violated inequality at a time, dropping an active
 * one when its multiplier would turn negative: every iterate solves a sub-problem, so no
 * feasible start is needed.  With H = L L' and the active normals N: V = L^-1 N and
 * S = V'V = R'R (R upper triangular: one column appended per constraint added, made
 * triangular again by Givens rotations when one is dropped).  For a normal n_p: v = L^-1 n_p, R's = V'v, R r = s (the
 * dual direction), w = v - V r, z = L^-T w (the primal direction), z'n_p = w'w.
 *
 * Soft rows (as acados and HPIPM soften constraints): a row i with z1[i] > 0 gets a
 * slack for each finite side, s_l and s_u >= 0, and reads lba_i <= a_i x + s_l - s_u <=
 * uba_i; each slack adds z1[i] s + 1/2 z2[i] s^2 to the objective (z2[i] > 0).  The QP
 * then has a solution whatever its soft rows ask (the hard rows and bounds permitting),
 * and where the hard QP is feasible and z1[i] exceeds |row i's multiplier| it is the hard
 * one with the slacks 0 (an exact penalty).  The slacks are variables like x: the
 * method's variables are y = (x, s), the factor blockdiag(L, sqrt(z2)), a soft row's
 * normal (a_i, e_l, -e_u); the slacks' bounds s >= 0 are added before any other
 * inequality (from the unconstrained s = -z1/z2 < 0, the hard problem first).
 *
 * Sizes are the macros CTL_QP_N, CTL_QP_M and CTL_QP_NS (the slacks at most, default 0;
 * define them before including); the workspace is the caller's ctl_qp struct: nothing
 * is allocated, nothing static is written.  C99; also valid C++.
 */
#ifndef CTL_QP_H
#define CTL_QP_H

#include <math.h>

#define CTL_QP_SOLVED 0
#define CTL_QP_INFEASIBLE 1
#define CTL_QP_MAX_ITER 2
#define CTL_QP_NOT_CONVEX 3          /* H, or a soft row's z2, not positive definite */
#define CTL_QP_TOO_MANY_SLACKS 4     /* the soft rows' finite sides exceed CTL_QP_NS */

#define CTL_QP_VIOLATION_TOL 1e-11   /* violated below -tol (the constraint's units) */
#define CTL_QP_DEPENDENT_TOL 1e-12   /* w'w <= tol v'v: n_p depends on the active normals */
#define CTL_QP_FINAL_TOL 1e-8        /* the answer's constraints hold to this */
#ifndef CTL_QP_NS
#define CTL_QP_NS 0
#endif
#define CTL_QP_NV (CTL_QP_N + CTL_QP_NS)      /* variables at most: x, then the slacks */
#define CTL_QP_NC (CTL_QP_M + CTL_QP_NV)      /* constraints: rows, x's bounds, s >= 0 */

typedef struct {
  double L[CTL_QP_N * CTL_QP_N];      /* H = L L', lower, column-major */
  double ls[CTL_QP_NS + 1];           /* the slacks' part of the factor: sqrt(z2) */
  double V[CTL_QP_NV * CTL_QP_NV];    /* column k: L^-1 of the k-th active normal */
  double R[CTL_QP_NV * CTL_QP_NV];    /* V'V = R'R, upper, column-major */
  double u[CTL_QP_NV + 1];            /* multipliers of the active constraints */
  int act[CTL_QP_NV + 1];             /* the active constraints: index */
  int side[CTL_QP_NV + 1];            /* +1: a y >= lb, -1: -a y >= -ub */
  int eq[CTL_QP_NV + 1];              /* 1: an equality (never dropped) */
  int is_active[CTL_QP_NC];
  int slot_l[CTL_QP_M], slot_u[CTL_QP_M];   /* a row's slacks (-1: none) */
  int row_of[CTL_QP_NS + 1];          /* a slack's row */
  double s[CTL_QP_NS + 1];            /* the slacks */
  /* vectors of the method's variables (one more than they can hold: with no slacks,
     the slacks' index stays in bounds where it is never reached) */
  double np_[CTL_QP_NV + 1], v[CTL_QP_NV + 1], sv[CTL_QP_NV + 1], r[CTL_QP_NV + 1];
  double w[CTL_QP_NV + 1], z[CTL_QP_NV + 1], y[CTL_QP_NV + 1];
  double ax[CTL_QP_M];
  int nact, nv, nc, iterations, ax_ok;
} ctl_qp;

/* lower L with H = L L', column by column; 0, or 1 when H is not positive definite */
static int ctl_qp_chol(const double *H, double *L, int n)
{
  int i, j, k;
  for (j = 0; j < n; ++j) {
    double d = H[j + n * j];
    for (k = 0; k < j; ++k) d -= L[j + n * k] * L[j + n * k];
    if (!(d > 0.0)) return 1;
    d = sqrt(d);
    L[j + n * j] = d;
    for (i = j + 1; i < n; ++i) {
      double acc = H[i + n * j];
      for (k = 0; k < j; ++k) acc -= L[i + n * k] * L[j + n * k];
      L[i + n * j] = acc / d;
    }
    for (i = 0; i < j; ++i) L[i + n * j] = 0.0;
  }
  return 0;
}

/* y = L^-1 b (the factor blockdiag(L, ls)) */
static void ctl_qp_forward(const ctl_qp *q, const double *b, double *y)
{
  const int n = CTL_QP_N;
  int i, k;
  for (i = 0; i < n; ++i) {
    double acc = b[i];
    for (k = 0; k < i; ++k) acc -= q->L[i + n * k] * y[k];
    y[i] = acc / q->L[i + n * i];
  }
  for (i = n; i < q->nv; ++i) y[i] = b[i] / q->ls[i - n];
}

/* y = L^-T b */
static void ctl_qp_backward_t(const ctl_qp *q, const double *b, double *y)
{
  const int n = CTL_QP_N;
  int i, k;
  for (i = n; i < q->nv; ++i) y[i] = b[i] / q->ls[i - n];
  for (i = n - 1; i >= 0; --i) {
    double acc = b[i];
    for (k = i + 1; k < n; ++k) acc -= q->L[k + n * i] * y[k];
    y[i] = acc / q->L[i + n * i];
  }
}

static void ctl_qp_bounds(const ctl_qp *q, int i, const double *lba, const double *uba,
                          const double *lbx, const double *ubx, double *lo, double *hi)
{
  (void)q;
  if (i < CTL_QP_M) { *lo = lba[i]; *hi = uba[i]; }
  else if (i < CTL_QP_M + CTL_QP_N) { *lo = lbx[i - CTL_QP_M]; *hi = ubx[i - CTL_QP_M]; }
  else { *lo = 0.0; *hi = HUGE_VAL; }
}

/* the normal of constraint i on side sd, into q->np_ */
static void ctl_qp_normal(ctl_qp *q, const double *A, int i, int sd)
{
  int j;
  for (j = 0; j < q->nv; ++j) q->np_[j] = 0.0;
  if (i < CTL_QP_M) {
    for (j = 0; j < CTL_QP_N; ++j) q->np_[j] = sd * A[i + CTL_QP_M * j];
    if (q->slot_l[i] >= 0) q->np_[CTL_QP_N + q->slot_l[i]] = sd;
    if (q->slot_u[i] >= 0) q->np_[CTL_QP_N + q->slot_u[i]] = -sd;
  } else {
    q->np_[i - CTL_QP_M] = sd;
  }
}

/* A x into q->ax (x = the first CTL_QP_N of y) */
static void ctl_qp_ax(ctl_qp *q, const double *A)
{
  int i, j;
  for (i = 0; i < CTL_QP_M; ++i) q->ax[i] = 0.0;
  for (j = 0; j < CTL_QP_N; ++j)
    for (i = 0; i < CTL_QP_M; ++i) q->ax[i] += A[i + CTL_QP_M * j] * q->y[j];
  q->ax_ok = 1;
}

/* a_i y: a row's from q->ax while it holds (after ctl_qp_ax, until the next step), else
   its own dot product */
static double ctl_qp_value(const ctl_qp *q, const double *A, int i)
{
  double a = 0.0;
  int j;
  if (i >= CTL_QP_M) return q->y[i - CTL_QP_M];
  if (q->ax_ok) a = q->ax[i];
  else
    for (j = 0; j < CTL_QP_N; ++j) a += A[i + CTL_QP_M * j] * q->y[j];
  if (q->slot_l[i] >= 0) a += q->y[CTL_QP_N + q->slot_l[i]];
  if (q->slot_u[i] >= 0) a -= q->y[CTL_QP_N + q->slot_u[i]];
  return a;
}

/* the slack of constraint i on side sd (positive when it holds) */
static double ctl_qp_slack(const ctl_qp *q, const double *A, int i, int sd,
                           const double *lba, const double *uba, const double *lbx,
                           const double *ubx)
{
  double lo, hi, ay = ctl_qp_value(q, A, i);
  ctl_qp_bounds(q, i, lba, uba, lbx, ubx, &lo, &hi);
  return sd > 0 ? ay - lo : hi - ay;
}

/* v, s, r, w for the normal in q->np_; returns w'w and v'v */
static void ctl_qp_directions(ctl_qp *q, double *d2, double *vv)
{
  const int nv = q->nv, k = q->nact;
  int i, j;
  ctl_qp_forward(q, q->np_, q->v);
  for (i = 0; i < k; ++i) {                 /* R's = V'v */
    double acc = 0.0;
    for (j = 0; j < nv; ++j) acc += q->V[j + CTL_QP_NV * i] * q->v[j];
    for (j = 0; j < i; ++j) acc -= q->R[j + CTL_QP_NV * i] * q->sv[j];
    q->sv[i] = acc / q->R[i + CTL_QP_NV * i];
  }
  for (i = k - 1; i >= 0; --i) {            /* R r = s */
    double acc = q->sv[i];
    for (j = i + 1; j < k; ++j) acc -= q->R[i + CTL_QP_NV * j] * q->r[j];
    q->r[i] = acc / q->R[i + CTL_QP_NV * i];
  }
  *d2 = 0.0;
  *vv = 0.0;
  for (j = 0; j < nv; ++j) q->w[j] = q->v[j];
  for (i = 0; i < k; ++i) {                 /* w = v - V r, column by column */
    const double ri = q->r[i];
    const double *Vi = q->V + CTL_QP_NV * i;
    for (j = 0; j < nv; ++j) q->w[j] -= Vi[j] * ri;
  }
  for (j = 0; j < nv; ++j) {
    *d2 += q->w[j] * q->w[j];
    *vv += q->v[j] * q->v[j];
  }
}

static void ctl_qp_add(ctl_qp *q, int i, int sd, int eq, double d2)
{
  const int k = q->nact;
  int j;
  for (j = 0; j < q->nv; ++j) q->V[j + CTL_QP_NV * k] = q->v[j];
  for (j = 0; j < k; ++j) q->R[j + CTL_QP_NV * k] = q->sv[j];
  q->R[k + CTL_QP_NV * k] = sqrt(d2);
  q->act[k] = i;
  q->side[k] = sd;
  q->eq[k] = eq;
  q->is_active[i] = 1;
  q->nact = k + 1;
}

/* drop the active constraint k: V and R lose their column k, and Givens rotations of
   R's rows k.. make it triangular again (R'R = V'V still: the rotations are orthogonal);
   0, or 1 when a diagonal entry vanishes (V's columns dependent) */
static int ctl_qp_drop(ctl_qp *q, int k)
{
  const int nv = q->nv;
  int i, j, l;
  q->is_active[q->act[k]] = 0;
  for (i = k; i < q->nact - 1; ++i) {
    q->act[i] = q->act[i + 1];
    q->side[i] = q->side[i + 1];
    q->eq[i] = q->eq[i + 1];
    q->u[i] = q->u[i + 1];
    for (j = 0; j < nv; ++j) q->V[j + CTL_QP_NV * i] = q->V[j + CTL_QP_NV * (i + 1)];
    for (j = 0; j <= i + 1; ++j) q->R[j + CTL_QP_NV * i] = q->R[j + CTL_QP_NV * (i + 1)];
  }
  --q->nact;
  for (j = k; j < q->nact; ++j) {           /* R(j+1, j) to 0 */
    const double a = q->R[j + CTL_QP_NV * j], b = q->R[(j + 1) + CTL_QP_NV * j];
    const double h = sqrt(a * a + b * b);
    double c, sn;
    if (!(h > 0.0)) return 1;
    c = a / h;
    sn = b / h;
    q->R[j + CTL_QP_NV * j] = h;
    q->R[(j + 1) + CTL_QP_NV * j] = 0.0;
    for (l = j + 1; l < q->nact; ++l) {
      const double x = q->R[j + CTL_QP_NV * l], y = q->R[(j + 1) + CTL_QP_NV * l];
      q->R[j + CTL_QP_NV * l] = c * x + sn * y;
      q->R[(j + 1) + CTL_QP_NV * l] = c * y - sn * x;
    }
  }
  return 0;
}

static int ctl_qp_holds(ctl_qp *q, const double *A, const double *lba, const double *uba,
                        const double *lbx, const double *ubx)
{
  int i;
  ctl_qp_ax(q, A);
  for (i = 0; i < q->nc; ++i) {
    double lo, hi, ay = ctl_qp_value(q, A, i);
    ctl_qp_bounds(q, i, lba, uba, lbx, ubx, &lo, &hi);
    if (!(ay >= lo - CTL_QP_FINAL_TOL) || !(ay <= hi + CTL_QP_FINAL_TOL)) return 0;
  }
  return 1;
}

/* the solution's x and slacks out of q->y; the status through */
static int ctl_qp_done(ctl_qp *q, double *x, int status, int it)
{
  int j;
  for (j = 0; j < CTL_QP_N; ++j) x[j] = q->y[j];
  for (j = 0; j < q->nv - CTL_QP_N; ++j) q->s[j] = q->y[CTL_QP_N + j];
  q->iterations = it;
  return status;
}

/* the step along z (the primal direction of the normal in q->np_): y += t z */
static void ctl_qp_step(ctl_qp *q, double t)
{
  int j;
  ctl_qp_backward_t(q, q->w, q->z);
  for (j = 0; j < q->nv; ++j) q->y[j] += t * q->z[j];
  q->ax_ok = 0;
}

/* Solve into x (CTL_QP_N); returns a CTL_QP_ status, the iterations in q->iterations and
   the slacks in q->s (in the order of the rows, the lower one first).  z1, z2: the rows'
   L1 and quadratic weights (CTL_QP_M each; z1[i] = 0: a hard row), or NULL: all hard. */
static int ctl_qp_solve(ctl_qp *q, const double *H, const double *g, const double *A,
                        const double *lba, const double *uba, const double *lbx,
                        const double *ubx, const double *z1, const double *z2, double *x,
                        int max_iter)
{
  const int n = CTL_QP_N;
  int i, j, k, it = 0, ns = 0;
  double d2, vv;
  q->nact = 0;
  q->iterations = 0;
  q->ax_ok = 0;
  q->nv = n;
  for (j = 0; j < CTL_QP_NV; ++j) q->y[j] = 0.0;
  for (i = 0; i < CTL_QP_M; ++i) {          /* the slacks: one per finite side */
    q->slot_l[i] = q->slot_u[i] = -1;
    if (!z1 || !(z1[i] > 0.0)) continue;
    if (!(z2[i] > 0.0)) return ctl_qp_done(q, x, CTL_QP_NOT_CONVEX, 0);
    if (lba[i] - lba[i] == 0.0) {
      if (ns == CTL_QP_NS) return ctl_qp_done(q, x, CTL_QP_TOO_MANY_SLACKS, 0);
      q->row_of[ns] = i;
      q->slot_l[i] = ns++;
    }
    if (uba[i] - uba[i] == 0.0) {
      if (ns == CTL_QP_NS) return ctl_qp_done(q, x, CTL_QP_TOO_MANY_SLACKS, 0);
      q->row_of[ns] = i;
      q->slot_u[i] = ns++;
    }
  }
  q->nv = n + ns;
  q->nc = CTL_QP_M + n + ns;
  for (i = 0; i < q->nc; ++i) q->is_active[i] = 0;
  if (ctl_qp_chol(H, q->L, n)) return ctl_qp_done(q, x, CTL_QP_NOT_CONVEX, 0);
  for (j = 0; j < n; ++j) q->np_[j] = g[j];
  for (j = 0; j < ns; ++j) {
    q->ls[j] = sqrt(z2[q->row_of[j]]);
    q->np_[n + j] = z1[q->row_of[j]];
  }
  ctl_qp_forward(q, q->np_, q->z);
  ctl_qp_backward_t(q, q->z, q->y);
  for (j = 0; j < q->nv; ++j) q->y[j] = -q->y[j];
  ctl_qp_ax(q, A);
  /* the equalities first, each with its full step */
  for (i = 0; i < q->nc; ++i) {
    double lo, hi, sp, t;
    int sd;
    ctl_qp_bounds(q, i, lba, uba, lbx, ubx, &lo, &hi);
    if (lo != hi) continue;
    sd = ctl_qp_slack(q, A, i, 1, lba, uba, lbx, ubx) <= 0.0 ? 1 : -1;
    ctl_qp_normal(q, A, i, sd);
    ctl_qp_directions(q, &d2, &vv);
    sp = ctl_qp_slack(q, A, i, sd, lba, uba, lbx, ubx);
    if (d2 <= CTL_QP_DEPENDENT_TOL * vv) {
      if (sp < -CTL_QP_VIOLATION_TOL) return ctl_qp_done(q, x, CTL_QP_INFEASIBLE, it);
      continue;                             /* implied by the others */
    }
    t = -sp / d2;
    ctl_qp_step(q, t);
    for (j = 0; j < q->nact; ++j) q->u[j] -= t * q->r[j];
    q->u[q->nact] = t;
    ctl_qp_add(q, i, sd, 1, d2);
    ++it;
  }
  /* then the inequalities, the most violated first; but the slacks' bounds before any
     other */
  for (;;) {
    double worst = -CTL_QP_VIOLATION_TOL, up = 0.0;
    int p = -1, psd = 0;
    ctl_qp_ax(q, A);
    for (k = 0; k < q->nc; ++k) {
      double lo, hi, sl;
      i = (k + CTL_QP_M + n) % q->nc;       /* the slacks' bounds, then the rest */
      if (i == 0 && p >= 0) break;          /* a slack's bound is violated: it first */
      if (q->is_active[i]) continue;
      ctl_qp_bounds(q, i, lba, uba, lbx, ubx, &lo, &hi);
      if (lo == hi) continue;
      if (lo - lo == 0.0) {                 /* finite */
        sl = ctl_qp_slack(q, A, i, 1, lba, uba, lbx, ubx);
        if (sl < worst) { worst = sl; p = i; psd = 1; }
      }
      if (hi - hi == 0.0) {
        sl = ctl_qp_slack(q, A, i, -1, lba, uba, lbx, ubx);
        if (sl < worst) { worst = sl; p = i; psd = -1; }
      }
    }
    if (p < 0)
      return ctl_qp_done(q, x, ctl_qp_holds(q, A, lba, uba, lbx, ubx) ? CTL_QP_SOLVED
                                                                    : CTL_QP_INFEASIBLE, it);
    ctl_qp_normal(q, A, p, psd);
    for (;;) {
      double t1 = HUGE_VAL, t2, t;
      int k1 = -1, dependent;
      if (++it > max_iter) return ctl_qp_done(q, x, CTL_QP_MAX_ITER, it);
      ctl_qp_directions(q, &d2, &vv);
      for (j = 0; j < q->nact; ++j)
        if (!q->eq[j] && q->r[j] > 0.0) {
          const double tj = q->u[j] / q->r[j];
          if (tj < t1) { t1 = tj; k1 = j; }
        }
      dependent = d2 <= CTL_QP_DEPENDENT_TOL * vv;
      t2 = dependent ? HUGE_VAL : -ctl_qp_slack(q, A, p, psd, lba, uba, lbx, ubx) / d2;
      t = t1 < t2 ? t1 : t2;
      if (!(t < HUGE_VAL)) return ctl_qp_done(q, x, CTL_QP_INFEASIBLE, it);
      if (!dependent) ctl_qp_step(q, t);
      for (j = 0; j < q->nact; ++j) q->u[j] -= t * q->r[j];
      up += t;
      if (t == t2) {
        q->u[q->nact] = up;
        ctl_qp_add(q, p, psd, 0, d2);
        break;
      }
      if (ctl_qp_drop(q, k1)) return ctl_qp_done(q, x, CTL_QP_NOT_CONVEX, it);
    }
  }
}

#endif /* CTL_QP_H */
