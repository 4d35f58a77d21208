/*
 * crt_lie.h: flight on the integral -- the Lie-group steps for the attitude with K and C's
 * parabola as constants of the flight (models with MODEL_LIE).  The steps lie8 and lie5,
 * whose tableaus are written out term by term, are rendered into crt_lie_steps.h from
 * derive/runtime/tableaus.py; the limits CRT_LIE_* come from crt_constants.h.  crt_step.h
 * dispatches between these and the classical methods (crt_integrators.h).
 *
 * Hand-written C: this file is templates/runtime/crt_lie.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_LIE_H
#define CRT_LIE_H

/*
 * In flight the kinetic moment K about C is constant in fixed axes (E1.1) and C moves on
 * a parabola (E1.2).  The methods `lie`, `lie5` and `lie8` keep them as constants of the
 * flight (set from the state at the start of the run and after every event) and integrate
 * the attitude alone, A' = A skew(omega) (E1.8), with omega from E1.4 solved:
 *     J omega = A^T K - mu OP x V_r                                  (lie_stage)
 * (the moments models: J omega = A^T K - k of their moments, moments_lie_stage; the model
 * names its family's functions MODEL_LIE_STAGE, MODEL_LIE_POINT, MODEL_FIXED_KINETIC_MOMENT)
 * Over a step from t_n the attitude is A = A_n exp(W^) with W(t_n) = 0, and the step is
 * a Runge-Kutta step (the DOP853 or DOPRI5 coefficients, with their error estimates and
 * dense outputs) for W' = dexpinv(W, omega) in R^3 (Runge-Kutta-Munthe-Kaas with the
 * exponential map, derive/lie.py; a uniform rotation is integrated exactly).  A stays on
 * SO(3) whatever W the method returns: the session keeps the attitude as a unit
 * quaternion, composed with that of exp(W^) at every step, and writes its matrix into the
 * state.  K in fixed axes, hence |K| (E1.9), is exact by construction: the omega written
 * (step ends, dense output, event search) is the one E1.4 gives for that attitude.
 * `lie` takes the coefficients of `lie8` when rtol < CRT_LIE_TIGHT, of `lie5` otherwise.
 * The error is controlled on W (radians of attitude: scale atol + rtol).
 * In persistent contact (the reaction's moment changes K) and in models without an
 * attitude the classical method of the same order runs instead (DOP853, DOPRI5).
 */

#include "crt_constants.h"     /* CRT_LIE_TIGHT, CRT_LIE_MAX_W2, CRT_LIE_MAX_TURN */
#include "crt_integrators.h"   /* crt_dense_weights */

