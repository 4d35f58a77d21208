/*
 * crt_step.h: the steppers' dispatcher -- which method takes the session's step (a Lie
 * method in flight where the model has the momentum form, the classical method of the same
 * order otherwise), its order, its first step, the longest step it takes, its dense output
 * and the output rows read from it.  Built on crt_integrators.h and crt_lie.h; the loop
 * (crt_loop.h) and the event search (crt_events.h) step through it.
 *
 * Hand-written C: this file is templates/runtime/crt_step.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_STEP_H
#define CRT_STEP_H

#include "crt_integrators.h"
#include "crt_lie.h"

/* lie: the order of its coefficients by the tolerance (8 below CRT_LIE_TIGHT, else 5) */
static int crt_resolve_method(const crt_session *s)
{
  const int method = (int)s->opt[CRT_OPT_METHOD];
  if (method == CRT_LIE) return s->opt[CRT_OPT_RTOL] < CRT_LIE_TIGHT ? CRT_LIE8 : CRT_LIE5;
  return method;
}

/* the classical method that stands in for a Lie method where it does not apply */
static int crt_classical_method(const crt_session *s)
{
  const int method = crt_resolve_method(s);
  if (method == CRT_LIE8) return CRT_DOP853;
  if (method == CRT_LIE5) return CRT_DOPRI5;
  return method;
}

static int crt_lie_active(const crt_session *s)
{
#if MODEL_LIE
  const int method = (int)s->opt[CRT_OPT_METHOD];
  return (method == CRT_LIE || method == CRT_LIE5 || method == CRT_LIE8)
         && s->phase == CRT_FLIGHT;
#else
  (void)s;
  return 0;
#endif
}

/* the longest step the method takes from s->t (HUGE_VAL: no limit of its own) */
static double crt_step_limit(crt_session *s)
{
#if MODEL_LIE
  if (crt_lie_active(s)) {
    const double *w;
    double rate;
    if (!s->lie.valid) crt_lie_restart(s);
    w = s->lie.omega;
    rate = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    return rate > 0.0 ? CRT_LIE_MAX_TURN / rate : HUGE_VAL;
  }
#endif
  (void)s;
  return HUGE_VAL;
}

/* ---- dispatch ------------------------------------------------------------------------------ */
/* One step of the session's method from (t, y0) = (s->t, s->q): returns the error norm (0
   for RK4) and y1; f1 = f(y1) for the classical methods (the Lie methods read omega from
   the session and leave f1 zero). */
static double crt_step(crt_session *s, double t, const double *y0, const double *f0,
                       double h, double *y1, double *f1, int with_dense)
{
#if MODEL_LIE
  if (crt_lie_active(s)) {
    int i;
    if (!s->lie.valid) crt_lie_restart(s);
    for (i = 0; i < NQ; ++i) f1[i] = 0.0;
    (void)y0; (void)f0;
    return crt_resolve_method(s) == CRT_LIE8 ? crt_step_lie8(s, t, h, y1, with_dense)
                                            : crt_step_lie5(s, t, h, y1, with_dense);
  }
#endif
  return crt_step_classical(s, crt_classical_method(s), t, y0, f0, h, y1, f1, with_dense);
}

static int crt_order(const crt_session *s)
{
  return crt_order_classical(crt_classical_method(s));
}

static void crt_dense_complete(crt_session *s)
{
  if (!s->dense.pending) return;
#if MODEL_LIE
  if (s->dense.lie) { crt_lie_dense_complete8(s); return; }
#endif
  crt_dense_complete_classical(s);
}

/* the dense output at t, completing it first if needed */
static void crt_dense_at(crt_session *s, double t, double *y)
{
  if (s->dense.pending) crt_dense_complete(s);
#if MODEL_LIE
  if (s->dense.lie) { crt_lie_dense_eval(s, t, y); return; }
#endif
  crt_dense_eval(&s->dense, t, y);
}

/* Hairer's starting step for the classical methods */
static double crt_initial_step(crt_session *s)
{
  double d0 = 0.0, d1 = 0.0, d2 = 0.0, h0, h1, y1[NQ], f1[NQ];
  int i;
  const int order = crt_order(s);
  for (i = 0; i < NQ; ++i) {
    const double sc = s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * fabs(s->q[i]);
    d0 += (s->q[i] / sc) * (s->q[i] / sc);
    d1 += (s->f[i] / sc) * (s->f[i] / sc);
  }
  d0 = sqrt(d0 / NQ); d1 = sqrt(d1 / NQ);
  h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
  h0 = crt_min(h0, s->opt[CRT_OPT_HMAX]);
  for (i = 0; i < NQ; ++i) y1[i] = s->q[i] + h0 * s->f[i];
  crt_rhs(s, s->t + h0, y1, f1);
  for (i = 0; i < NQ; ++i) {
    const double sc = s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * fabs(s->q[i]);
    const double r = (f1[i] - s->f[i]) / sc;
    d2 += r * r;
  }
  d2 = sqrt(d2 / NQ) / h0;
  if (crt_max(d1, d2) <= 1e-15) h1 = crt_max(1e-6, h0 * 1e-3);
  else h1 = pow(0.01 / crt_max(d1, d2), 1.0 / (order + 1));
  return crt_min(crt_min(100.0 * h0, h1), s->opt[CRT_OPT_HMAX]);
}

/* the first step of a run that gives none (opt[CRT_OPT_H0] = 0) with an adaptive method:
   Hairer's, on W for a Lie method, on the state for a classical one */
static double crt_first_step(crt_session *s)
{
#if MODEL_LIE
  if (crt_lie_active(s)) return crt_lie_initial_step(s, crt_order(s));
#endif
  return crt_initial_step(s);
}

/* ---- output rows ------------------------------------------------------------------------ */
/* rows every output_dt from the dense output of the current step, before t_stop (up to
   and including it when inclusive); returns 0 when the buffer filled first */
static int crt_flush_outputs(crt_session *s, crt_out *o, double t_stop, int inclusive)
{
  const double out_dt = s->opt[CRT_OPT_OUTPUT_DT];
  const double slack = inclusive ? 1e-9 * out_dt : 0.0;
  double y[NQ];
  if (!(out_dt > 0.0)) return 1;
  while (s->next_output < t_stop || (inclusive && s->next_output <= t_stop + slack)) {
    const double at = s->next_output < t_stop ? s->next_output : t_stop;
    if (o->n + 4 > o->cap) {
      s->out_pending = 1;
      s->out_until = t_stop;
      return 0;
    }
    crt_dense_at(s, at, y);
    crt_emit(o, at, y, CRT_ROW_STEP);
    s->out_k += 1.0;
    s->next_output = s->out_origin + s->out_k * out_dt;
  }
  s->out_pending = 0;
  return 1;
}

#endif /* CRT_STEP_H */
