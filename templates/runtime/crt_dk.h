/*
 * crt_dk.h: Darboux-Keller -- one frictional impact at S, integrated in the normal impulse.
 * A law of impact that needs only math: the Delassus matrix W and the velocity of S before
 * the impact in, the impulse, the velocity after and the work of each component out
 * (crt_dk_impact).  It reads no session; the rough contact (crt_rough.h) calls it at every
 * impact with the model's W (model_delassus), and crt_eval_impact exposes it.  It uses
 * the model's emitted impulse_slip_direction_rate, impulse_stick_rate and impulse_resliding
 * (derive/friction_models.py), crt_math.h and the return codes of crt_abi.h.
 *
 * Hand-written C: this file is templates/runtime/crt_dk.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * ---- The derivation (derive/friction.py; the functions from derive/friction_models.py) ---
 * The reaction at S is R = N e_Z + R_t with |R_t| <= mu_f N.  An impulse P at S changes the
 * velocity of S by W P, W the Delassus matrix (fixed axes, model_delassus: three solves
 * with J).  An impact is integrated in the normal impulse p (Darboux-Keller),
 * y = (v_X, v_Y, v_Z, P_X, P_Y, E_n, E_t):
 *   slip (v_t != 0): dv/dp = W (e_Z - mu_f sigma), sigma = v_t/|v_t|
 *                                                   (impulse_slip_direction_rate)
 *   stick (v_t = 0, |tau| <= mu_f): dP_t/dp = tau keeps v_t = 0          (impulse_stick_rate)
 *   re-slide (v_t = 0, |tau| > mu_f): along the ray sigma(c), |sigma(c)| = 1 (impulse_resliding)
 * W is constant during an impact, so stick and re-sliding last to its end at constant
 * rates, whose events are solved in closed form; the slip is integrated by DOP853
 * (crt_dk_step, rendered in crt_dk_steps.h) unless its direction is a ray of the slip
 * equations (W_tn - mu_f W_tt sigma parallel to sigma: a sphere about its centre, or a
 * plane motion), where its rates are constant too.  Compression ends where v_Z = 0;
 * restitution (the law: energetic, the default; poisson; newton) where E_n = (1 - e^2) E_c
 * (energetic), p = (1 + e) p_c (poisson) or v_Z = -e v_n- (newton: refused, status
 * restitution_refused, where mu_f |W_tn| > 0, since there it can gain energy).  An impact
 * whose normal velocity stops growing (dv_n/dp <= 0 with v_n < 0) is refused with status
 * painleve.  The state after is model_apply_impulse's (V_C + P/(m+M), omega + J^-1
 * (CS x A^T P)).
 */
#ifndef CRT_DK_H
#define CRT_DK_H

#include "crt_abi.h"           /* CRT_OK, CRT_PAINLEVE, CRT_RESTITUTION_* */
#include "crt_math.h"

#define CRT_DK_N 7            /* Darboux-Keller's state: v_X, v_Y, v_Z, P_X, P_Y, E_n, E_t */

typedef struct {
  double P[3];                /* the impulse at S (P_X, P_Y, p), fixed axes */
  double v_minus[3];          /* the velocity of S before, and after */
  double v[3];
  double work_n, work_t;      /* E_n = int v_Z dp, E_t = int (v_t, dP_t) <= 0 */
  int stage;                  /* 0 S slipped to the end (or never slipped with mu_f = 0),
                                 1 the slip stopped (or was 0) and S stuck, 2 it re-slid */
} crt_dk_result;

typedef struct {
  const double *w6;
  double mu_f, e, v_n0;
  int law;
  double p, y[CRT_DK_N];      /* p and (v_X, v_Y, v_Z, P_X, P_Y, E_n, E_t) */
  int compressed, done;
  double p_c, E_c;            /* p and E_n where compression ended */
} crt_dk;

