/*
 * ctl_qp.h: a dense, strictly convex QP solved by the dual active-set method of
 * Goldfarb and Idnani -- the re-planning controller's QP (controller.c includes it).
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
 * S = V'V = R'R (R upper triangular: one column appended per constraint added, factored
 * again when one is dropped).  For a normal n_p: v = L^-1 n_p, R's = V'v, R r = s (the
 * dual direction), w = v - V r, z = L^-T w (the primal direction), z'n_p = w'w.
 *
 * Sizes are the macros CTL_QP_N and CTL_QP_M (define them before including); the
 * workspace is the caller's ctl_qp struct: nothing is allocated, nothing static is
 * written.  C99; also valid C++.
 */
#ifndef CTL_QP_H
#define CTL_QP_H

#include <math.h>

#define CTL_QP_SOLVED 0
#define CTL_QP_INFEASIBLE 1
#define CTL_QP_MAX_ITER 2
#define CTL_QP_NOT_CONVEX 3

#define CTL_QP_VIOLATION_TOL 1e-11   /* violated below -tol (the constraint's units) */
#define CTL_QP_DEPENDENT_TOL 1e-12   /* w'w <= tol v'v: n_p depends on the active normals */
#define CTL_QP_FINAL_TOL 1e-8        /* the answer's constraints hold to this */
#define CTL_QP_NC (CTL_QP_M + CTL_QP_N)   /* constraints: the rows, then the bounds */

