/*
 * Hand-written C: this file is templates/control/crt_hop.c, copied verbatim into
 * generated/control/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.  It includes the controllers' ABI,
 * crt_call.h, from generated/runtime/.
 *
 * crt_hop.c: per-hop feedback as a C controller of the closed loop (crt_call.h's ABI):
 * the controller of derive/control/hop.py (HopController), for a robot's firmware or for
 * runs with no Python per call.  Every number is in its memory (crt_hop_params), set by
 * the caller: one compiled file serves every design.
 *
 * After each impact it reads the impact's time and C's upward velocity, forms the
 * deviation s = (phase, velocity, gait before) from the orbit's, sets the coming hop's
 * gait amplitude a* - K s (clamped to limit a*) and writes the law: the gait in use
 * (corrected to the law's value and rate now) blended into the new one over tb by a
 * smoothstep, as cubic Hermite pieces of step h over n pieces; at the start, the design's
 * gait.  No heap, no globals: C99, and valid C++.
 */
#include <math.h>

#include "crt_hop.h"

int crt_hop_sizeof(void) { return (int)sizeof(crt_hop_params); }

/* the cubic of one coordinate on [t0, t1] from value and rate at both ends (c3 = x0 and
   c2 = v0 exactly), as derive.runtime.loop.hermite */
static void crt_hop_hermite(double t0, double x0, double v0, double t1, double x1, double v1,
                            double *c)
{
  const double h = t1 - t0, d = x1 - x0;
  c[1] = (3.0 * d - h * (2.0 * v0 + v1)) / (h * h);
  c[0] = (h * (v0 + v1) - 2.0 * d) / (h * h * h);
  c[2] = v0;
  c[3] = x0;
}

/* z and z' of the gait a sin(W t) */
static void crt_hop_gait(double a, double W, double t, double *z, double *v)
{
  *z = a * sin(W * t);
  *v = a * W * cos(W * t);
}

/* the law from t0 (u0: the law now), the old gait blended into the new; as
   derive.control.hop.blend_law */
static int crt_hop_blend(const crt_hop_params *P, double t0, const double *u0, double a_old,
                         double a_new, int max_knots, int *n_knots, double *knots,
                         double *coef)
{
  double zo0, vo0, dz, dv, z_prev = 0.0, v_prev = 0.0, t_prev = t0;
  int i, c;
  if (P->n + 1 > max_knots) return -1;
  crt_hop_gait(a_old, P->W, t0, &zo0, &vo0);
  dz = u0[2] - zo0;
  dv = u0[5] - vo0;
  for (i = 0; i <= P->n; ++i) {
    const double t = t0 + P->h * (double)i;
    double zo, vo, zn, vn, x, s, ds, z, v;
    crt_hop_gait(a_old, P->W, t, &zo, &vo);
    zo = zo + dz + dv * (t - t0);
    vo = vo + dv;
    crt_hop_gait(a_new, P->W, t, &zn, &vn);
    x = (t - t0) / P->tb;
    x = x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x);
    s = x * x * (3.0 - 2.0 * x);
    ds = 6.0 * x * (1.0 - x);
    z = zo + s * (zn - zo);
    v = vo + s * (vn - vo) + ds / P->tb * (zn - zo);
    if (i == 0) {
      z = u0[2];
      v = u0[5];
    }
    knots[i] = t;
    if (i > 0) {
      double *k = coef + 12L * (i - 1);
      for (c = 0; c < 2; ++c) {          /* x and y: as the law was at t0 (the axis) */
        const double x0 = i == 1 ? u0[c] : 0.0, v0 = i == 1 ? u0[3 + c] : 0.0;
        crt_hop_hermite(t_prev, x0, v0, t, 0.0, 0.0, k + 4 * c);
      }
      crt_hop_hermite(t_prev, z_prev, v_prev, t, z, v, k + 8);
    }
    z_prev = z;
    v_prev = v;
    t_prev = t;
  }
  *n_knots = P->n + 1;
  return 1;
}

/* The controller (crt_controller_fn): ctx is a crt_hop_params (crt_hop.h). */
int crt_hop_controller(void *ctx, const crt_call *call, int max_knots, int *n_knots,
                       double *knots, double *coef)
{
  crt_hop_params *P = (crt_hop_params *)ctx;
  double s[3], delta, a_new, r;
  int set;
  if (call->reason == 0) {
    P->a_prev = P->a_star;
    set = crt_hop_blend(P, call->t, call->u, P->a_star, P->a_star, max_knots, n_knots,
                        knots, coef);
    if (set > 0) P->law_end = knots[*n_knots - 1];
    return set;
  }
  if (call->reason != 2 || call->event != 1) {
    /* no impact for a while (resting contact, a long flight): within a period of the
       law's end the gait goes on from the law in use (beyond its last knot the last
       cubic would go on, unbounded) */
    if (call->t < P->law_end - P->T) return 0;
    set = crt_hop_blend(P, call->t, call->u, P->a_prev, P->a_prev, max_knots, n_knots,
                        knots, coef);
    if (set > 0) P->law_end = knots[*n_knots - 1];
    return set;
  }
  r = fmod(call->t - P->t_star + 0.5 * P->T, P->T);
  if (r < 0.0) r += P->T;
  s[0] = r - 0.5 * P->T;
  s[1] = call->q[P->zd] - P->v_star;
  s[2] = P->a_prev - P->a_star;
  delta = -(P->K[0] * s[0] + P->K[1] * s[1] + P->K[2] * s[2]);
  if (delta > P->limit * P->a_star) delta = P->limit * P->a_star;
  if (delta < -P->limit * P->a_star) delta = -P->limit * P->a_star;
  a_new = P->a_star + delta;
  r = P->a_prev;
  P->a_prev = a_new;
  set = crt_hop_blend(P, call->t, call->u, r, a_new, max_knots, n_knots, knots, coef);
  if (set > 0) P->law_end = knots[*n_knots - 1];
  return set;
}