/* where restitution ends: zero there, negative before (derive/friction.py, terminations) */
static double crt_dk_termination(const crt_dk *k, double p, const double *y)
{
  if (k->law == CRT_RESTITUTION_POISSON) return p - (1.0 + k->e) * k->p_c;
  if (k->law == CRT_RESTITUTION_NEWTON) return y[2] + k->e * k->v_n0;
  return y[5] - (1.0 - k->e * k->e) * k->E_c;
}

/* constant rates (dv, dP_t) over d, the slip speed rho0 + c d' along the stretch */
static void crt_dk_advance(crt_dk *k, const double *dv, const double *dPt, double rho0,
                           double c, double d)
{
  const double v_n = k->y[2];
  k->y[0] += dv[0] * d; k->y[1] += dv[1] * d; k->y[2] += dv[2] * d;
  k->y[3] += dPt[0] * d; k->y[4] += dPt[1] * d;
  k->y[5] += v_n * d + 0.5 * dv[2] * d * d;
  k->y[6] -= k->mu_f * (rho0 * d + 0.5 * c * d * d);
  k->p += d;
}

/* smallest root x >= 0 of a2 x^2 + a1 x + a0 where it crosses upwards, or -1 */
static double crt_dk_first_root(double a2, double a1, double a0)
{
  double disc, r, qv, x1, x2, lo, hi;
  if (a2 == 0.0) return (a1 > 0.0 && -a0 / a1 >= 0.0) ? -a0 / a1 : -1.0;
  disc = a1 * a1 - 4.0 * a2 * a0;
  if (disc < 0.0) return -1.0;
  r = sqrt(disc);
  qv = -0.5 * (a1 + (a1 >= 0.0 ? r : -r));
  x1 = qv != 0.0 ? qv / a2 : 0.0;
  x2 = qv != 0.0 ? a0 / qv : 0.0;
  lo = crt_min(x1, x2); hi = crt_max(x1, x2);
  if (lo >= -1e-15 * crt_max(1.0, fabs(hi)) && 2.0 * a2 * lo + a1 >= 0.0) return crt_max(lo, 0.0);
  if (hi >= -1e-15 * crt_max(1.0, fabs(hi)) && 2.0 * a2 * hi + a1 >= 0.0) return crt_max(hi, 0.0);
  return -1.0;
}

/* At constant rates for at most d_max (HUGE_VAL: to the end of the impact), the slip speed
   rho0 + c d: compression and restitution end where they do, in closed form.  Returns
   CRT_OK, or CRT_PAINLEVE when the impact cannot end at these rates. */
static int crt_dk_constant(crt_dk *k, const double *dv, const double *dPt, double rho0,
                           double c, double d_max)
{
  const double a_n = dv[2];
  double d;
  if (!k->compressed) {
    const double v_n = k->y[2];
    double d_c;
    if (v_n >= 0.0) d_c = 0.0;
    else if (a_n > 0.0) d_c = -v_n / a_n;
    else d_c = HUGE_VAL;
    if (d_c > d_max) { crt_dk_advance(k, dv, dPt, rho0, c, d_max); return CRT_OK; }
    if (d_c == HUGE_VAL) return CRT_PAINLEVE;
    crt_dk_advance(k, dv, dPt, rho0, c, d_c);
    k->y[2] = 0.0;
    k->compressed = 1; k->p_c = k->p; k->E_c = k->y[5];
    if (k->e == 0.0) { k->done = 1; return CRT_OK; }
    rho0 += c * d_c;
    d_max -= d_c;
  }
  if (k->law == CRT_RESTITUTION_POISSON) d = (1.0 + k->e) * k->p_c - k->p;
  else if (k->law == CRT_RESTITUTION_NEWTON)
    d = a_n > 0.0 ? (-k->e * k->v_n0 - k->y[2]) / a_n : -1.0;
  else d = crt_dk_first_root(0.5 * a_n, k->y[2], k->y[5] - (1.0 - k->e * k->e) * k->E_c);
  if (d >= 0.0 && d <= d_max) {
    crt_dk_advance(k, dv, dPt, rho0, c, d);
    k->done = 1;
    return CRT_OK;
  }
  if (d_max == HUGE_VAL) return CRT_PAINLEVE;
  crt_dk_advance(k, dv, dPt, rho0, c, d_max);
  return CRT_OK;
}