typedef struct {
  double L[CTL_QP_N * CTL_QP_N];      /* H = L L', lower, column-major */
  double V[CTL_QP_N * CTL_QP_N];      /* column k: L^-1 of the k-th active normal */
  double R[CTL_QP_N * CTL_QP_N];      /* V'V = R'R, upper, column-major */
  double u[CTL_QP_N];                 /* multipliers of the active constraints */
  int act[CTL_QP_N];                  /* the active constraints: index */
  int side[CTL_QP_N];                 /* +1: a x >= lb, -1: -a x >= -ub */
  int eq[CTL_QP_N];                   /* 1: an equality (never dropped) */
  int is_active[CTL_QP_NC];
  int nact;
  double np_[CTL_QP_N], v[CTL_QP_N], s[CTL_QP_N], r[CTL_QP_N], w[CTL_QP_N], z[CTL_QP_N];
  double ax[CTL_QP_M];
  int iterations;
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

/* y = L^-1 b */
static void ctl_qp_forward(const double *L, const double *b, double *y, int n)
{
  int i, k;
  for (i = 0; i < n; ++i) {
    double acc = b[i];
    for (k = 0; k < i; ++k) acc -= L[i + n * k] * y[k];
    y[i] = acc / L[i + n * i];
  }
}

/* y = L^-T b */
static void ctl_qp_backward_t(const double *L, const double *b, double *y, int n)
{
  int i, k;
  for (i = n - 1; i >= 0; --i) {
    double acc = b[i];
    for (k = i + 1; k < n; ++k) acc -= L[k + n * i] * y[k];
    y[i] = acc / L[i + n * i];
  }
}

static void ctl_qp_bounds(int i, const double *lba, const double *uba, const double *lbx,
                          const double *ubx, double *lo, double *hi)
{
  if (i < CTL_QP_M) { *lo = lba[i]; *hi = uba[i]; }
  else { *lo = lbx[i - CTL_QP_M]; *hi = ubx[i - CTL_QP_M]; }
}

/* the normal of constraint i on side sd, into q->np_ */
static void ctl_qp_normal(ctl_qp *q, const double *A, int i, int sd)
{
  int j;
  for (j = 0; j < CTL_QP_N; ++j) q->np_[j] = 0.0;
  if (i < CTL_QP_M)
    for (j = 0; j < CTL_QP_N; ++j) q->np_[j] = sd * A[i + CTL_QP_M * j];
  else
    q->np_[i - CTL_QP_M] = sd;
}

/* a_i x (rows from q->ax, kept up to date by ctl_qp_ax) */
static double ctl_qp_value(const ctl_qp *q, int i, const double *x)
{
  return i < CTL_QP_M ? q->ax[i] : x[i - CTL_QP_M];
}

static void ctl_qp_ax(ctl_qp *q, const double *A, const double *x)
{
  int i, j;
  for (i = 0; i < CTL_QP_M; ++i) q->ax[i] = 0.0;
  for (j = 0; j < CTL_QP_N; ++j)
    for (i = 0; i < CTL_QP_M; ++i) q->ax[i] += A[i + CTL_QP_M * j] * x[j];
}

/* the slack of constraint i on side sd (positive when it holds) */
static double ctl_qp_slack(const ctl_qp *q, int i, int sd, const double *x, const double *lba,
                           const double *uba, const double *lbx, const double *ubx)
{
  double lo, hi, ax = ctl_qp_value(q, i, x);
  ctl_qp_bounds(i, lba, uba, lbx, ubx, &lo, &hi);
  return sd > 0 ? ax - lo : hi - ax;
}

/* v, s, r, w for the normal in q->np_; returns w'w and v'v */
static void ctl_qp_directions(ctl_qp *q, double *d2, double *vv)
{
  const int n = CTL_QP_N, k = q->nact;
  int i, j;
  ctl_qp_forward(q->L, q->np_, q->v, n);
  for (i = 0; i < k; ++i) {                 /* R's = V'v */
    double acc = 0.0;
    for (j = 0; j < n; ++j) acc += q->V[j + n * i] * q->v[j];
    for (j = 0; j < i; ++j) acc -= q->R[j + n * i] * q->s[j];
    q->s[i] = acc / q->R[i + n * i];
  }
  for (i = k - 1; i >= 0; --i) {            /* R r = s */
    double acc = q->s[i];
    for (j = i + 1; j < k; ++j) acc -= q->R[i + n * j] * q->r[j];
    q->r[i] = acc / q->R[i + n * i];
  }
  *d2 = 0.0;
  *vv = 0.0;
  for (j = 0; j < n; ++j) {
    double acc = q->v[j];
    for (i = 0; i < k; ++i) acc -= q->V[j + n * i] * q->r[i];
    q->w[j] = acc;
    *d2 += acc * acc;
    *vv += q->v[j] * q->v[j];
  }
}

static void ctl_qp_add(ctl_qp *q, int i, int sd, int eq, double d2)
{
  const int n = CTL_QP_N, k = q->nact;
  int j;
  for (j = 0; j < n; ++j) q->V[j + n * k] = q->v[j];
  for (j = 0; j < k; ++j) q->R[j + n * k] = q->s[j];
  q->R[k + n * k] = sqrt(d2);
  q->act[k] = i;
  q->side[k] = sd;
  q->eq[k] = eq;
  q->is_active[i] = 1;
  q->nact = k + 1;
}

/* drop the active constraint k: V loses its column, R is factored again; 0, or 1 when
   V'V is not positive definite */
static int ctl_qp_drop(ctl_qp *q, int k)
{
  const int n = CTL_QP_N;
  int i, j, l;
  q->is_active[q->act[k]] = 0;
  for (i = k; i < q->nact - 1; ++i) {
    q->act[i] = q->act[i + 1];
    q->side[i] = q->side[i + 1];
    q->eq[i] = q->eq[i + 1];
    q->u[i] = q->u[i + 1];
    for (j = 0; j < n; ++j) q->V[j + n * i] = q->V[j + n * (i + 1)];
  }
  --q->nact;
  for (j = 0; j < q->nact; ++j) {           /* R'R = V'V, column by column */
    for (i = 0; i <= j; ++i) {
      double acc = 0.0;
      for (l = 0; l < n; ++l) acc += q->V[l + n * i] * q->V[l + n * j];
      for (l = 0; l < i; ++l) acc -= q->R[l + n * i] * q->R[l + n * j];
      if (i < j) q->R[i + n * j] = acc / q->R[i + n * i];
      else if (!(acc > 0.0)) return 1;
      else q->R[j + n * j] = sqrt(acc);
    }
  }
  return 0;
}

static int ctl_qp_holds(const ctl_qp *q, const double *x, const double *lba,
                        const double *uba, const double *lbx, const double *ubx)
{
  int i;
  for (i = 0; i < CTL_QP_M; ++i)
    if (!(q->ax[i] >= lba[i] - CTL_QP_FINAL_TOL) || !(q->ax[i] <= uba[i] + CTL_QP_FINAL_TOL))
      return 0;
  for (i = 0; i < CTL_QP_N; ++i)
    if (!(x[i] >= lbx[i] - CTL_QP_FINAL_TOL) || !(x[i] <= ubx[i] + CTL_QP_FINAL_TOL))
      return 0;
  return 1;
}

/* Solve into x (CTL_QP_N); returns a CTL_QP_ status, the iterations in q->iterations. */
static int ctl_qp_solve(ctl_qp *q, const double *H, const double *g, const double *A,
                        const double *lba, const double *uba, const double *lbx,
                        const double *ubx, double *x, int max_iter)
{
  const int n = CTL_QP_N;
  int i, j, it = 0;
  double d2, vv;
  q->nact = 0;
  q->iterations = 0;
  for (i = 0; i < CTL_QP_NC; ++i) q->is_active[i] = 0;
  if (ctl_qp_chol(H, q->L, n)) return CTL_QP_NOT_CONVEX;
  ctl_qp_forward(q->L, g, q->z, n);
  ctl_qp_backward_t(q->L, q->z, x, n);
  for (j = 0; j < n; ++j) x[j] = -x[j];
  ctl_qp_ax(q, A, x);
  /* the equalities first, each with its full step */
  for (i = 0; i < CTL_QP_NC; ++i) {
    double lo, hi, sp, t;
    int sd;
    ctl_qp_bounds(i, lba, uba, lbx, ubx, &lo, &hi);
    if (lo != hi) continue;
    sd = ctl_qp_slack(q, i, 1, x, lba, uba, lbx, ubx) <= 0.0 ? 1 : -1;
    ctl_qp_normal(q, A, i, sd);
    ctl_qp_directions(q, &d2, &vv);
    sp = ctl_qp_slack(q, i, sd, x, lba, uba, lbx, ubx);
    if (d2 <= CTL_QP_DEPENDENT_TOL * vv) {
      if (sp < -CTL_QP_VIOLATION_TOL) return CTL_QP_INFEASIBLE;
      continue;                             /* implied by the others */
    }
    t = -sp / d2;
    ctl_qp_backward_t(q->L, q->w, q->z, n);
    for (j = 0; j < n; ++j) x[j] += t * q->z[j];
    ctl_qp_ax(q, A, x);
    for (j = 0; j < q->nact; ++j) q->u[j] -= t * q->r[j];
    q->u[q->nact] = t;
    ctl_qp_add(q, i, sd, 1, d2);
    ++it;
  }
  /* then the inequalities, the most violated first */
  for (;;) {
    double worst = -CTL_QP_VIOLATION_TOL, up = 0.0;
    int p = -1, psd = 0;
    for (i = 0; i < CTL_QP_NC; ++i) {
      double lo, hi, sv;
      if (q->is_active[i]) continue;
      ctl_qp_bounds(i, lba, uba, lbx, ubx, &lo, &hi);
      if (lo == hi) continue;
      if (lo - lo == 0.0) {                 /* finite */
        sv = ctl_qp_slack(q, i, 1, x, lba, uba, lbx, ubx);
        if (sv < worst) { worst = sv; p = i; psd = 1; }
      }
      if (hi - hi == 0.0) {
        sv = ctl_qp_slack(q, i, -1, x, lba, uba, lbx, ubx);
        if (sv < worst) { worst = sv; p = i; psd = -1; }
      }
    }
    if (p < 0) {
      q->iterations = it;
      return ctl_qp_holds(q, x, lba, uba, lbx, ubx) ? CTL_QP_SOLVED : CTL_QP_INFEASIBLE;
    }
    ctl_qp_normal(q, A, p, psd);
    for (;;) {
      double t1 = HUGE_VAL, t2, t;
      int k1 = -1, dependent;
      if (++it > max_iter) { q->iterations = it; return CTL_QP_MAX_ITER; }
      ctl_qp_directions(q, &d2, &vv);
      for (j = 0; j < q->nact; ++j)
        if (!q->eq[j] && q->r[j] > 0.0) {
          const double tj = q->u[j] / q->r[j];
          if (tj < t1) { t1 = tj; k1 = j; }
        }
      dependent = d2 <= CTL_QP_DEPENDENT_TOL * vv;
      t2 = dependent ? HUGE_VAL : -ctl_qp_slack(q, p, psd, x, lba, uba, lbx, ubx) / d2;
      t = t1 < t2 ? t1 : t2;
      if (!(t < HUGE_VAL)) { q->iterations = it; return CTL_QP_INFEASIBLE; }
      if (!dependent) {
        ctl_qp_backward_t(q->L, q->w, q->z, n);
        for (j = 0; j < n; ++j) x[j] += t * q->z[j];
        ctl_qp_ax(q, A, x);
      }
      for (j = 0; j < q->nact; ++j) q->u[j] -= t * q->r[j];
      up += t;
      if (t == t2) {
        q->u[q->nact] = up;
        ctl_qp_add(q, p, psd, 0, d2);
        break;
      }
      if (ctl_qp_drop(q, k1)) { q->iterations = it; return CTL_QP_NOT_CONVEX; }
    }
  }
}

#endif /* CTL_QP_H */
