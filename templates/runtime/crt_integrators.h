/*
 * crt_integrators.h: the classical Runge-Kutta methods of the runtime (RK4, DOPRI5,
 * DOP853), their error norm and dense outputs, on the right-hand side of crt_rhs.h.  The
 * steps of DOPRI5 and DOP853, whose tableaus are written out term by term, are rendered
 * into crt_rk_steps.h from derive/runtime/tableaus.py; crt_step.h dispatches between these
 * and the Lie methods (crt_lie.h).
 *
 * Hand-written C: this file is templates/runtime/crt_integrators.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_INTEGRATORS_H
#define CRT_INTEGRATORS_H

#include "crt_rhs.h"

static double crt_error_norm(const crt_session *s, const double *y0, const double *y1,
                             const double *err)
{
  double sum = 0.0;
  int i;
  for (i = 0; i < NQ; ++i) {
    const double sc = s->opt[CRT_OPT_ATOL]
                      + s->opt[CRT_OPT_RTOL] * crt_max(fabs(y0[i]), fabs(y1[i]));
    const double r = err[i] / sc;
    sum += r * r;
  }
  return sqrt(sum / NQ);
}

/* ---- dense output: y0 + s (F0 + (1 - s) (F1 + s (F2 + (1 - s) (F3 + ...)))) ----------
   = y0 + sum_j w_j F_j with w_0 = s, w_j = w_{j-1} (1 - s) for odd j, s for even j:
   the weights once per call, then one short dot product per component. */
static void crt_dense_weights(const crt_dense *d, double t, double *w)
{
  const double s = (t - d->t0) / d->h;
  int j;
  w[0] = s;
  for (j = 1; j < d->m; ++j) w[j] = w[j - 1] * ((j % 2 == 1) ? 1.0 - s : s);
}

static void crt_dense_eval(const crt_dense *d, double t, double *y)
{
  double w[CRT_MAX_DENSE];
  int i, j;
  crt_dense_weights(d, t, w);
  if (d->m == 7) {
    for (i = 0; i < NQ; ++i)
      y[i] = d->y0[i] + w[0] * d->F[0][i] + w[1] * d->F[1][i] + w[2] * d->F[2][i]
             + w[3] * d->F[3][i] + w[4] * d->F[4][i] + w[5] * d->F[5][i] + w[6] * d->F[6][i];
    return;
  }
  for (i = 0; i < NQ; ++i) {
    double acc = d->y0[i];
    for (j = 0; j < d->m; ++j) acc += w[j] * d->F[j][i];
    y[i] = acc;
  }
}

/* ---- one step of each method: returns the error norm (0 for RK4); y1, f1 = f(y1) ------ */
static double crt_step_rk4(crt_session *s, double t, const double *y0, const double *f0,
                           double h, double *y1, double *f1, int with_dense)
{
  double tmp[NQ];
  int i;
  double (*k)[NQ] = s->k;
  for (i = 0; i < NQ; ++i) tmp[i] = y0[i] + 0.5 * h * f0[i];
  crt_rhs(s, t + 0.5 * h, tmp, k[1]);
  for (i = 0; i < NQ; ++i) tmp[i] = y0[i] + 0.5 * h * k[1][i];
  crt_rhs(s, t + 0.5 * h, tmp, k[2]);
  for (i = 0; i < NQ; ++i) tmp[i] = y0[i] + h * k[2][i];
  crt_rhs(s, t + h, tmp, k[3]);
  for (i = 0; i < NQ; ++i)
    y1[i] = y0[i] + h / 6.0 * (f0[i] + 2.0 * k[1][i] + 2.0 * k[2][i] + k[3][i]);
  crt_rhs(s, t + h, y1, f1);
  if (with_dense) {
    crt_dense *d = &s->dense;
    d->t0 = t; d->h = h; d->m = 3; d->pending = 0; d->lie = 0;
    for (i = 0; i < NQ; ++i) {
      const double dy = y1[i] - y0[i];
      d->y0[i] = y0[i];
      d->F[0][i] = dy;
      d->F[1][i] = h * f0[i] - dy;
      d->F[2][i] = 2.0 * dy - h * (f0[i] + f1[i]);
    }
  }
  return 0.0;
}

#include "crt_rk_steps.h"   /* crt_step_dopri5, crt_step_dop853, crt_dense_complete_classical */

static double crt_step_classical(crt_session *s, int method, double t, const double *y0,
                                 const double *f0, double h, double *y1, double *f1,
                                 int with_dense)
{
  switch (method) {
    case CRT_RK4: return crt_step_rk4(s, t, y0, f0, h, y1, f1, with_dense);
    case CRT_DOP853: return crt_step_dop853(s, t, y0, f0, h, y1, f1, with_dense);
    default: return crt_step_dopri5(s, t, y0, f0, h, y1, f1, with_dense);
  }
}

static int crt_order_classical(int method)
{
  switch (method) {
    case CRT_RK4: return 4;
    case CRT_DOP853: return 8;
    default: return 5;
  }
}

#endif /* CRT_INTEGRATORS_H */