/* The slip stage's rates, the slip in polar coordinates: the emitted
   impulse_slip_direction_rate at the unit slip sigma = (cos theta, sin theta) gives dv/dp = W (e_Z - mu_f sigma) and
   dP_t/dp = -mu_f sigma, and rho' = (sigma, dv_t/dp), theta' = (sigma x dv_t/dp)/rho,
   E_t' = -mu_f rho.  In the impulse (log_rho = 0): y = (rho, theta, v_Z, P_X, P_Y, E_n,
   E_t) along p; rho crosses 0 smoothly (theta stays continuous), where the Cartesian slip
   would chatter about 0.  Near the stop of the slip theta' grows as rho^(kappa - 1) (the
   direction converges only as a power of rho), and steps in p shrink with rho; there the
   independent variable is s = ln rho (log_rho = 1): y = (p, theta, v_Z, P_X, P_Y, E_n, E_t)
   along s, dy/ds = dy/dp rho/rho', and theta converges exponentially in s.  Valid while
   rho' < 0: else NaN, which the step control refuses. */
static void crt_dk_rate(const double *w6, double mu_f, int log_rho, double x, const double *y,
                        double *dy)
{
  double sg[2], du[3], rho, rho_p, dp;
  crt_sincos(y[1], &sg[1], &sg[0]);
  impulse_slip_direction_rate(sg, w6, mu_f, du);
  rho_p = sg[0] * du[0] + sg[1] * du[1];
  if (!log_rho) {
    rho = y[0];
    dy[0] = rho_p;
    dy[1] = rho != 0.0 ? (sg[0] * du[1] - sg[1] * du[0]) / rho : 0.0;
    dp = 1.0;
  } else {
    rho = exp(x);
    dp = rho_p < 0.0 ? rho / rho_p : NAN;
    dy[0] = dp;
    dy[1] = (sg[0] * du[1] - sg[1] * du[0]) / rho_p;
  }
  dy[2] = du[2] * dp; dy[3] = -mu_f * sg[0] * dp; dy[4] = -mu_f * sg[1] * dp;
  dy[5] = y[2] * dp;
  dy[6] = -mu_f * rho * dp;
}

#include "crt_dk_steps.h"    /* crt_dk_step: DOP853 on crt_dk_rate */

/* the event functions of the slip stage, each positive before it and <= 0 at it: the slip
   speed down to rho_stop (0, in p only), compression (1), restitution (2); x is p or s */
static double crt_dk_event(const crt_dk *k, int which, int log_rho, double x, const double *y,
                           double rho_stop)
{
  if (which == 0) return y[0] - rho_stop;
  if (which == 1) return -y[2];
  return -crt_dk_termination(k, log_rho ? y[0] : x, y);
}

/* The first zero of event `which` in the step of length h from (x0, y0) (g0 > 0 at its
   start, g1 <= 0 at its end), by the Anderson-Bjorck regula falsi on the fraction of the
   step, each value from a re-step of DOP853 from y0 (the method's own solution there);
   y_at: the state at the returned fraction. */
