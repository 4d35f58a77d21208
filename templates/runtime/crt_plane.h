/*
 * crt_plane.h: the plane z = 0 -- the height h of the lowest point S and its rate v_n
 * (E1.14), the reaction of persistent contact, the scales below which heights and speeds
 * are round-off, the projection of S onto the plane, and the lift-off (the one way back
 * to flight).  Models with the plane (MODEL_HAS_PLANE) only; the contact's two variants
 * (crt_smooth.h, crt_rough.h) and the event search (crt_events.h) build on it.
 *
 * Hand-written C: this file is templates/runtime/crt_plane.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_PLANE_H
#define CRT_PLANE_H

#include "crt_session.h"

#if MODEL_HAS_PLANE
static void crt_gap(crt_session *s, double t, const double *q, double *h, double *v_n)
{
  model_gap(s->prm, crt_u(s, t), q, h, v_n);
  ++s->stat[CRT_STAT_EVENT_FUNCTION_EVALUATIONS];
}

static void crt_contact_state(crt_session *s, double t, const double *q, double *N,
                              double *a_free)
{
  double dq[NQ];
  model_contact(s->prm, crt_u(s, t), q, dq, N, a_free);
  ++s->stat[CRT_STAT_EVENT_FUNCTION_EVALUATIONS];
}

/* The relative and absolute error a step of the method keeps.  An adaptive method keeps
   each step's error within atol + rtol |y|.  RK4 keeps no tolerance: its step is
   [run].step, cut to a quarter of a hop shorter than it (crt_collide), so a hop of
   duration tau takes steps of tau/4 whose error falls as tau^5 against the apex's tau^2:
   what it resolves is round-off.  (Read from rtol, RK4's hops had ended where the scene's
   rtol said: ell.toml entered contact after 12 impacts at rtol 1e-3, 48 at 1e-10, 68 at
   round-off, with the same 2150 steps; derive/docs/runtime.md.) */
static double crt_kept_rtol(const crt_session *s)
{
  return (int)s->opt[CRT_OPT_METHOD] == CRT_RK4 ? 64.0 * CRT_EPS : s->opt[CRT_OPT_RTOL];
}

static double crt_kept_atol(const crt_session *s)
{
  return (int)s->opt[CRT_OPT_METHOD] == CRT_RK4 ? 0.0 : s->opt[CRT_OPT_ATOL];
}

/* heights below this are not resolved: the integrator's own error in Z_C, or round-off */
static double crt_height_resolution(const crt_session *s, const double *q)
{
  const double size = fabs(q[MODEL_Z]) + s->opt[CRT_OPT_LENGTH_SCALE];
  return 10.0 * crt_max(crt_kept_atol(s) + crt_kept_rtol(s) * size, 64.0 * CRT_EPS * size);
}

/* a step may end this far below the plane (round-off of the height, and a margin far
   below what any test asks): lower means an event was missed, and the step is retried */
static double crt_penetration_tolerance(const crt_session *s, const double *q)
{
  const double L = s->opt[CRT_OPT_LENGTH_SCALE];
  return crt_max(1e-10 * L, 64.0 * CRT_EPS * (fabs(q[MODEL_Z]) + L));
}

/* normal speeds below this are round-off: S is touching, not hitting */
static double crt_speed_noise(crt_session *s, double t, const double *q)
{
  const double L = s->opt[CRT_OPT_LENGTH_SCALE];
  const double rate = model_rate(s->prm, crt_u(s, t), q);
  return 1e3 * CRT_EPS * (fabs(q[MODEL_ZD]) + rate * L + sqrt(s->prm[CRT_P_g] * L));
}

static void crt_track_height(crt_session *s, double t, double h)
{
  if (h < s->summary[CRT_SUMMARY_MIN_HEIGHT]) {
    s->summary[CRT_SUMMARY_MIN_HEIGHT] = h;
    s->summary[CRT_SUMMARY_T_MIN_HEIGHT] = t;
  }
}

/* After a step in contact, v_n at S is the integration's drift, a tolerance's worth.  A
   v_n of a sizeable fraction of sqrt(g L) + |Z_C'| (L the largest |CS|) is no drift: S
   has jumped to another point of the surface (one that is not strictly convex), whose
   velocity the projection would wipe out without an impact, gaining energy.  1 if so.
   Asked only of surfaces that may jump (model_surface_may_jump: a fixed-step RK4 run on a
   sphere can drift by more in a step of fast sliding, and there S cannot jump).  Also 1
   when another point across the body is as low as S to within the penetration tolerance
   (model_surface_second): the body lies on a line or a face (a cylinder landed on its
   side, its rim impacts accumulated), where S jumps between the line's ends at every
   tilt of round-off with no v_n to show it (275,810 steps of 1e-11 to 1e-6 s before). */
static int crt_surface_jumped(crt_session *s, double t, const double *q)
{
  double h, v_n;
  const double scale = sqrt(fabs(s->prm[CRT_P_g]) * s->opt[CRT_OPT_LENGTH_SCALE])
                       + fabs(q[MODEL_ZD]);
  crt_gap(s, t, q, &h, &v_n);
  return fabs(v_n) > crt_max(1e-3, 10.0 * crt_kept_rtol(s)) * scale
         || model_surface_second(s->prm, q, s->opt[CRT_OPT_LENGTH_SCALE])
            <= crt_penetration_tolerance(s, q);
}

/* S onto the plane: h and v_n are affine in Z_C and Z_C' with unit coefficients */
static void crt_project(crt_session *s, double t, double *q, int velocity_too)
{
  double h, v_n;
  int it;
  for (it = 0; it < 2; ++it) {
    crt_gap(s, t, q, &h, &v_n);
    q[MODEL_Z] -= h;
    if (velocity_too) q[MODEL_ZD] -= v_n;
  }
}

/* Lift off at (t, s->q) in contact, N the reaction that reached zero: S put on the plane
   with v_n = 0 (the contact constraint the phase ends with; N does not depend on Z_C and
   Z_C', which that changes), the rows before and after the event, the event, and the
   session in flight from t.  The one lift-off of the runtime: at the start of a step
   whose reaction is already non-positive (crt_contact_due), and where it crosses zero
   inside a step (crt_contact_transition). */
static void crt_lift_off(crt_session *s, crt_out *o, double t, double N)
{
  s->last_event_t = t;
  crt_project(s, t, s->q, 1);
  crt_emit(o, t, s->q, CRT_ROW_BEFORE_EVENT);
  s->phase = CRT_FLIGHT;
  crt_event(o, t, CRT_EV_LIFT_OFF, N, 0.0, 0.0, 0.0);
  ++s->stat[CRT_STAT_LIFT_OFFS];
  s->last_flight = 0.0;
  crt_emit(o, t, s->q, CRT_ROW_AFTER_EVENT);
  crt_changed(s);
  s->g_valid = 0;
}
#endif /* MODEL_HAS_PLANE */

#endif /* CRT_PLANE_H */
