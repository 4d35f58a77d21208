/*
 * crt_smooth.h: the smooth plane (the paper's: no friction) -- its contact's hooks.  In
 * contact S is held on the plane by the normal reaction N alone (model_contact), and lifts
 * off where N reaches zero; an impact is the impact map (E1.10-E1.16) with restitution e;
 * entering contact removes S's normal velocity by a plastic impulse.  crt_contact.h
 * chooses this file for the models with the plane and without friction.
 *
 * Hand-written C: this file is templates/runtime/crt_smooth.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_SMOOTH_H
#define CRT_SMOOTH_H

#include "crt_plane.h"

/* the right-hand side where S is held on the plane: 1, else 0 */
static int crt_contact_rhs(crt_session *s, double t, const double *u, const double *q,
                           double *dq)
{
  (void)t;
  if (s->phase != CRT_CONTACT) return 0;
  {
    double N, a_free;
    model_contact(s->prm, u, q, dq, &N, &a_free);
  }
  return 1;
}

/* the event function in contact: the reaction N (*deriv, its rate: not used, 0) */
static double crt_contact_event_value(crt_session *s, double t, const double *y,
                                      double *deriv)
{
  double N, a_free;
  crt_contact_state(s, t, y, &N, &a_free);
  *deriv = 0.0;
  return N;
}

/* the event function has no kinks */
static int crt_contact_kinked(const crt_session *s)
{
  (void)s;
  return 0;
}

/* crt_init: nothing to set */
static void crt_contact_start(crt_session *s)
{
  (void)s;
}

/* Enter persistent contact at (t, s->q): S put on the plane, and its normal velocity
   v_cut (what the remaining hops would have carried) removed by a plastic impulse at S,
   -v_cut/k along n (the impact map with e = 0): it acts on omega through d as the
   remaining impacts would, so the state after the cut differs from the accumulated
   cascade only at second order. */
static void crt_contact_enter(crt_session *s, crt_out *o, double t, double v_cut,
                              double t_accumulation)
{
  double N, a_free, q_plastic[NQ], impulse;
  int i;
  crt_project(s, t, s->q, 0);
  model_impact(s->prm, 0.0, crt_u(s, t), s->q, q_plastic, &impulse);
  for (i = 0; i < NQ; ++i) s->q[i] = q_plastic[i];
  crt_project(s, t, s->q, 1);               /* the round-off left in h and v_n */
  s->phase = CRT_CONTACT;
  crt_contact_state(s, t, s->q, &N, &a_free);
  if (N < s->summary[CRT_SUMMARY_MIN_NORMAL]) s->summary[CRT_SUMMARY_MIN_NORMAL] = N;
  crt_event(o, t, CRT_EV_CONTACT, N, v_cut, 0.0, t_accumulation);
  ++s->stat[CRT_STAT_CONTACTS];
}

/* The impact at (t, s->q), S approaching at v_n: the impact map with restitution e; the
   state after into q_plus, the normal velocity of S after into *v_plus, the event row.
   Never refused: 1. */
static int crt_contact_impact(crt_session *s, crt_out *o, double t, double v_n,
                              double *q_plus, double *v_plus)
{
  double impulse, gap2;
  model_impact(s->prm, s->prm[CRT_P_e], crt_u(s, t), s->q, q_plus, &impulse);
  crt_gap(s, t, q_plus, &gap2, v_plus);
  crt_event(o, t, CRT_EV_IMPACT, impulse, v_n, *v_plus, 0.0);
  return 1;
}

/* N reached 0 inside a step, at (t, s->q): lift off */
static void crt_contact_transition(crt_session *s, crt_out *o, double t)
{
  double N, a_free;
  crt_contact_state(s, t, s->q, &N, &a_free);
  crt_lift_off(s, o, t, N);
}

/* The reaction already non-positive at the start of a step: lift off now.  CRT_DUE_NONE,
   or CRT_DUE_TELL (the controller of a closed loop hears of the lift-off). */
static int crt_contact_due(crt_session *s, crt_out *o)
{
  double N, a_free;
  crt_contact_state(s, s->t, s->q, &N, &a_free);
  if (N > 0.0) return CRT_DUE_NONE;
  crt_lift_off(s, o, s->t, N);
  return CRT_DUE_TELL;
}

/* after an accepted step in contact (S projected onto the plane): the summary's least
   normal reaction; 1 (the step stands) */
static int crt_contact_after_step(crt_session *s)
{
  double N, a_free;
  crt_contact_state(s, s->t, s->q, &N, &a_free);
  if (N < s->summary[CRT_SUMMARY_MIN_NORMAL]) s->summary[CRT_SUMMARY_MIN_NORMAL] = N;
  return 1;
}

#endif /* CRT_SMOOTH_H */