static double crt_dk_root(const crt_dk *k, int which, int log_rho, double x0, const double *y0,
                          const double *f0, double h, double g0, double g1, double rho_stop,
                          const double *scale, double rtol, double *y_at)
{
  double a = 0.0, b = 1.0, ga = g0, gb = g1, f1[CRT_DK_N];
  const double tol = 4.0 * CRT_EPS * (fabs(x0) + fabs(h)) / fabs(h);
  int side = 0, it;
  for (it = 0; it < 100 && b - a > tol; ++it) {
    double c = (a * gb - b * ga) / (gb - ga), gc;
    if (!(c > a && c < b)) c = 0.5 * (a + b);
    crt_dk_step(k->w6, k->mu_f, log_rho, x0, y0, f0, c * h, y_at, f1, scale, rtol);
    gc = crt_dk_event(k, which, log_rho, x0 + c * h, y_at, rho_stop);
    if (gc > 0.0) {
      if (side == 1) { const double m = 1.0 - gc / ga; gb *= m > 0.0 ? m : 0.5; }
      a = c; ga = gc; side = 1;
    } else {
      if (side == -1) { const double m = 1.0 - gc / gb; ga *= m > 0.0 ? m : 0.5; }
      b = c; gb = gc; side = -1;
      if (gc == 0.0) break;
    }
  }
  crt_dk_step(k->w6, k->mu_f, log_rho, x0, y0, f0, b * h, y_at, f1, scale, rtol);
  return b;
}

/* The turn of the slip's direction per unit of ln rho, F(theta) = (sigma x r_t)/(sigma .
   r_t) with r_t = dv_t/dp along sigma = (cos theta, sin theta): the direction obeys the
   autonomous d theta/d ln rho = F(theta) wherever rho' = (sigma . r_t) != 0, so F = 0 on
   the rays of the slip equations (directions the slip keeps); rho_p: rho' there; dF: F'
   (r_t is affine in sigma, r_t = W_tn - mu_f W_tt sigma, so its derivative along theta is
   r_t(sigma_perp) - W_tn, sigma_perp = (-sin theta, cos theta)). */
static double crt_dk_turn(const crt_dk *k, double theta, double *rho_p, double *dF)
{
  double sg[2], sp[2], r[3], rq[3], cross, dot, dr[2];
  crt_sincos(theta, &sg[1], &sg[0]);
  sp[0] = -sg[1]; sp[1] = sg[0];
  impulse_slip_direction_rate(sg, k->w6, k->mu_f, r);
  impulse_slip_direction_rate(sp, k->w6, k->mu_f, rq);
  dr[0] = rq[0] - k->w6[2]; dr[1] = rq[1] - k->w6[4];      /* W_tn = (W_XZ, W_YZ) */
  cross = sg[0] * r[1] - sg[1] * r[0];
  dot = sg[0] * r[0] + sg[1] * r[1];
  *rho_p = dot;
  /* d(cross) = sigma_perp x r + sigma x r';  d(dot) = sigma_perp . r + sigma . r' */
  *dF = ((sp[0] * r[1] - sp[1] * r[0] + sg[0] * dr[1] - sg[1] * dr[0]) * dot
         - cross * (sp[0] * r[0] + sp[1] * r[1] + sg[0] * dr[0] + sg[1] * dr[1]))
        / (dot * dot);
  return cross / dot;
}

/* The slip decreasing at speed rho along *theta near the ray it converges to: Newton on
   F from *theta for the ray theta* (F' > 0: the ray attracts as rho decreases, the
   deviation shrinks as rho^F'); when the rest of the slip's path, within rho |theta -
   theta*| of the ray's, is within tol, *theta = theta* and 1, else 0. */
static int crt_dk_ray_near(const crt_dk *k, double rho, double *theta, double tol)
{
  double th = *theta, F = 1.0, dF = 0.0, rp;
  int it;
  for (it = 0; it < 12; ++it) {
    double step;
    F = crt_dk_turn(k, th, &rp, &dF);
    if (!(rp < 0.0) || !(dF > 0.0)) return 0;
    step = -F / dF;
    th += step;
    if (fabs(step) <= 1e-14) break;
  }
  F = crt_dk_turn(k, th, &rp, &dF);
  if (!(rp < 0.0) || !(fabs(F) <= 1e-12 * crt_max(1.0, dF))) return 0;
  if (!(rho * fabs(th - *theta) <= tol)) return 0;
  *theta = th;
  return 1;
}

