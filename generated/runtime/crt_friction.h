/*
 * crt_friction.h: Coulomb friction at S -- frictional impacts by Darboux-Keller's
 * integration in the normal impulse, and sliding and sticking contact with their
 * transitions.  Compiled into the friction models only (MODEL_FRICTION, the `rough`
 * model); crt_core.h includes it after its own contact helpers and calls it from a few
 * hooks (each marked MODEL_FRICTION there).
 *
 * Hand-written C: this file is templates/runtime/crt_friction.h, copied verbatim into
 * generated/runtime/ by `derive emit`.  Edit it there, then run `derive emit`.
 *
 * ---- The derivation (derive/friction.py; the functions from derive/friction_models.py) ---
 * The reaction at S is R = N e_Z + R_t with |R_t| <= mu_f N (mu_f = prm[CRT_P_friction]).
 * An impulse P at S changes the velocity of S by W P, W the Delassus matrix (fixed axes,
 * model_delassus: three solves with J).  An impact is integrated in the normal impulse p
 * (Darboux-Keller), y = (v_X, v_Y, v_Z, P_X, P_Y, E_n, E_t):
 *   slip (v_t != 0): dv/dp = W (e_Z - mu_f sigma), sigma = v_t/|v_t|
 *                                                   (impulse_slip_direction_rate)
 *   stick (v_t = 0, |tau| <= mu_f): dP_t/dp = tau keeps v_t = 0          (impulse_stick_rate)
 *   re-slide (v_t = 0, |tau| > mu_f): along the ray sigma(c), |sigma(c)| = 1 (impulse_resliding)
 * W is constant during an impact, so stick and re-sliding last to its end at constant
 * rates, whose events are solved in closed form; the slip is integrated by DOPRI5
 * (DOP853: crt_dk_step, rendered in crt_rk_steps.h) unless its direction is a ray of the slip
 * equations (W_tn - mu_f W_tt sigma parallel to sigma: a sphere about its centre, or a
 * plane motion), where its rates are constant too.  Compression ends where v_Z = 0;
 * restitution (prm[CRT_P_restitution_model]) where E_n = (1 - e^2) E_c (energetic, the
 * default), p = (1 + e) p_c (poisson) or v_Z = -e v_n- (newton: refused, status
 * restitution_refused, where mu_f |W_tn| > 0, since there it can gain energy).  An impact
 * whose normal velocity stops growing (dv_n/dp <= 0 with v_n < 0) ends the run with
 * status painleve.  The state after is model_apply_impulse's (V_C + P/(m+M), omega + J^-1
 * (CS x A^T P)).
 *
 * In contact (s->phase == CRT_CONTACT) S is held on the plane (h = 0, v_n = 0 after every
 * step, as in smooth contact) in one of two modes (s->fr.mode):
 *   sliding:  R = N (e_Z - mu_f dir), N from dv_n/dt = 0 (model_sliding); dir is the slip's
 *             direction, continued through zero along the reference s->fr.dir within a
 *             step, so that "the slip reaches 0" (v_t . dir = 0) is a sign change the event
 *             search finds; k_f = W_ZZ - mu_f (W_tn, dir) > 0 is checked at the end of each
 *             step (else status painleve);
 *   sticking: v_S = 0 held by R from dv_S/dt = 0 (model_sticking: a solve with W); after
 *             every step the slip's round-off is removed from V_C (v_S is affine in V_C with
 *             the unit matrix).
 * Transitions (events, each with the rows before and after it):
 *   sliding, N reaches 0              -> flight (liftoff);
 *   sliding, the slip reaches 0       -> slip set to 0; sticking if the sticking reaction R
 *                                        is inside the cone (stick), flight if R_Z <= 0
 *                                        (liftoff), else sliding again from rest along
 *                                        -R_t/|R_t| (reversal);
 *   sticking, |R_t| reaches mu_f R_Z  -> sliding from rest along -R_t/|R_t| (slip), or
 *                                        flight if R_Z <= 0 (liftoff).
 * Entering contact (impacts accumulating, or S resting on the plane) chooses the mode by
 * the slip: sliding along it, or from rest as above.
 */
#ifndef CRT_FRICTION_H
#define CRT_FRICTION_H

/* ---- Darboux-Keller: one impact in the normal impulse ------------------------------------ */
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
  double mu, e, v_n0;
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
  k->y[6] -= k->mu * (rho0 * d + 0.5 * c * d * d);
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
static void crt_dk_rate(const double *w6, double mu, int log_rho, double x, const double *y,
                        double *dy)
{
  double sg[2], du[3], rho, rho_p, dp;
  crt_sincos(y[1], &sg[1], &sg[0]);
  impulse_slip_direction_rate(sg, w6, mu, du);
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
  dy[2] = du[2] * dp; dy[3] = -mu * sg[0] * dp; dy[4] = -mu * sg[1] * dp;
  dy[5] = y[2] * dp;
  dy[6] = -mu * rho * dp;
}

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
    crt_dk_step(k->w6, k->mu, log_rho, x0, y0, f0, c * h, y_at, f1, scale, rtol);
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
  crt_dk_step(k->w6, k->mu, log_rho, x0, y0, f0, b * h, y_at, f1, scale, rtol);
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
  impulse_slip_direction_rate(sg, k->w6, k->mu, r);
  impulse_slip_direction_rate(sp, k->w6, k->mu, rq);
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
  crt_dk_rate(k->w6, k->mu, log_rho, *x, y, f);
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
    norm = crt_dk_step(k->w6, k->mu, log_rho, *x, y, f, h, y1, f1, scale, rtol);
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
  const double mu = k->mu;
  const double sg[2] = {cos(theta), sin(theta)};
  const double dPt[2] = {-mu * sg[0], -mu * sg[1]};
  double dv[3], c;
  int status;
  impulse_slip_direction_rate(sg, k->w6, mu, dv);
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
      crt_dk_rate(k->w6, k->mu, 0, x, y, f);
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
      crt_dk_rate(k->w6, k->mu, 0, x, y, f);
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
static double crt_dk_ray(const double *w6, double mu, double *sigma)
{
  double c = 0.0, f, df;
  int it;
  for (it = 0; it < 100; ++it) {
    double step;
    impulse_resliding(w6, mu, c, sigma, &f, &df);
    step = -f / df;
    if (!(step > 4e-16 * c)) break;
    c += step;
  }
  impulse_resliding(w6, mu, c, sigma, &f, &df);
  return c;
}

/* One impact: W (upper triangle w6), the velocity of S before v0 (v0[2] < 0), mu_f, e, the
   restitution law and the tolerance of the slip stage.  Returns CRT_OK (result in r),
   CRT_PAINLEVE or CRT_RESTITUTION_REFUSED. */