#if MODEL_LIE
/* ---- rotations: unit quaternions (w, x, y, z), Hamilton's product ----------------------- */
static void crt_quat_mul(const double *a, const double *b, double *c)
{
  c[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  c[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  c[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  c[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
}

static void crt_quat_normalize(double *q)
{
  const double r = 1.0 / sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  q[0] *= r; q[1] *= r; q[2] *= r; q[3] *= r;
}

/* the rotation matrix of a unit quaternion, row-major (R(p q) = R(p) R(q)) */
static void crt_quat_matrix(const double *q, double *R)
{
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  R[0] = w * w + x * x - y * y - z * z; R[1] = 2.0 * (x * y - w * z); R[2] = 2.0 * (x * z + w * y);
  R[3] = 2.0 * (x * y + w * z); R[4] = w * w - x * x + y * y - z * z; R[5] = 2.0 * (y * z - w * x);
  R[6] = 2.0 * (x * z - w * y); R[7] = 2.0 * (y * z + w * x); R[8] = w * w - x * x - y * y + z * z;
}

/* the unit quaternion of a rotation matrix (Shepperd's method: the largest of the four
   candidates, so no cancellation), normalised */
static void crt_matrix_quat(const double *R, double *q)
{
  const double tr = R[0] + R[4] + R[8];
  if (tr >= R[0] && tr >= R[4] && tr >= R[8]) {
    const double r = sqrt(1.0 + tr);
    q[0] = 0.5 * r; q[1] = 0.5 * (R[7] - R[5]) / r; q[2] = 0.5 * (R[2] - R[6]) / r;
    q[3] = 0.5 * (R[3] - R[1]) / r;
  } else if (R[0] >= R[4] && R[0] >= R[8]) {
    const double r = sqrt(1.0 + R[0] - R[4] - R[8]);
    q[1] = 0.5 * r; q[0] = 0.5 * (R[7] - R[5]) / r; q[2] = 0.5 * (R[1] + R[3]) / r;
    q[3] = 0.5 * (R[2] + R[6]) / r;
  } else if (R[4] >= R[8]) {
    const double r = sqrt(1.0 - R[0] + R[4] - R[8]);
    q[2] = 0.5 * r; q[0] = 0.5 * (R[2] - R[6]) / r; q[1] = 0.5 * (R[1] + R[3]) / r;
    q[3] = 0.5 * (R[5] + R[7]) / r;
  } else {
    const double r = sqrt(1.0 - R[0] - R[4] + R[8]);
    q[3] = 0.5 * r; q[0] = 0.5 * (R[3] - R[1]) / r; q[1] = 0.5 * (R[2] + R[6]) / r;
    q[2] = 0.5 * (R[5] + R[7]) / r;
  }
  crt_quat_normalize(q);
}

/* a rotation whose third row is the unit vector n (the vertical model knows n only; the
   heading it fixes is arbitrary and nothing depends on it) */
static void crt_frame_from_axis(const double *n, double *R)
{
  double a[3] = {1.0, 0.0, 0.0}, e1[3], e2[3], r;
  int i;
  if (fabs(n[0]) > 0.8) { a[0] = 0.0; a[1] = 1.0; }
  /* e1 = a - (a.n) n normalised, e2 = n x e1: rows e1, e2, n are right-handed */
  r = a[0] * n[0] + a[1] * n[1] + a[2] * n[2];
  for (i = 0; i < 3; ++i) e1[i] = a[i] - r * n[i];
  r = 1.0 / sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
  for (i = 0; i < 3; ++i) e1[i] *= r;
  e2[0] = n[1] * e1[2] - n[2] * e1[1];
  e2[1] = n[2] * e1[0] - n[0] * e1[2];
  e2[2] = n[0] * e1[1] - n[1] * e1[0];
  for (i = 0; i < 3; ++i) { R[i] = e1[i]; R[3 + i] = e2[i]; R[6 + i] = n[i]; }
}

/* R^T v */
static void crt_transpose_times(const double *R, const double *v, double *out)
{
  int j;
  for (j = 0; j < 3; ++j) out[j] = R[j] * v[0] + R[3 + j] * v[1] + R[6 + j] * v[2];
}

/* ---- the constants of a flight ------------------------------------------------------------ */
/* From the state at s->t: C at the flight start, K in fixed axes (fixed_kinetic_moment, E1.4),
   the attitude as a unit quaternion (the state's own matrix; for the vertical model a frame
   with the state's n as third row; for the attitude model the identity). */
static void crt_lie_restart(crt_session *s)
{
  crt_lie *L = &s->lie;
  double R[9], omega[3];
  const double *u = crt_u(s, s->t);
  const int kind = model_lie_read(s->q, L->c0, omega, R, &L->n_scale);
  int i;
  if (kind == 1) {
    double n[3];
    for (i = 0; i < 3; ++i) n[i] = R[6 + i] / L->n_scale;
    crt_frame_from_axis(n, R);
  } else if (kind == 2) {
    for (i = 0; i < 9; ++i) R[i] = (i % 4 == 0) ? 1.0 : 0.0;
  }
  crt_matrix_quat(R, L->quat);
  crt_quat_matrix(L->quat, L->R);
#if MODEL_HAS_PLANE
  if (s->plane) {
    /* the state's attitude becomes the rotation the quaternion holds (a classical
       method, in contact, lets A drift off the rotations by its tolerance): the session
       takes that state, with Z_C moved so that the height of S does not change (S
       stays on the plane at a lift-off) */
    double qn[NQ], hb, ha, vb, va;
    model_lie_state(s->prm, L->c0, 0.0, omega, L->R, L->n_scale, qn);
    model_gap(s->prm, u, s->q, &hb, &vb);
    model_gap(s->prm, u, qn, &ha, &va);
    qn[MODEL_Z] += hb - ha;
    L->c0[2] += hb - ha;
    for (i = 0; i < NQ; ++i) s->q[i] = qn[i];
    s->g_valid = 0;
  }
#endif
  MODEL_FIXED_KINETIC_MOMENT(L->R, omega, u, s->prm, L->K);
  crt_transpose_times(L->R, L->K, L->k);
  for (i = 0; i < 3; ++i) L->omega[i] = omega[i];
  L->t_f = s->t;
  L->valid = 1;
}

/* the accepted step's end becomes the session's attitude */
static void crt_lie_accept(crt_session *s)
{
  crt_lie *L = &s->lie;
  int i;
  for (i = 0; i < 4; ++i) L->quat[i] = L->quat_end[i];
  for (i = 0; i < 3; ++i) L->omega[i] = L->omega_end[i];
  crt_quat_matrix(L->quat, L->R);
  crt_transpose_times(L->R, L->K, L->k);
}

/* one stage: W' and omega at (t, W) for the attitude A_n exp(W^), k = A_n^T K */
static void crt_lie_eval(crt_session *s, double t, const double *W, const double *k,
                         double *dW, double *omega)
{
  ++s->stat[CRT_STAT_RHS_EVALUATIONS];
  MODEL_LIE_STAGE(W, k, crt_u(s, t), s->prm, dW, omega);
}

/* the end of a step: the attitude A_n cay(W1) as a quaternion and the model's state */
static void crt_lie_finish(crt_session *s, double t1, const double *W1, double *y1)
{
  crt_lie *L = &s->lie;
  double E[9], c[4], R[9];
  exp_map(W1, E, c);
  crt_quat_mul(L->quat, c, L->quat_end);
  crt_quat_normalize(L->quat_end);
  crt_quat_matrix(L->quat_end, R);
  model_lie_state(s->prm, L->c0, t1 - L->t_f, L->omega_end, R, L->n_scale, y1);
}

static void crt_lie_dense_start(crt_session *s, double t, double h, int m, int pending)
{
  crt_dense *d = &s->dense;
  const crt_lie *L = &s->lie;
  int i;
  d->t0 = t; d->h = h; d->m = m; d->pending = pending; d->lie = 1;
  for (i = 0; i < 9; ++i) d->R0[i] = L->R[i];
  for (i = 0; i < 3; ++i) d->k0[i] = L->k[i];
  for (i = 0; i < 6; ++i) d->c0[i] = L->c0[i];
  d->t_f = L->t_f;
  d->n_scale = L->n_scale;
}

/* Exponential coordinates of a step beyond |W| = CRT_LIE_THETA_MAX rad (CRT_LIE_MAX_W2 is
   its square) are refused: the series of derive/lie.py are exact to rounding up to there.
   Steps are kept below a turn of CRT_LIE_MAX_TURN radians at the rate of the step's start
   so that this rarely happens.  A refused chart returns an error norm that shrinks the
   step by about 0.45 |W|max/|W|. */
static double crt_lie_refuse(double big, int order)
{
  return pow(4.0 * big / CRT_LIE_MAX_W2, 0.5 * order);
}

#include "crt_lie_steps.h"     /* crt_step_lie8, crt_lie_dense_complete8, crt_step_lie5 */

/* the state at t from the dense output of W: A = A_n cay(W(t)) (a rotation whatever W),
   omega from E1.4 at that attitude, C on its parabola */
static void crt_lie_dense_eval(crt_session *s, double t, double *y)
{
  const crt_dense *d = &s->dense;
  double w[CRT_MAX_DENSE], W[3], omega[3], C[9], R[9];
  int i, j, l;
  crt_dense_weights(d, t, w);
  for (i = 0; i < 3; ++i) {
    double acc = 0.0;
    for (j = 0; j < d->m; ++j) acc += w[j] * d->F[j][i];
    W[i] = acc;
  }
  ++s->stat[CRT_STAT_RHS_EVALUATIONS];
  MODEL_LIE_POINT(W, d->k0, crt_u(s, t), s->prm, C, omega);
  for (i = 0; i < 3; ++i)
    for (j = 0; j < 3; ++j) {
      double acc = 0.0;
      for (l = 0; l < 3; ++l) acc += d->R0[3 * i + l] * C[3 * l + j];
      R[3 * i + j] = acc;
    }
  model_lie_state(s->prm, d->c0, t - d->t_f, omega, R, d->n_scale, y);
}

/* Hairer's starting step for W' = dexpinv(W, omega), W(t) = 0 */
static double crt_lie_initial_step(crt_session *s, int order)
{
  crt_lie *L = &s->lie;
  const double sc = s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL];
  double d1 = 0.0, d2 = 0.0, h0, h1, W[3], f1[3], omega[3];
  int i;
  if (!L->valid) crt_lie_restart(s);
  for (i = 0; i < 3; ++i) d1 += (L->omega[i] / sc) * (L->omega[i] / sc);
  d1 = sqrt(d1 / 3.0);
  /* Hairer's h0 = 0.01 |y0|/|f0| with the attitude's scale, |y0| = 1 (W itself is 0) */
  h0 = d1 * sc < 1e-5 ? 1e-6 : 0.01 / (d1 * sc);
  h0 = crt_min(h0, s->opt[CRT_OPT_HMAX]);
  for (i = 0; i < 3; ++i) W[i] = h0 * L->omega[i];
  crt_lie_eval(s, s->t + h0, W, L->k, f1, omega);
  for (i = 0; i < 3; ++i) {
    const double r = (f1[i] - L->omega[i]) / sc;
    d2 += r * r;
  }
  d2 = sqrt(d2 / 3.0) / h0;
  if (crt_max(d1, d2) <= 1e-15) h1 = crt_max(1e-6, h0 * 1e-3);
  else h1 = pow(0.01 / crt_max(d1, d2), 1.0 / (order + 1));
  return crt_min(crt_min(100.0 * h0, h1), s->opt[CRT_OPT_HMAX]);
}
#else
/* without the momentum form no Lie method is active (crt_lie_active): nothing to accept */
static void crt_lie_accept(crt_session *s)
{
  (void)s;
}
#endif /* MODEL_LIE */

#endif /* CRT_LIE_H */