/* DOP853 with step-size control on the slip stage from (*x, y) (crt_dk_rate: x is p, or
   s = ln rho when log_rho) towards x_end, stopping at the first event (returned: 0 the slip
   at rho_stop, 1 compression ends, 2 restitution ends), at x_end (3), in s where the
   direction is within rtol of the ray it converges to (4: y[1] set to the ray, which the
   caller follows at constant rates; crt_dk_ray_near), or -1 when the steps underflow or p
   passes p_max (a jam; or in s, the slip not decreasing).  A slip below rho_stop but above
   rho_soft at a step's end stops there, without its root (a switch of variables needs no
   exact point; HUGE_VAL: always the root).  x and y are left at the stop;
   k->p follows p; scale[2] is the velocities' scale (the direction's, scale[1], is set
   from it step by step). */
static int crt_dk_integrate(crt_dk *k, int log_rho, double *x, double *y, double x_end,
                            double rho_stop, double rho_soft, double rtol,
                            const double *scale_in, double h, double p_max)
{
  double f[CRT_DK_N], y1[CRT_DK_N], f1[CRT_DK_N], scale[CRT_DK_N];
  const double dir = x_end >= *x ? 1.0 : -1.0;
  double h_old = 0.0, err_old = 0.0;
  int it, i, rejected = 0;
  for (i = 0; i < CRT_DK_N; ++i) scale[i] = scale_in[i];
  crt_dk_rate(k->w6, k->mu_f, log_rho, *x, y, f);
  h = dir * fabs(h);
  for (it = 0; it < 100000; ++it) {
    double norm, frac = HUGE_VAL, y_ev[CRT_DK_N] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    int which, hit = -1, last = 0;
    /* the direction's error moves v by rho times it: its scale is the velocities' over
       rho (at the step's start; rho falls along the stop's approach) */
    scale[1] = scale[2] / crt_max(log_rho ? exp(*x) : fabs(y[0]), rho_stop);
    if ((log_rho ? y[0] : *x) > p_max || !(fabs(h) > 1e-14 * crt_max(fabs(*x), 1e-300)))
      return -1;
    if (dir * (*x + h - x_end) >= 0.0) { h = x_end - *x; last = 1; }
    norm = crt_dk_step(k->w6, k->mu_f, log_rho, *x, y, f, h, y1, f1, scale, rtol);
    if (!(norm <= 1.0)) {
      h *= (norm == norm) ? crt_max(0.2, 0.9 * pow(norm, -0.125)) : 0.25;
      rejected = 1;
      continue;
    }
    for (which = log_rho ? 1 : 0; which < 3; ++which) {
      double g0, g1, at, y_at[CRT_DK_N];
      if (which == 1 && k->compressed) continue;
      if (which == 2 && !k->compressed) continue;
      g0 = crt_dk_event(k, which, log_rho, *x, y, rho_stop);
      g1 = crt_dk_event(k, which, log_rho, *x + h, y1, rho_stop);
      if (!(g0 > 0.0 && g1 <= 0.0)) continue;
      if (which == 0 && y1[0] > rho_soft) {     /* the step's end will do */
        at = 1.0;
        for (i = 0; i < CRT_DK_N; ++i) y_at[i] = y1[i];
      } else {
        at = crt_dk_root(k, which, log_rho, *x, y, f, h, g0, g1, rho_stop, scale, rtol,
                         y_at);
      }
      if (at < frac) {
        frac = at; hit = which;
        for (i = 0; i < CRT_DK_N; ++i) y_ev[i] = y_at[i];
      }
    }
    if (hit >= 0) {
      *x += frac * h;
      for (i = 0; i < CRT_DK_N; ++i) y[i] = y_ev[i];
      k->p = log_rho ? y[0] : *x;
      return hit;
    }
    *x = last ? x_end : *x + h;
    for (i = 0; i < CRT_DK_N; ++i) { y[i] = y1[i]; f[i] = f1[i]; }
    k->p = log_rho ? y[0] : *x;
    if (last) return 3;
    if (log_rho && exp(*x) * fabs(f[1]) <= 1e2 * rtol * scale[2]
        && crt_dk_ray_near(k, exp(*x), &y[1], rtol * scale[2])) return 4;
    /* no growth right after a rejection (the step the slip needs shrinks as rho does) */
    {
      /* Gustafsson's predictive control: the step the slip needs shrinks steadily as rho
         does (in p), which the ratio of the last two errors foresees; no growth right
         after a rejection */
      const double err = crt_max(norm, 1e-10);
      double fac = 0.9 * pow(err, -0.125);
      if (h_old != 0.0) fac *= crt_min(1.0, fabs(h / h_old) * pow(err_old / err, 0.125));
      h_old = h; err_old = err;
      h *= crt_min(rejected ? 1.0 : 5.0, crt_max(0.2, fac));
      rejected = 0;
    }
  }
  return -1;
}