static int crt_dk_impact(const double *w6, const double *v0, double mu, double e, int law,
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
      && mu * sqrt(w6[2] * w6[2] + w6[4] * w6[4]) > 1e-12 * w_max)
    return CRT_RESTITUTION_REFUSED;
  k.w6 = w6; k.mu = mu; k.e = e; k.v_n0 = v0[2]; k.law = law;
  k.p = 0.0; k.compressed = 0; k.done = 0; k.p_c = 0.0; k.E_c = 0.0;
  for (i = 0; i < 3; ++i) k.y[i] = v0[i];
  for (i = 3; i < CRT_DK_N; ++i) k.y[i] = 0.0;
  r->stage = 0;
  if (mu == 0.0) {
    const double dv[3] = {w6[2], w6[4], w6[5]}, dPt[2] = {0.0, 0.0};
    status = crt_dk_constant(&k, dv, dPt, 0.0, 0.0, HUGE_VAL);
  } else {
    if (rho0 > 0.0) {
      /* the slip's direction is a ray of the slip equations when the tangential rate
         W_tn - mu_f W_tt sigma is parallel to sigma: constant rates, else DOPRI5 */
      const double sg[2] = {v0[0] / rho0, v0[1] / rho0};
      double rt[3], cross;
      impulse_slip_direction_rate(sg, w6, mu, rt);
      cross = sg[0] * rt[1] - sg[1] * rt[0];
      const double size = fabs(rt[0]) + fabs(rt[1]) + mu * w_max;
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
      impulse_stick_rate(k.y, w6, mu, dy, tau, &margin);
      if (margin >= -1e-12 * mu * mu) {
        const double dv[3] = {0.0, 0.0, dy[2]};
        r->stage = 1;
        status = crt_dk_constant(&k, dv, tau, 0.0, 0.0, HUGE_VAL);
      } else {
        double sigma[2], c = crt_dk_ray(w6, mu, sigma);
        const double dPt[2] = {-mu * sigma[0], -mu * sigma[1]};
        double dv[3];
        impulse_slip_direction_rate(sigma, w6, mu, dv);
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

/* ---- the session: scales, event rows ----------------------------------------------------- */
static double crt_rough_force_scale(const crt_session *s)
{
  const double g = s->prm[CRT_P_g];
  return (s->prm[CRT_P_M] + s->prm[CRT_P_m]) * (g > 0.0 ? g : 1.0);
}

/* the tolerance of an impact's slip stage */
static double crt_rough_dk_rtol(const crt_session *s)
{
  return crt_max(crt_min(s->opt[CRT_OPT_RTOL], 1e-10), 1e-14);
}

/* the slip's scale, its round-off and its resolution, set entering a contact mode */
static void crt_rough_scales(crt_session *s, double t)
{
  const double L = s->opt[CRT_OPT_LENGTH_SCALE], g = s->prm[CRT_P_g];
  const double *vc = s->q + Q_COM_VELOCITY;
  const double v = sqrt(vc[0] * vc[0] + vc[1] * vc[1] + vc[2] * vc[2])
                   + model_rate(s->prm, crt_u(s, t), s->q) * L + sqrt((g > 0.0 ? g : 1.0) * L);
  s->fr.v_scale = v > 0.0 ? v : 1.0;
  s->fr.v_eps = 1e3 * CRT_EPS * s->fr.v_scale;
  s->fr.v_arm = crt_max(10.0 * (s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * s->fr.v_scale),
                        s->fr.v_eps);
  s->fr.v_freeze = crt_max(sqrt(s->opt[CRT_OPT_RTOL]) * s->fr.v_scale, s->fr.v_arm);
  /* the couples' channels: the same over the length scale */
  s->fr.spin.w_scale = s->fr.roll.w_scale = s->fr.v_scale / L;
  s->fr.spin.w_eps = s->fr.roll.w_eps = s->fr.v_eps / L;
  s->fr.spin.w_arm = s->fr.roll.w_arm = s->fr.v_arm / L;
  s->fr.spin.w_freeze = s->fr.roll.w_freeze = s->fr.v_freeze / L;
}

/* an event row with the friction columns (abi.EVENT_COLUMNS) */
static void crt_rough_event(const crt_session *s, crt_out *o, double t, int kind, double value,
                            double a, double b, double t_accumulation, int mode,
                            const crt_dk_result *dk)
{
  double *row;
  int i;
  if (o->ev_n >= o->ev_cap) return;
  row = o->ev + (long)CRT_EVENT_COLUMNS * o->ev_n;
  for (i = 0; i < CRT_EVENT_COLUMNS; ++i) row[i] = 0.0;
  row[0] = t; row[1] = (double)kind; row[2] = value; row[3] = a; row[4] = b;
  row[5] = t_accumulation; row[6] = (double)mode;
  if (dk != 0) {
    row[7] = dk->P[0]; row[8] = dk->P[1];
    row[9] = dk->v_minus[0]; row[10] = dk->v_minus[1];
    row[11] = dk->v[0]; row[12] = dk->v[1];
    row[13] = dk->work_n; row[14] = dk->work_t;
    row[15] = (double)dk->stage;
  }
  if (mode != CRT_MODE_FLIGHT)
    row[16] = (double)((s->fr.spin.on && s->fr.spin.held) + 2 * (s->fr.roll.on && s->fr.roll.held));
  ++o->ev_n;
}

/* ---- contact: the two modes ---------------------------------------------------------------- */
/* sliding: the direction opposite the friction.  Armed (the slip resolved): the slip's,
   v_t/|v_t|, continued through zero along the reference s->fr.dir (so that the stop of the
   slip is a sign change of v_t . dir); restarting from rest: the reference itself, fixed,
   until the slip is resolved along it (v_t/|v_t| of a slip at round-off would turn the
   friction at random and chatter).  Below v_freeze = sqrt(rtol) times the slip's scale the
   reference too, which follows the slip at the end of every step: the slip's direction
   damps a deviation at the rate |a_t|/|v_t|, which no explicit step survives as the slip
   passes 0; a step there lags the friction's direction by its own turn of the slip. */
static void crt_follow_dir(int armed, double v_freeze, const double *ref, int dim,
                           const double *v, double *dir)
{
  const double rho = dim == 2 ? sqrt(v[0] * v[0] + v[1] * v[1]) : fabs(v[0]);
  if (armed && rho > v_freeze) {
    const double sg = v[0] * ref[0] + (dim == 2 ? v[1] * ref[1] : 0.0) < 0.0 ? -1.0 : 1.0;
    dir[0] = sg * v[0] / rho; dir[1] = dim == 2 ? sg * v[1] / rho : 0.0;
  } else {
    dir[0] = ref[0]; dir[1] = ref[1];
  }
}

static void crt_rough_dir(const crt_session *s, const double *v, double *dir)
{
  crt_follow_dir(s->fr.armed, s->fr.v_freeze, s->fr.dir, 2, v, dir);
}

/* sliding: the slip along the reference over its scale, zero where the slip stops (armed)
   or where a slip restarting from rest turns back against the reference (v_t . dir =
   -v_eps: the friction no longer opposes it); a couple's channel the same in its units */
static double crt_follow_value(int armed, double v_eps, double v_scale, const double *ref,
                               int dim, const double *v)
{
  return (v[0] * ref[0] + (dim == 2 ? v[1] * ref[1] : 0.0) + (armed ? 0.0 : v_eps)) / v_scale;
}

static double crt_rough_slip_value(const crt_session *s, const double *v)
{
  return crt_follow_value(s->fr.armed, s->fr.v_eps, s->fr.v_scale, s->fr.dir, 2, v);
}

/* ---- spin friction and rolling resistance: the contact as a wrench ---------------------- */
/* With either on (s->fr.couples), the contact's reaction is a wrench w = (R, T) at S (fixed
   axes); u = (v_S, Omega), Omega = A omega, changes as du/dt = a_free + G w
   (model_contact_wrench, derive/friction.py: contact_wrench).  The couple's channels:
   spin (c = 0) is Omega_Z with |T_Z| <= mu_s N, roll (c = 1) is (Omega_X, Omega_Y) with
   |(T_X, T_Y)| <= mu_r N; each is held (its Omega 0, its couple an unknown) or turning
   (its couple -mu N along its direction, followed as the slip's is: crt_follow_dir). */
typedef struct {
  double w[6];                /* (R, T) at S, fixed axes */
  double u[6];                /* (v_S, Omega) */
  double a[6];                /* du/dt = a_free + G w (crt_wrench_rates_of_u) */
  double N, k, g_zz;          /* N, its coefficient in dv_n/dt (k > 0 needed) and G_ZZ */
} crt_wrench;

static crt_channel *crt_couple(crt_session *s, int c)
{
  return c ? &s->fr.roll : &s->fr.spin;
}

static int crt_couple_first(int c) { return c ? 3 : 5; }
static int crt_couple_dim(int c) { return c ? 2 : 1; }

static double crt_couple_bound(const crt_session *s, int c)
{
  return s->prm[c ? CRT_P_rolling_resistance : CRT_P_spin_friction];
}

static double crt_norm_of(int dim, const double *v)
{
  return dim == 2 ? sqrt(v[0] * v[0] + v[1] * v[1]) : fabs(v[0]);
}

/* The reference of a slip or a channel (ref, dim 2 or 1) moved to its velocity v and
   armed: armed, where v is above eps; not yet, where v is resolved (above arm) along the
   reference.  Returns 1 if it moved. */
static int crt_follow_arm(int *armed, double *ref, int dim, const double *v, double eps,
                          double arm)
{
  const double rho = crt_norm_of(dim, v);
  if (*armed ? rho > eps
             : rho > arm && v[0] * ref[0] + (dim == 2 ? v[1] * ref[1] : 0.0) > 0.0) {
    ref[0] = v[0] / rho; ref[1] = dim == 2 ? v[1] / rho : 0.0;
    *armed = 1;
    return 1;
  }
  return 0;
}

/* The wrench in the mode `mode` of the slip (sliding along dir, or along crt_rough_dir's
   where dir is 0; sticking) and the channels' modes at (t, q), and dq/dt under it (where
   dq is not 0: the events and the mode decisions need the wrench alone).  The
   unknowns are the held components and N, the equations their rates and dv_n/dt, all 0:
   Gaussian elimination in that order (the held block is a principal block of G, positive
   definite: no pivoting), whose last pivot is N's coefficient k. */
typedef struct {
  double G[6][6], a[6];       /* du/dt = a + G w */
  double u[6];                /* (v_S, Omega) */
  double w0[3], Yw[18];       /* omega' = w0 + Yw w (Yw column by column) */
} crt_wrench_terms;

/* the state's side of the wrench equations at (t, q) (model_contact_wrench) */
static void crt_wrench_terms_at(crt_session *s, double t, const double *q,
                                crt_wrench_terms *m)
{
  double g21[21];
  int i, j, k;
  model_contact_wrench(s->prm, crt_u(s, t), q, g21, m->a, m->u, m->w0, m->Yw);
  for (k = 0, i = 0; i < 6; ++i)
    for (j = i; j < 6; ++j, ++k) m->G[i][j] = m->G[j][i] = g21[k];
}

/* the modes' side: the unknowns for the terms m (crt_rough_wrench without the rates) */
static void crt_wrench_solve(crt_session *s, const crt_wrench_terms *m, int mode,
                             const double *dir, crt_wrench *o)
{
  const double mu = s->prm[CRT_P_friction];
  double b[6] = {0.0, 0.0, 1.0, 0.0, 0.0, 0.0}, K[7][7], r[7], x[7];
  int idx[7], n = 0, i, j, k, c;
  for (i = 0; i < 6; ++i) o->u[i] = m->u[i];
  if (mode == CRT_MODE_STICKING) { idx[n++] = 0; idx[n++] = 1; }
  else {
    double d[2];
    if (dir != 0) { d[0] = dir[0]; d[1] = dir[1]; } else crt_rough_dir(s, o->u, d);
    b[0] = -mu * d[0]; b[1] = -mu * d[1];
  }
  for (c = 0; c < 2; ++c) {
    const crt_channel *ch = crt_couple(s, c);
    const int first = crt_couple_first(c), dim = crt_couple_dim(c);
    if (!ch->on) continue;
    if (ch->held) {
      for (i = 0; i < dim; ++i) idx[n++] = first + i;
    } else {
      double d[2];
      crt_follow_dir(ch->armed, ch->w_freeze, ch->dir, dim, o->u + first, d);
      for (i = 0; i < dim; ++i) b[first + i] = -crt_couple_bound(s, c) * d[i];
    }
  }
  idx[n] = 2;
  for (i = 0; i <= n; ++i) {
    const int ri = idx[i];
    double gb = 0.0;
    for (j = 0; j < n; ++j) K[i][j] = m->G[ri][idx[j]];
    for (k = 0; k < 6; ++k) gb += m->G[ri][k] * b[k];
    K[i][n] = gb;
    r[i] = -m->a[ri];
  }
  for (k = 0; k < n; ++k)
    for (i = k + 1; i <= n; ++i) {
      const double f = K[i][k] / K[k][k];
      for (j = k; j <= n; ++j) K[i][j] -= f * K[k][j];
      r[i] -= f * r[k];
    }
  for (i = n; i >= 0; --i) {
    double acc = r[i];
    for (j = i + 1; j <= n; ++j) acc -= K[i][j] * x[j];
    x[i] = acc / K[i][i];
  }
  o->k = K[n][n];
  o->g_zz = m->G[2][2];
  o->N = x[n];
  for (i = 0; i < 6; ++i) o->w[i] = x[n] * b[i];
  for (i = 0; i < n; ++i) o->w[idx[i]] += x[i];
}

/* du/dt = a + G w of a solved wrench (the onset's scan reads it) */
static void crt_wrench_rates_of_u(const crt_wrench_terms *m, crt_wrench *o)
{
  int i, j;
  for (i = 0; i < 6; ++i) {
    double acc = m->a[i];
    for (j = 0; j < 6; ++j) acc += m->G[i][j] * o->w[j];
    o->a[i] = acc;
  }
}

static void crt_rough_wrench(crt_session *s, double t, const double *q, int mode,
                             const double *dir, double *dq, crt_wrench *o)
{
  crt_wrench_terms m;
  crt_wrench_terms_at(s, t, q, &m);
  crt_wrench_solve(s, &m, mode, dir, o);
  if (dq != 0) {          /* omega' = w0 + Yw w, then the rates */
    double wd[3];
    int i, j;
    for (i = 0; i < 3; ++i) {
      double acc = m.w0[i];
      for (j = 0; j < 6; ++j) acc += m.Yw[3 * j + i] * o->w[j];
      wd[i] = acc;
    }
    model_wrench_rates(s->prm, q, wd, o->w, dq);
  }
}

/* the least of the channels' event values: a held one's (mu N - |T_c|)/(mu F), a turning
   one's crt_follow_value (HUGE_VAL without couples); *which: the channel that gives it */
static double crt_couples_value(crt_session *s, const crt_wrench *w, int *which)
{
  const double F = crt_rough_force_scale(s);
  double g = HUGE_VAL;
  int c;
  for (c = 0; c < 2; ++c) {
    const crt_channel *ch = crt_couple(s, c);
    const int first = crt_couple_first(c), dim = crt_couple_dim(c);
    double gc;
    if (!ch->on) continue;
    if (ch->held) {
      const double mu = crt_couple_bound(s, c);
      gc = (mu * w->w[2] - crt_norm_of(dim, w->w + first)) / (mu * F);
    } else {
      gc = crt_follow_value(ch->armed, ch->w_eps, ch->w_scale, ch->dir, dim, w->u + first);
      if (!ch->armed)          /* resolved: arm it (crt_couples_arm) */
        gc = crt_min(gc, (2.0 * ch->w_arm - crt_norm_of(dim, w->u + first)) / ch->w_scale);
    }
    if (gc < g) { g = gc; *which = c; }
  }
  return g;
}

/* the slip's event value with couples: as crt_rough_event_value's without them */
static double crt_wrench_slip_value(crt_session *s, const crt_wrench *w)
{
  const double F = crt_rough_force_scale(s);
  double g;
  if (s->fr.mode == CRT_MODE_STICKING)
    return (s->prm[CRT_P_friction] * w->w[2] - sqrt(w->w[0] * w->w[0] + w->w[1] * w->w[1]))
           / F;
  g = crt_min(w->N / F, crt_rough_slip_value(s, w->u));
  if (!s->fr.armed)            /* resolved: arm it (crt_couples_arm) */
    g = crt_min(g, (2.0 * s->fr.v_arm - crt_norm_of(2, w->u)) / s->fr.v_scale);
  return g;
}

/* With couples a slip or a channel restarting from rest is armed where it is resolved
   (twice v_arm; an event of the event function), not at the end of the step: the
   friction and the couples then follow their velocities from there on (a step frozen
   along the reference while the slip turns would jump at its end, and a held couple
   with it).  Returns 1 if one was armed. */
static int crt_couples_arm(crt_session *s, const crt_wrench *w)
{
  int c, armed = 0;
  if (s->fr.mode == CRT_MODE_SLIDING && !s->fr.armed)
    armed |= crt_follow_arm(&s->fr.armed, s->fr.dir, 2, w->u, s->fr.v_eps, s->fr.v_arm);
  for (c = 0; c < 2; ++c) {
    crt_channel *ch = crt_couple(s, c);
    if (ch->on && !ch->held && !ch->armed)
      armed |= crt_follow_arm(&ch->armed, ch->dir, crt_couple_dim(c),
                              w->u + crt_couple_first(c), ch->w_eps, ch->w_arm);
  }
  return armed;
}

/* Omega = A omega of the state q */
static void crt_omega_fixed(const double *q, double *Om)
{
  int i, j;
  for (i = 0; i < 3; ++i) {
    double acc = 0.0;
    for (j = 0; j < 3; ++j) acc += q[Q_A + 3 * i + j] * q[Q_OMEGA + j];
    Om[i] = acc;
  }
}

/* channel c's angular velocity set to 0 in q (the components of Omega along the fixed axes
   of the channel removed from omega: the rows of A are those axes in body axes) */
static void crt_couple_stop(double *q, int c)
{
  const int first = crt_couple_first(c) - 3, dim = crt_couple_dim(c);
  double Om[3];
  int i, j;
  crt_omega_fixed(q, Om);
  for (i = first; i < first + dim; ++i)
    for (j = 0; j < 3; ++j) q[Q_OMEGA + j] -= Om[i] * q[Q_A + 3 * i + j];
}

/* the slip of S removed in V_C (v_S is affine in V_C with the unit matrix) */
static void crt_rough_stop_slip(crt_session *s, double t, double *q)
{
  double v[3];
  model_contact_velocity(s->prm, crt_u(s, t), q, v);
  q[Q_COM_VELOCITY] -= v[0];
  q[Q_COM_VELOCITY + 1] -= v[1];
}

/* entering a contact mode with couples: each channel turning along its angular velocity
   where that is resolved (armed), else held with it set to 0 */
static void crt_couples_enter(crt_session *s)
{
  int c;
  for (c = 0; c < 2; ++c) {
    crt_channel *ch = crt_couple(s, c);
    const int first = crt_couple_first(c) - 3, dim = crt_couple_dim(c);
    double Om[3], rho;
    if (!ch->on) continue;
    crt_omega_fixed(s->q, Om);
    rho = crt_norm_of(dim, Om + first);
    if (rho > ch->w_arm) {
      ch->held = 0; ch->armed = 1;
      ch->dir[0] = Om[first] / rho; ch->dir[1] = dim == 2 ? Om[first + 1] / rho : 0.0;
    } else {
      ch->held = 1;
      crt_couple_stop(s->q, c);
    }
  }
}

/* a held channel whose couple is outside its bound turns from rest against it */
static void crt_couples_release(crt_session *s, const crt_wrench *w)
{
  int c;
  for (c = 0; c < 2; ++c) {
    crt_channel *ch = crt_couple(s, c);
    const int first = crt_couple_first(c), dim = crt_couple_dim(c);
    const double Tn = crt_norm_of(dim, w->w + first);
    if (!ch->on || !ch->held || !(Tn > crt_couple_bound(s, c) * w->N)) continue;
    ch->held = 0; ch->armed = 0;
    ch->dir[0] = -w->w[first] / Tn; ch->dir[1] = dim == 2 ? -w->w[first + 1] / Tn : 0.0;
  }
}

/* sliding at (t, q): dq/dt, N and the velocity of S */
static void crt_rough_sliding(crt_session *s, double t, const double *q, double *dq, double *N,
                              double *v)
{
  const double *u = crt_u(s, t);
  double dir[2], v_t[2], a_t[2];
  if (s->fr.couples) {
    crt_wrench w;
    crt_rough_wrench(s, t, q, CRT_MODE_SLIDING, 0, dq, &w);
    *N = w.N;
    v[0] = w.u[0]; v[1] = w.u[1]; v[2] = w.u[2];
    return;
  }
  model_contact_velocity(s->prm, u, q, v);
  crt_rough_dir(s, v, dir);
  model_sliding(s->prm, u, q, s->prm[CRT_P_friction], dir, dq, N, v_t, a_t);
}

/* sticking at (t, q): dq/dt and the reaction R */
static void crt_rough_sticking(crt_session *s, double t, const double *q, double *dq,
                               double *R)
{
  if (s->fr.couples) {
    crt_wrench w;
    crt_rough_wrench(s, t, q, CRT_MODE_STICKING, 0, dq, &w);
    R[0] = w.w[0]; R[1] = w.w[1]; R[2] = w.w[2];
    return;
  }
  model_sticking(s->prm, crt_u(s, t), q, dq, R);
}

/* the right-hand side in contact (crt_rhs) */
static void crt_rough_rhs(crt_session *s, double t, const double *q, double *dq)
{
  if (s->fr.mode == CRT_MODE_STICKING) {
    double R[3];
    crt_rough_sticking(s, t, q, dq, R);
  } else {
    double N, v[3];
    crt_rough_sliding(s, t, q, dq, &N, v);
  }
}

/* The event function in contact (crt_event_value): sticking, (mu_f R_Z - |R_t|)/F, zero
   where R leaves the cone (or R_Z reaches 0 with it); sliding, the lesser of N/F and of
   crt_rough_slip_value: zero at lift-off or where the slip reaches 0.  F = (m+M) g. */
static double crt_rough_event_value(crt_session *s, double t, const double *y)
{
  double dq[NQ];
  const double F = crt_rough_force_scale(s);
  ++s->stat[CRT_STAT_EVENT_FUNCTION_EVALUATIONS];
  if (s->fr.couples) {
    /* with couples, also the channels' values (crt_couples_value) */
    crt_wrench w;
    double g;
    int which = 0;
    crt_rough_wrench(s, t, y, s->fr.mode, 0, 0, &w);
    g = crt_wrench_slip_value(s, &w);
    return crt_min(g, crt_couples_value(s, &w, &which));
  }
  if (s->fr.mode == CRT_MODE_STICKING) {
    double R[3];
    model_sticking(s->prm, crt_u(s, t), y, dq, R);
    return (s->prm[CRT_P_friction] * R[2] - sqrt(R[0] * R[0] + R[1] * R[1])) / F;
  } else {
    double N, v[3], g;
    crt_rough_sliding(s, t, y, dq, &N, v);
    g = N / F;
    return crt_min(g, crt_rough_slip_value(s, v));
  }
}

/* sliding needs k_f = W_ZZ - mu_f (W_Zt, dir) > 0 (derive/friction.py: sliding_contact),
   else N is not determined (Painleve); and as k_f falls to 0 with a_free < 0, N = -a_free/
   k_f grows without bound (the sliding motion ends in a jam, which the rigid model can only
   resolve by an impact) and the steps underflow: so k_f <= 1e-6 W_ZZ, or k_f <= 1e-2 W_ZZ
   with N (when known, else pass 0) above 100 times the weight, ends the run with status
   painleve; returns 0 then */
static int crt_rough_consistent(crt_session *s, double t, double N)
{
  double w6[6], v[3], dir[2], k_f;
  if (s->fr.couples) {            /* N's coefficient after the held channels' elimination */
    crt_wrench w;
    crt_rough_wrench(s, t, s->q, CRT_MODE_SLIDING, 0, 0, &w);
    k_f = w.k;
    w6[5] = w.g_zz;
  } else {
    model_delassus(s->prm, crt_u(s, t), s->q, w6, v);
    crt_rough_dir(s, v, dir);
    k_f = w6[5] - s->prm[CRT_P_friction] * (w6[2] * dir[0] + w6[4] * dir[1]);
  }
  if (k_f > 1e-6 * w6[5] && !(k_f <= 1e-2 * w6[5] && N > 1e2 * crt_rough_force_scale(s)))
    return 1;
  s->status = CRT_PAINLEVE;
  return 0;
}

/* sigma = (cos th, sin th) x a_t(sigma) and (sigma, a_t(sigma)) for crt_rough_onset
   (NaN where k_f <= 0 or N <= 0: no sliding along sigma) */
static void crt_rough_onset_at(const double *w6, const double *R, double WR_n, double mu,
                               double th, double *g, double *along)
{
  const double c = cos(th), s = sin(th);
  const double k_f = w6[5] - mu * (w6[2] * c + w6[4] * s);
  const double N = WR_n / k_f;
  /* the impulse-like vector N (e_Z - mu sigma) - R, and a_t = W_t. of it */
  const double x = -N * mu * c - R[0], y = -N * mu * s - R[1], z = N - R[2];
  const double ax = w6[0] * x + w6[1] * y + w6[2] * z;
  const double ay = w6[1] * x + w6[3] * y + w6[4] * z;
  if (!(k_f > 0.0 && N > 0.0)) { *g = NAN; *along = NAN; return; }
  *g = c * ay - s * ax;
  *along = c * ax + s * ay;
}

/* The direction a slip takes from rest where sticking would need R (fixed axes) outside
   the cone, R_Z > 0: the contact analogue of an impact's re-sliding ray.  S sliding along
   sigma from rest feels R(sigma) = N (e_Z - mu_f sigma) with N from dv_n/dt = 0; as
   dv_S/dt = a_free + W R with a_free = -W R (the sticking reaction makes it 0),
   a(sigma) = W (N(sigma) (e_Z - mu_f sigma) - R), N(sigma) = (W R)_Z/k_f(sigma),
   k_f(sigma) = W_ZZ - mu_f (W_Zt, sigma).  The slip keeps its direction where
   a_t(sigma) = c sigma, c > 0: the zeros of sigma x a_t(sigma) on a scan of 72 angles
   where k_f > 0 and N > 0 (refined by bisection) with (sigma, a_t) > 0 there (near such a
   ray |a_t| is small and turns fast with sigma: a direction off it by a degree can start
   a slip that the friction then turns back); a stable one (sigma x a_t falls through 0:
   the slip's direction, which the friction then follows, turns back to it) nearest
   -R_t/|R_t| (the friction's direction continued) in dir, else any nearest.  Returns 0 (dir = -R_t/|R_t|)
   when there is none. */
static void crt_onset_at_wrench(crt_session *s, const crt_wrench_terms *m, int which,
                                double th, double *g, double *along)
{
  const double sg[2] = {cos(th), sin(th)};
  const int first = which ? 3 : 0;
  crt_wrench w;
  if (which == 0) {
    crt_wrench_solve(s, m, CRT_MODE_SLIDING, sg, &w);
  } else {
    const crt_channel keep = s->fr.roll;
    s->fr.roll.held = 0; s->fr.roll.armed = 0;
    s->fr.roll.dir[0] = sg[0]; s->fr.roll.dir[1] = sg[1];
    crt_wrench_solve(s, m, s->fr.mode, 0, &w);
    s->fr.roll = keep;
  }
  crt_wrench_rates_of_u(m, &w);
  if (!(w.k > 0.0 && w.N > 0.0)) { *g = NAN; *along = NAN; return; }
  *g = sg[0] * w.a[first + 1] - sg[1] * w.a[first];
  *along = sg[0] * w.a[first] + sg[1] * w.a[first + 1];
}

/* crt_rough_onset's function: without couples crt_rough_onset_at (W and R alone), with
   them crt_onset_at_wrench (the slip, which = 0, or the rolling, which = 1) */
static void crt_onset_eval(crt_session *s, const crt_wrench_terms *m, int which,
                           const double *w6, const double *R, double WR_n, double th,
                           double *g, double *along)
{
  if (s->fr.couples) crt_onset_at_wrench(s, m, which, th, g, along);
  else crt_rough_onset_at(w6, R, WR_n, s->prm[CRT_P_friction], th, g, along);
}

static int crt_rough_onset(crt_session *s, double t, int which, const double *w6,
                           const double *R, double *dir)
{
  const double WR_n = w6 != 0 ? w6[2] * R[0] + w6[4] * R[1] + w6[5] * R[2] : 0.0;
  const double rt = sqrt(R[0] * R[0] + R[1] * R[1]);
  const double d0[2] = {-R[0] / rt, -R[1] / rt};
  double best = -2.0, g_prev = 0.0, th_prev = 0.0, score;
  int k, ok_prev = 0, found = 0;
  crt_wrench_terms m;       /* with couples: the state's side, once for the scan */
  if (s->fr.couples) crt_wrench_terms_at(s, t, s->q, &m);
  dir[0] = d0[0]; dir[1] = d0[1];
  for (k = 0; k <= 72; ++k) {
    const double th = 6.283185307179586 * (double)k / 72.0;
    double g, along, sg[2];
    int ok, it;
    crt_onset_eval(s, &m, which, w6, R, WR_n, th, &g, &along);
    ok = g == g;                           /* k_f > 0 and N > 0 there */
    if (k > 0 && ok && ok_prev && (g > 0.0) != (g_prev > 0.0)) {
      double a = th_prev, b = th, ga = g_prev, gm, al = 0.0;
      for (it = 0; it < 60; ++it) {
        const double c = 0.5 * (a + b);
        double gc;
        crt_onset_eval(s, &m, which, w6, R, WR_n, c, &gc, &al);
        if ((gc > 0.0) == (ga > 0.0)) { a = c; ga = gc; } else b = c;
      }
      crt_onset_eval(s, &m, which, w6, R, WR_n, 0.5 * (a + b), &gm, &al);
      sg[0] = cos(0.5 * (a + b)); sg[1] = sin(0.5 * (a + b));
      /* a stable ray first (g falls through 0: a slip turned off it turns back), then the
         nearest to -R_t/|R_t| */
      score = (g < g_prev ? 4.0 : 0.0) + sg[0] * d0[0] + sg[1] * d0[1];
      if (al > 0.0 && score > best) {
        best = score;
        dir[0] = sg[0]; dir[1] = sg[1];
        found = 1;
      }
    }
    g_prev = g; th_prev = th; ok_prev = ok;
  }
  return found;
}

/* S on the plane with its slip at round-off, at (t, s->q): the slip set to 0 (in V_C); then
   CRT_MODE_STICKING when the sticking reaction R is inside the cone, CRT_MODE_FLIGHT when
   R_Z <= 0, else CRT_MODE_SLIDING from rest along the direction the slip takes
   (crt_rough_onset; the mode is set), or CRT_MODE_FLIGHT where no direction can slide and
   S leaves the plane unpushed, or status painleve where it cannot */
static int crt_rough_at_rest(crt_session *s, double t, double *R)
{
  const double *u = crt_u(s, t);
  double dq[NQ], rt;
  crt_rough_stop_slip(s, t, s->q);
  crt_rough_sticking(s, t, s->q, dq, R);
  if (!(R[2] > 0.0)) return CRT_MODE_FLIGHT;
  rt = sqrt(R[0] * R[0] + R[1] * R[1]);
  if (rt <= s->prm[CRT_P_friction] * R[2]) {
    s->fr.mode = CRT_MODE_STICKING;
    return CRT_MODE_STICKING;
  }
  s->fr.mode = CRT_MODE_SLIDING;
  s->fr.armed = 0;
  if (s->fr.couples) {
    /* from rest along the direction the slip takes (crt_rough_onset, here on the wrench's
       equations; else -R_t/|R_t|): N > 0 slides, else S leaves the plane; k <= 0 is
       Painleve's case */
    crt_wrench w;
    crt_rough_onset(s, t, 0, 0, R, s->fr.dir);
    crt_rough_wrench(s, t, s->q, CRT_MODE_SLIDING, 0, 0, &w);
    if (!(w.N > 0.0)) return CRT_MODE_FLIGHT;
    if (!(w.k > 0.0)) s->status = CRT_PAINLEVE;
    return CRT_MODE_SLIDING;
  }
  {
    double w6[6], vv[3];
    model_delassus(s->prm, u, s->q, w6, vv);
    if (!crt_rough_onset(s, t, 0, w6, R, s->fr.dir)) {
      /* no direction found that slides with N > 0, k_f > 0 and a growing slip (the cone
         barely violated leaves the slip's rate at round-off): if S leaves the plane
         without a reaction (a_free_n = -(W R)_Z > 0) it lifts off; else -R_t/|R_t| where
         k_f > 0 there; else neither sticking, sliding nor flight is consistent
         (Painleve: only an impulse could resolve it) */
      const double k_f = w6[5] - s->prm[CRT_P_friction] * (w6[2] * s->fr.dir[0]
                                                         + w6[4] * s->fr.dir[1]);
      if (w6[2] * R[0] + w6[4] * R[1] + w6[5] * R[2] < 0.0) return CRT_MODE_FLIGHT;
      if (!(k_f > 0.0)) s->status = CRT_PAINLEVE;
    }
  }
  return CRT_MODE_SLIDING;
}

/* Enter contact at (t, s->q) (crt_enter_contact's hook): S put on the plane and the normal
   velocity v_cut removed by the plastic normal impulse of smooth contact (the friction of
   that cut, an impulse below the resolution, is left out); then sliding along the slip, or
   the mode of S at rest (crt_rough_at_rest). */
static void crt_rough_enter_contact(crt_session *s, crt_out *o, double t, double v_cut,
                                    double t_accumulation)
{
  double q_plastic[NQ], impulse, v[3], R[3], dq[NQ], N = 0.0, rho;
  int i, mode;
  crt_project(s, t, s->q, 0);
  model_impact(s->prm, 0.0, crt_u(s, t), s->q, q_plastic, &impulse);
  for (i = 0; i < NQ; ++i) s->q[i] = q_plastic[i];
  crt_project(s, t, s->q, 1);
  s->phase = CRT_CONTACT;
  crt_rough_scales(s, t);
  if (s->fr.couples) crt_couples_enter(s);
  model_contact_velocity(s->prm, crt_u(s, t), s->q, v);
  rho = sqrt(v[0] * v[0] + v[1] * v[1]);
  if (rho > s->fr.v_arm) {
    s->fr.mode = CRT_MODE_SLIDING;
    s->fr.dir[0] = v[0] / rho; s->fr.dir[1] = v[1] / rho;
    s->fr.armed = 1;
    mode = CRT_MODE_SLIDING;
  } else {
    mode = crt_rough_at_rest(s, t, R);
    if (mode == CRT_MODE_FLIGHT) {
      /* not pressed onto the plane after all: S touched it (a graze), and flies on */
      s->phase = CRT_FLIGHT;
      s->last_flight = 0.0;
      crt_rough_event(s, o, t, CRT_EV_GRAZE, 0.0, v_cut, 0.0, 0.0, CRT_MODE_FLIGHT, 0);
      ++s->stat[CRT_STAT_GRAZES];
      return;
    }
  }
  if (s->fr.couples) {
    crt_wrench w;
    crt_rough_wrench(s, t, s->q, mode, 0, 0, &w);
    crt_couples_release(s, &w);
  }
  if (mode == CRT_MODE_STICKING) N = R[2];
  else {
    crt_rough_sliding(s, t, s->q, dq, &N, v);
    if (N > 0.0) crt_rough_consistent(s, t, 0.0);
  }
  if (N < s->summary[CRT_SUMMARY_MIN_NORMAL]) s->summary[CRT_SUMMARY_MIN_NORMAL] = N;
  crt_rough_event(s, o, t, CRT_EV_CONTACT, N, v_cut, 0.0, t_accumulation, mode, 0);
  ++s->stat[CRT_STAT_CONTACTS];
}

/* The frictional impact at (t, s->q) (crt_collide's hook; S on the plane approaching at
   v_n): the state after in q_plus and the impact's numbers in dk; returns 0 with s->status
   set when the impact is refused (painleve, restitution_refused). */
static int crt_rough_impact(crt_session *s, double t, double *q_plus, crt_dk_result *dk)
{
  const double *u = crt_u(s, t);
  double w6[6], v[3];
  int status;
  model_delassus(s->prm, u, s->q, w6, v);
  status = crt_dk_impact(w6, v, s->prm[CRT_P_friction], s->prm[CRT_P_e],
                         (int)s->prm[CRT_P_restitution_model], crt_rough_dk_rtol(s), dk);
  if (status != CRT_OK) { s->status = status; return 0; }
  model_apply_impulse(s->prm, u, s->q, dk->P, q_plus);
  return 1;
}

/* A contact event at (t, s->q): the rows before and after it and the event row; value,
   the slip speed before and after */
static void crt_rough_mark(crt_session *s, crt_out *o, double t, int kind, double value,
                           double slip_before, int mode)
{
  double v[3];
  s->last_event_t = t;
  model_contact_velocity(s->prm, crt_u(s, t), s->q, v);
  crt_rough_event(s, o, t, kind, value, slip_before, sqrt(v[0] * v[0] + v[1] * v[1]), 0.0, mode,
                  0);
  crt_emit(o, t, s->q, CRT_ROW_AFTER_EVENT);
  crt_changed(s);
  s->g_valid = 0;
}

/* A transition in contact at (t, s->q), where the event function reached 0 (crt_handle_event
   and the start of a step): lift-off, stick, slip or reversal (the top of this file). */
/* With couples, a slip or a rolling whose event "reached 0" fired while it had only turned
   away from its reference (it passed by 0, it did not stop there: its speed still above
   twice its resolution) takes its own direction as the new reference, with no event: the
   friction and the couple follow it (stopping it would remove the speed across the
   reference); the slip only where N stays positive with its coefficient.  Returns 1 if
   one was re-aimed. */
static int crt_couples_turned(crt_session *s, double t, const crt_wrench *w)
{
  int c, turned = 0;
  if (s->fr.mode == CRT_MODE_SLIDING && s->fr.armed && crt_rough_slip_value(s, w->u) <= 0.0) {
    const double rho = crt_norm_of(2, w->u), keep[2] = {s->fr.dir[0], s->fr.dir[1]};
    if (rho > 2.0 * s->fr.v_arm) {
      /* below v_freeze the friction kept the reference: turning it to the slip moves N,
         which must stay positive with its coefficient */
      crt_wrench w2;
      s->fr.dir[0] = w->u[0] / rho; s->fr.dir[1] = w->u[1] / rho;
      crt_rough_wrench(s, t, s->q, CRT_MODE_SLIDING, 0, 0, &w2);
      if (w2.N > 0.0 && w2.k > 1e-2 * w2.g_zz) turned = 1;
      else { s->fr.dir[0] = keep[0]; s->fr.dir[1] = keep[1]; }
    }
  }
  for (c = 1; c < 2; ++c) {      /* the rolling (the spin's one component cannot turn) */
    crt_channel *ch = crt_couple(s, c);
    const double *om = w->u + crt_couple_first(c), rho = crt_norm_of(2, om);
    if (!ch->on || ch->held || !ch->armed
        || crt_follow_value(1, 0.0, ch->w_scale, ch->dir, 2, om) > 0.0) continue;
    if (rho > 2.0 * ch->w_arm) {
      ch->dir[0] = om[0] / rho; ch->dir[1] = om[1] / rho;
      turned = 1;
    }
  }
  return turned;
}

/* With couples, after a transition: a slip or a rolling that restarted from rest and is
   not armed yet is re-aimed along the direction it takes in the new modes (crt_rough_onset
   from its reference; kept where none is found), so that it does not jump when armed. */
static void crt_couples_reaim(crt_session *s, double t)
{
  if (s->fr.mode == CRT_MODE_SLIDING && !s->fr.armed) {
    const double ref[3] = {-s->fr.dir[0], -s->fr.dir[1], 1.0};
    crt_rough_onset(s, t, 0, 0, ref, s->fr.dir);
  }
  if (s->fr.roll.on && !s->fr.roll.held && !s->fr.roll.armed) {
    const double ref[2] = {-s->fr.roll.dir[0], -s->fr.roll.dir[1]};
    crt_rough_onset(s, t, 1, 0, ref, s->fr.roll.dir);
  }
}

static void crt_couple_transition(crt_session *s, crt_out *o, double t, int c,
                                  const crt_wrench *w)
{
  crt_channel *ch = crt_couple(s, c);
  const int first = crt_couple_first(c), dim = crt_couple_dim(c);
  const double mu = crt_couple_bound(s, c), before = crt_norm_of(dim, w->u + first);
  double Tn;
  crt_wrench w2 = *w;
  if (!(w->N > 0.0)) { crt_lift_off(s, o, t, w->N); return; }
  crt_project(s, t, s->q, 1);
  crt_emit(o, t, s->q, CRT_ROW_BEFORE_EVENT);
  crt_rough_scales(s, t);
  if (!ch->held) {
    /* the channel's turning reached 0: held, if its couple stays inside the bound */
    ch->held = 1;
    crt_couple_stop(s->q, c);
    if (s->fr.mode == CRT_MODE_STICKING) crt_rough_stop_slip(s, t, s->q);
    crt_rough_wrench(s, t, s->q, s->fr.mode, 0, 0, &w2);
    Tn = crt_norm_of(dim, w2.w + first);
    if (Tn <= mu * w2.N) {
      crt_couples_reaim(s, t);
      ++s->stat[CRT_STAT_COUPLE_STOPS];
      crt_rough_mark(s, o, t, c ? CRT_EV_ROLL_STOP : CRT_EV_SPIN_STOP, Tn / (mu * w2.N),
                     before, s->fr.mode);
      return;
    }
  }
  /* the held couple reached its bound (or cannot hold the channel it just stopped): it
     turns from rest against the couple */
  Tn = crt_norm_of(dim, w2.w + first);
  ch->held = 0; ch->armed = 0;
  if (Tn > 0.0) {
    ch->dir[0] = -w2.w[first] / Tn; ch->dir[1] = dim == 2 ? -w2.w[first + 1] / Tn : 0.0;
    if (dim == 2) crt_rough_onset(s, t, 1, 0, w2.w + first, ch->dir);
  }
  if (s->fr.mode == CRT_MODE_SLIDING && !s->fr.armed) {
    const double ref[3] = {-s->fr.dir[0], -s->fr.dir[1], 1.0};
    crt_rough_onset(s, t, 0, 0, ref, s->fr.dir);
  }
  ++s->stat[CRT_STAT_COUPLE_STARTS];
  crt_rough_mark(s, o, t, c ? CRT_EV_ROLL_START : CRT_EV_SPIN_START, Tn / (mu * w2.N), before,
                 s->fr.mode);
}

static void crt_rough_transition(crt_session *s, crt_out *o, double t)
{
  double dq[NQ], v[3], R[3];
  const double F = crt_rough_force_scale(s);
  if (s->fr.couples) {
    /* a channel's event first where its value is the least */
    crt_wrench w;
    int which = 0;
    crt_rough_wrench(s, t, s->q, s->fr.mode, 0, 0, &w);
    if (crt_couples_arm(s, &w) || crt_couples_turned(s, t, &w)) {
      crt_changed(s);
      s->g_valid = 0;
      return;
    }
    if (crt_couples_value(s, &w, &which) < crt_wrench_slip_value(s, &w)) {
      crt_couple_transition(s, o, t, which, &w);
      return;
    }
  }
  if (s->fr.mode == CRT_MODE_STICKING) {
    double rt;
    crt_rough_sticking(s, t, s->q, dq, R);
    rt = sqrt(R[0] * R[0] + R[1] * R[1]);
    if (!(R[2] > 0.0) || !(rt > 0.0)) { crt_lift_off(s, o, t, R[2]); return; }
    crt_project(s, t, s->q, 1);
    crt_emit(o, t, s->q, CRT_ROW_BEFORE_EVENT);
    crt_rough_scales(s, t);
    s->fr.mode = CRT_MODE_SLIDING;
    s->fr.dir[0] = -R[0] / rt; s->fr.dir[1] = -R[1] / rt;
    s->fr.armed = 0;
    if (s->fr.couples) crt_rough_onset(s, t, 0, 0, R, s->fr.dir);
    ++s->stat[CRT_STAT_SLIPS];
    crt_rough_mark(s, o, t, CRT_EV_SLIP, rt / (s->prm[CRT_P_friction] * R[2]), 0.0,
                   CRT_MODE_SLIDING);
    crt_rough_consistent(s, t, 0.0);
  } else {
    double N, before;
    int mode;
    crt_rough_sliding(s, t, s->q, dq, &N, v);
    before = sqrt(v[0] * v[0] + v[1] * v[1]);
    if (N / F <= crt_rough_slip_value(s, v)) { crt_lift_off(s, o, t, N); return; }
    /* the slip reached 0 */
    crt_project(s, t, s->q, 1);
    crt_emit(o, t, s->q, CRT_ROW_BEFORE_EVENT);
    crt_rough_scales(s, t);
    mode = crt_rough_at_rest(s, t, R);
    if (mode == CRT_MODE_FLIGHT) {
      s->phase = CRT_FLIGHT;
      s->last_flight = 0.0;
      ++s->stat[CRT_STAT_LIFTOFFS];
      crt_rough_mark(s, o, t, CRT_EV_LIFTOFF, R[2], before, CRT_MODE_FLIGHT);
      return;
    }
    if (mode == CRT_MODE_STICKING) {
      ++s->stat[CRT_STAT_STICKS];
      crt_rough_mark(s, o, t, CRT_EV_STICK, R[2], before, mode);
      return;
    }
    ++s->stat[CRT_STAT_REVERSALS];
    crt_rough_mark(s, o, t, CRT_EV_REVERSAL, R[2], before, mode);
    crt_rough_consistent(s, t, 0.0);
  }
}

/* After an accepted step with couples: a held channel's round-off removed, a turning one's
   reference moved to its angular velocity and armed once that grows (as the slip's) */
static void crt_couples_after_step(crt_session *s)
{
  int c;
  for (c = 0; c < 2; ++c) {
    crt_channel *ch = crt_couple(s, c);
    double Om[3];
    if (!ch->on) continue;
    if (ch->held) { crt_couple_stop(s->q, c); continue; }
    crt_omega_fixed(s->q, Om);
    crt_follow_arm(&ch->armed, ch->dir, crt_couple_dim(c), Om + crt_couple_first(c) - 3,
                   ch->w_eps, ch->w_arm);
  }
}

/* After an accepted step in contact (S already projected onto the plane): sticking, the
   slip's round-off removed; sliding, the reference direction moved to the slip's and the
   search armed once the slip grows; the summary's least normal reaction and largest
   |R_t|/(mu_f R_Z) */
static void crt_rough_after_step(crt_session *s)
{
  const double t = s->t, mu = s->prm[CRT_P_friction];
  double dq[NQ], v[3], normal, ratio;
  if (s->fr.couples) crt_couples_after_step(s);
  if (s->fr.mode == CRT_MODE_STICKING) {
    double R[3];
    crt_rough_stop_slip(s, t, s->q);
    crt_rough_sticking(s, t, s->q, dq, R);
    normal = R[2];
    ratio = R[2] > 0.0 ? sqrt(R[0] * R[0] + R[1] * R[1]) / (mu * R[2]) : HUGE_VAL;
  } else {
    /* (crt_follow_arm written out: the runtime's -ffp-contract=fast contracts the helper
       differently, and without couples the run stays what it was, bit for bit) */
    double rho;
    model_contact_velocity(s->prm, crt_u(s, t), s->q, v);
    rho = sqrt(v[0] * v[0] + v[1] * v[1]);
    if (s->fr.armed ? rho > s->fr.v_eps
                    : rho > s->fr.v_arm && v[0] * s->fr.dir[0] + v[1] * s->fr.dir[1] > 0.0) {
      s->fr.dir[0] = v[0] / rho; s->fr.dir[1] = v[1] / rho;
      s->fr.armed = 1;
    }
    crt_rough_sliding(s, t, s->q, dq, &normal, v);
    ratio = 1.0;
    crt_rough_consistent(s, t, normal);
  }
  if (normal < s->summary[CRT_SUMMARY_MIN_NORMAL]) s->summary[CRT_SUMMARY_MIN_NORMAL] = normal;
  if (ratio > s->summary[CRT_SUMMARY_MAX_FRICTION_RATIO])
    s->summary[CRT_SUMMARY_MAX_FRICTION_RATIO] = ratio;
}

/* ---- public API of the friction models -------------------------------------------------- */

/* the contact mode (enum crt_mode): CRT_MODE_FLIGHT, CRT_MODE_SLIDING or CRT_MODE_STICKING */
int crt_contact_mode(const crt_session *s)
{
  return s->phase == CRT_FLIGHT ? CRT_MODE_FLIGHT : s->fr.mode;
}

/* Along n rows (t[k], q[k*NQ..]) in the modes mode[k] (enum crt_mode; CRT_MODE_SLIDING
   along dir[2k..] (fixed axes, normalised here), or where that is 0 along the slip, or
   (1, 0) where the slip is 0 too; CRT_MODE_STICKING; any other: flight): dq/dt into
   dq[k*NQ..], the reaction at S R[3k..] (fixed axes; 0 in flight) and the velocity of S
   v_S[3k..]. */
void crt_eval_rough_rows(crt_session *s, int n, const double *t, const double *q,
                         const int *mode, const double *dir_in, double *dq, double *R,
                         double *v_S)
{
  const double mu = s->prm[CRT_P_friction];
  int k;
  for (k = 0; k < n; ++k) {
    const double *qk = q + (long)k * NQ, *u = crt_u(s, t[k]);
    double *dqk = dq + (long)k * NQ, *Rk = R + 3L * k, *vk = v_S + 3L * k;
    model_contact_velocity(s->prm, u, qk, vk);
    if (mode[k] == CRT_MODE_STICKING) {
      model_sticking(s->prm, u, qk, dqk, Rk);
    } else if (mode[k] == CRT_MODE_SLIDING) {
      const double *d = dir_in + 2L * k;
      const double given = sqrt(d[0] * d[0] + d[1] * d[1]);
      const double rho = sqrt(vk[0] * vk[0] + vk[1] * vk[1]);
      double dir[2], N, v_t[2], a_t[2];
      if (given > 0.0) { dir[0] = d[0] / given; dir[1] = d[1] / given; }
      else {
        dir[0] = rho > 0.0 ? vk[0] / rho : 1.0;
        dir[1] = rho > 0.0 ? vk[1] / rho : 0.0;
      }
      model_sliding(s->prm, u, qk, mu, dir, dqk, &N, v_t, a_t);
      Rk[0] = -mu * N * dir[0]; Rk[1] = -mu * N * dir[1]; Rk[2] = N;
    } else {
      model_rhs(s->prm, u, qk, dqk);
      Rk[0] = Rk[1] = Rk[2] = 0.0;
    }
  }
}

/* As crt_eval_rough_rows with spin friction or rolling resistance: each row's held channels
   couples[k] (bit 1: the spin, bit 2: the rolling; the event column "couples") and the
   turning channels' directions cdir[3k..] (the spin's sign, then the rolling's direction,
   fixed axes; 0: along the angular velocity): dq/dt into dq[k*NQ..], the wrench at S
   w[6k..] = (R, T) (fixed axes; 0 in flight) and u[6k..] = (v_S, A omega). */
void crt_eval_wrench_rows(crt_session *s, int n, const double *t, const double *q,
                          const int *mode, const double *dir_in, const int *couples,
                          const double *cdir, double *dq, double *w, double *u6)
{
  const crt_channel keep[2] = {s->fr.spin, s->fr.roll};
  int k, c, i;
  for (k = 0; k < n; ++k) {
    const double *qk = q + (long)k * NQ, *d = dir_in + 2L * k;
    double *dqk = dq + (long)k * NQ, *wk = w + 6L * k, *uk = u6 + 6L * k, Om[3], dir[2];
    crt_omega_fixed(qk, Om);
    for (c = 0; c < 2; ++c) {
      crt_channel *ch = crt_couple(s, c);
      const int first = crt_couple_first(c) - 3, dim = crt_couple_dim(c);
      const double *dc = cdir + 3L * k + c;
      const double given = crt_norm_of(dim, dc), rho = crt_norm_of(dim, Om + first);
      const double *from = given > 0.0 ? dc : Om + first;
      const double r = given > 0.0 ? given : rho;
      ch->held = (couples[k] >> c) & 1;
      ch->armed = 0;
      ch->dir[0] = r > 0.0 ? from[0] / r : 1.0;
      ch->dir[1] = dim == 2 && r > 0.0 ? from[1] / r : 0.0;
    }
    if (mode[k] == CRT_MODE_STICKING || mode[k] == CRT_MODE_SLIDING) {
      crt_wrench wr;
      const double given = sqrt(d[0] * d[0] + d[1] * d[1]);
      double v[3], rho;
      model_contact_velocity(s->prm, crt_u(s, t[k]), qk, v);
      rho = sqrt(v[0] * v[0] + v[1] * v[1]);
      dir[0] = given > 0.0 ? d[0] / given : rho > 0.0 ? v[0] / rho : 1.0;
      dir[1] = given > 0.0 ? d[1] / given : rho > 0.0 ? v[1] / rho : 0.0;
      crt_rough_wrench(s, t[k], qk, mode[k], dir, dqk, &wr);
      for (i = 0; i < 6; ++i) { wk[i] = wr.w[i]; uk[i] = wr.u[i]; }
    } else {
      model_rhs(s->prm, crt_u(s, t[k]), qk, dqk);
      model_contact_velocity(s->prm, crt_u(s, t[k]), qk, uk);
      for (i = 0; i < 3; ++i) { wk[i] = wk[3 + i] = 0.0; uk[3 + i] = Om[i]; }
    }
  }
  s->fr.spin = keep[0];
  s->fr.roll = keep[1];
}

/* After crt_init (CRT_OK): start the run in contact instead of flight, S held on the
   plane (h = 0 and v_n = 0 are made so), in the mode CRT_MODE_STICKING (the slip is set to
   0) or CRT_MODE_SLIDING along dir[2] (fixed axes; normalised; the slip's own direction
   once it is resolved).  For a run that resumes a contact phase (the energy balance's
   finer rows of a short phase).  Returns CRT_OK, or CRT_BAD_ARGUMENT for another mode or
   a zero dir (the session is then unchanged). */
int crt_set_contact_mode(crt_session *s, int mode, const double *dir)
{
  double v[3];
  if (s->status != CRT_OK) return s->status;
  if (mode != CRT_MODE_SLIDING && mode != CRT_MODE_STICKING) return CRT_BAD_ARGUMENT;
  if (mode == CRT_MODE_SLIDING && !(dir[0] * dir[0] + dir[1] * dir[1] > 0.0))
    return CRT_BAD_ARGUMENT;
  crt_project(s, s->t, s->q, 1);
  s->phase = CRT_CONTACT;
  crt_rough_scales(s, s->t);
  if (s->fr.couples) crt_couples_enter(s);
  s->fr.mode = mode;
  model_contact_velocity(s->prm, crt_u(s, s->t), s->q, v);
  if (mode == CRT_MODE_STICKING) {
    s->q[Q_COM_VELOCITY] -= v[0];
    s->q[Q_COM_VELOCITY + 1] -= v[1];
  } else {
    const double r = sqrt(dir[0] * dir[0] + dir[1] * dir[1]);
    s->fr.dir[0] = dir[0] / r; s->fr.dir[1] = dir[1] / r;
    s->fr.armed = sqrt(v[0] * v[0] + v[1] * v[1]) > s->fr.v_arm;
  }
  s->last_event_t = s->t;
  crt_changed(s);
  s->g_valid = 0;
  crt_rhs(s, s->t, s->q, s->f);
  s->f_valid = 1;
  return CRT_OK;
}

/* The Delassus matrix W (upper triangle w6[6], fixed axes) and the velocity of S v_S[3] at
   (t, q). */
void crt_eval_delassus(crt_session *s, double t, const double *q, double *w6, double *v_S)
{
  model_delassus(s->prm, crt_u(s, t), q, w6, v_S);
}

/* The contact as a wrench at (t, q): G's upper triangle g21[21] (row by row), a_free[6]
   and u6[6] = (v_S, A omega), fixed axes (general_contact_wrench). */
void crt_eval_contact_wrench(crt_session *s, double t, const double *q, double *g21,
                             double *a_free, double *u6)
{
  double w0[3], Yw[18];
  model_contact_wrench(s->prm, crt_u(s, t), q, g21, a_free, u6, w0, Yw);
}

/* Darboux-Keller's impact for W (w6[6]) and the velocity of S v0[3] (v0[2] < 0) with the
   session's mu_f, e, restitution law and tolerance: out[9] = (P_X, P_Y, P_Z, v_X+, v_Y+,
   v_Z+, E_n, E_t, stage).  Returns CRT_OK, CRT_PAINLEVE or CRT_RESTITUTION_REFUSED. */
int crt_eval_impact(const crt_session *s, const double *w6, const double *v0, double *out)
{
  crt_dk_result r;
  int i;
  const int status = crt_dk_impact(w6, v0, s->prm[CRT_P_friction], s->prm[CRT_P_e],
                                   (int)s->prm[CRT_P_restitution_model],
                                   crt_rough_dk_rtol(s), &r);
  for (i = 0; i < 9; ++i) out[i] = 0.0;
  if (status != CRT_OK) return status;
  for (i = 0; i < 3; ++i) { out[i] = r.P[i]; out[3 + i] = r.v[i]; }
  out[6] = r.work_n; out[7] = r.work_t; out[8] = (double)r.stage;
  return CRT_OK;
}

#endif /* CRT_FRICTION_H */