/* polar state along p <-> along s = ln rho (crt_dk_rate) */
static void crt_dk_to_log(double *x, double *y)
{
  const double rho = y[0];
  y[0] = *x;
  *x = log(rho);
}

static void crt_dk_from_log(double *x, double *y)
{
  const double p = y[0];
  y[0] = exp(*x);
  *x = p;
}

/* S slipping at the speed rho along theta, a ray of the slip equations: the slip stays on
   it, with constant rates dv/dp = W (e_Z - mu_f sigma) and the slip speed rho + c (p - p0),
   c = (sigma, dv_t/dp), to its stop where c < 0 (v_t = 0 then, k->done == 0), or to the
   end of the impact. */
static int crt_dk_ray_stretch(crt_dk *k, double rho, double theta)
{
  const double mu_f = k->mu_f;
  const double sg[2] = {cos(theta), sin(theta)};
  const double dPt[2] = {-mu_f * sg[0], -mu_f * sg[1]};
  double dv[3], c;
  int status;
  impulse_slip_direction_rate(sg, k->w6, mu_f, dv);
  c = sg[0] * dv[0] + sg[1] * dv[1];
  status = crt_dk_constant(k, dv, dPt, rho, c, c < 0.0 ? rho / -c : HUGE_VAL);
  if (status == CRT_OK && !k->done) { k->y[0] = 0.0; k->y[1] = 0.0; }
  return status;
}

/* The slip stage, until the slip stops (returns CRT_OK with k->done == 0 and v_t = 0), or
   the impact ends (k->done), or CRT_PAINLEVE.  In the impulse p down to rho = 1e-1 of the
   velocities' scale (the end of the step that passes it: the switch needs no exact point;
   a decade of rho costs several steps in p and about one in s, which is why the switch
   is early); then in s = ln rho down to rho = delta = rtol times that scale
   (falling back to p where the slip stops decreasing); the last stretch to 0 at the rates
   there (an error of the order of delta in v, as in derive/darboux_keller.py).
   Compression ending on the way sets v_Z = 0 and goes on (with e = 0 the impact ends). */
static int crt_dk_slip(crt_dk *k, double rtol, double s_v, double s_p)
{
  const double delta = rtol * s_v, rho_switch = 1e-1 * s_v;
  const double p_max = 1e6 * (1.0 + k->e) * s_p;    /* a jam beyond this */
  const double scale_p[CRT_DK_N] = {s_v, 1.0, s_v, s_p, s_p, s_v * s_p, s_v * s_p};
  const double scale_s[CRT_DK_N] = {s_p, 1.0, s_v, s_p, s_p, s_v * s_p, s_v * s_p};
  double y[CRT_DK_N], f[CRT_DK_N], x = k->p;
  int i, hit, use_log = 1, status = CRT_PAINLEVE;
  y[0] = sqrt(k->y[0] * k->y[0] + k->y[1] * k->y[1]);
  y[1] = atan2(k->y[1], k->y[0]);
  for (i = 2; i < CRT_DK_N; ++i) y[i] = k->y[i];
  for (;;) {
    hit = -2;                              /* -2: no stop yet */
    if (use_log && y[0] > rho_switch) {
      hit = crt_dk_integrate(k, 0, &x, y, HUGE_VAL, rho_switch, 1e2 * delta, rtol, scale_p,
                             0.05 * s_p, p_max);
      if (hit == 0) hit = -2;              /* at the switch */
    }
    if (hit == -2 && use_log && crt_dk_ray_near(k, y[0], &y[1], rtol * s_v)) hit = 4;
    if (hit == -2 && use_log) {
      crt_dk_rate(k->w6, k->mu_f, 0, x, y, f);
      if (f[0] < 0.0 && y[0] > delta) {
        crt_dk_to_log(&x, y);
        hit = crt_dk_integrate(k, 1, &x, y, log(delta), delta, HUGE_VAL, rtol, scale_s, 0.5,
                               p_max);
        crt_dk_from_log(&x, y);
        if (hit == 3) hit = 0;             /* the slip at delta */
      }
      if (hit == -1 || hit == -2) {
        use_log = 0;                       /* the slip does not decrease: in p to delta */
        hit = -2;
      }
    }
    if (hit == -2)
      hit = crt_dk_integrate(k, 0, &x, y, HUGE_VAL, delta, HUGE_VAL, rtol, scale_p, 1e-3 * s_p,
                             p_max);
    if (hit == -1) break;
    if (hit == 4) {
      /* a ray: to the stop of the slip at constant rates (crt_dk_ray_stretch) */
      k->p = x;
      k->y[0] = y[0] * cos(y[1]);
      k->y[1] = y[0] * sin(y[1]);
      for (i = 2; i < CRT_DK_N; ++i) k->y[i] = y[i];
      return crt_dk_ray_stretch(k, y[0], y[1]);
    }
    if (hit == 0) {
      /* the last stretch from delta to 0 at the rates there */
      crt_dk_rate(k->w6, k->mu_f, 0, x, y, f);
      if (f[0] < 0.0) {
        const double dp = -y[0] / f[0];
        for (i = 0; i < CRT_DK_N; ++i) y[i] += dp * f[i];
        x += dp;
      }
      y[0] = 0.0;
      status = CRT_OK;
      break;
    }
    if (hit == 1) {
      y[2] = 0.0;
      k->compressed = 1; k->p_c = x; k->E_c = y[5];
      if (k->e == 0.0) { k->done = 1; status = CRT_OK; break; }
      continue;
    }
    k->done = 1;
    status = CRT_OK;
    break;
  }
  k->p = x;
  k->y[0] = y[0] * cos(y[1]);
  k->y[1] = y[0] * sin(y[1]);
  for (i = 2; i < CRT_DK_N; ++i) k->y[i] = y[i];
  return status;
}

/* The re-sliding ray's rate c: Newton on f(c) = |sigma(c)|^2 - 1 from c = 0 (convex and
   decreasing for c > 0: the iterates rise monotonically to its one root) */
static double crt_dk_ray(const double *w6, double mu_f, double *sigma)
{
  double c = 0.0, f, df;
  int it;
  for (it = 0; it < 100; ++it) {
    double step;
    impulse_resliding(w6, mu_f, c, sigma, &f, &df);
    step = -f / df;
    if (!(step > 4e-16 * c)) break;
    c += step;
  }
  impulse_resliding(w6, mu_f, c, sigma, &f, &df);
  return c;
}

/* One impact: W (upper triangle w6), the velocity of S before v0 (v0[2] < 0), mu_f, e, the
   restitution law and the tolerance of the slip stage.  Returns CRT_OK (result in r),
   CRT_PAINLEVE or CRT_RESTITUTION_REFUSED. */
static int crt_dk_impact(const double *w6, const double *v0, double mu_f, double e, int law,
                         double rtol, crt_dk_result *r)
{
  crt_dk k;
  const double s_v = crt_max(fabs(v0[0]), crt_max(fabs(v0[1]), fabs(v0[2])));
  const double s_p = s_v / w6[5];
  const double rho0 = sqrt(v0[0] * v0[0] + v0[1] * v0[1]);
  double w_max = 0.0;
  int i, status = CRT_OK;
  for (i = 0; i < 6; ++i) w_max = crt_max(w_max, fabs(w6[i]));
  if (law == CRT_RESTITUTION_NEWTON
      && mu_f * sqrt(w6[2] * w6[2] + w6[4] * w6[4]) > 1e-12 * w_max)
    return CRT_RESTITUTION_REFUSED;
  k.w6 = w6; k.mu_f = mu_f; k.e = e; k.v_n0 = v0[2]; k.law = law;
  k.p = 0.0; k.compressed = 0; k.done = 0; k.p_c = 0.0; k.E_c = 0.0;
  for (i = 0; i < 3; ++i) k.y[i] = v0[i];
  for (i = 3; i < CRT_DK_N; ++i) k.y[i] = 0.0;
  r->stage = 0;
  if (mu_f == 0.0) {
    const double dv[3] = {w6[2], w6[4], w6[5]}, dPt[2] = {0.0, 0.0};
    status = crt_dk_constant(&k, dv, dPt, 0.0, 0.0, HUGE_VAL);
  } else {
    if (rho0 > 0.0) {
      /* the slip's direction is a ray of the slip equations when the tangential rate
         W_tn - mu_f W_tt sigma is parallel to sigma: constant rates, else DOPRI5 */
      const double sg[2] = {v0[0] / rho0, v0[1] / rho0};
      double rt[3], cross;
      impulse_slip_direction_rate(sg, w6, mu_f, rt);
      cross = sg[0] * rt[1] - sg[1] * rt[0];
      const double size = fabs(rt[0]) + fabs(rt[1]) + mu_f * w_max;
      if (fabs(cross) <= 1e-14 * size) {
        status = crt_dk_ray_stretch(&k, rho0, atan2(sg[1], sg[0]));
      } else {
        status = crt_dk_slip(&k, rtol, s_v, s_p);
      }
    }
    if (status == CRT_OK && !k.done) {
      /* v_t = 0: stick when |tau| <= mu_f, else re-slide along the ray (both at constant
         rates to the end: W is constant) */
      double dy[CRT_DK_N], tau[2], margin;
      impulse_stick_rate(k.y, w6, mu_f, dy, tau, &margin);
      if (margin >= -1e-12 * mu_f * mu_f) {
        const double dv[3] = {0.0, 0.0, dy[2]};
        r->stage = 1;
        status = crt_dk_constant(&k, dv, tau, 0.0, 0.0, HUGE_VAL);
      } else {
        double sigma[2], c = crt_dk_ray(w6, mu_f, sigma);
        const double dPt[2] = {-mu_f * sigma[0], -mu_f * sigma[1]};
        double dv[3];
        impulse_slip_direction_rate(sigma, w6, mu_f, dv);
        r->stage = 2;
        status = crt_dk_constant(&k, dv, dPt, 0.0, c, HUGE_VAL);
      }
    }
  }
  if (status != CRT_OK) return status;
  r->P[0] = k.y[3]; r->P[1] = k.y[4]; r->P[2] = k.p;
  for (i = 0; i < 3; ++i) { r->v_minus[i] = v0[i]; r->v[i] = k.y[i]; }
  r->work_n = k.y[5];
  r->work_t = k.y[6];
  return CRT_OK;
}

#endif /* CRT_DK_H */
