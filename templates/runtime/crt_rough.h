/*
 * crt_rough.h: Coulomb friction at S (the friction models: MODEL_FRICTION, the `rough`
 * model) -- the contact's events: frictional impacts (Darboux-Keller, crt_dk.h), entering
 * contact, the transitions between sliding, sticking and flight and of the couples'
 * channels, and the bookkeeping after each step in contact; at its end the hooks through
 * which the runtime reaches it (crt_contact.h chooses this file for the friction models).
 * The modes themselves are crt_rough_modes.h; the friction models' public functions are
 * crt_rough_api.h.
 *
 * Hand-written C: this file is templates/runtime/crt_rough.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * ---- Impacts and transitions (derive/friction.py) ---------------------------------------
 * An impact is Darboux-Keller's (crt_dk.h) with the model's W at S and the restitution law
 * prm[CRT_P_restitution_model]; it refuses with status painleve or restitution_refused.
 * Transitions (events, each with the rows before and after it):
 *   sliding, N reaches 0              -> flight (lift_off);
 *   sliding from rest, the slip       -> the friction follows the slip from there on
 *   reaches v_freeze unarmed             (armed along it; no event);
 *   sliding, the slip reaches 0       -> slip set to 0; sticking if the sticking reaction R
 *                                        is inside the cone (stick), flight if R_Z <= 0
 *                                        (lift_off), else sliding again from rest along
 *                                        -R_t/|R_t| (reversal);
 *   sticking, |R_t| reaches mu_f R_Z  -> sliding from rest along -R_t/|R_t| (slip), or
 *                                        flight if R_Z <= 0 (lift_off).
 * Entering contact (impacts accumulating, or S resting on the plane) chooses the mode by
 * the slip: sliding along it, or from rest as above.
 */
#ifndef CRT_ROUGH_H
#define CRT_ROUGH_H

#include "crt_dk.h"
#include "crt_rough_modes.h"

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
static void crt_rough_onset_at(const double *w6, const double *R, double WR_n, double mu_f,
                               double th, double *g, double *along)
{
  const double c = cos(th), s = sin(th);
  const double k_f = w6[5] - mu_f * (w6[2] * c + w6[4] * s);
  const double N = WR_n / k_f;
  /* the impulse-like vector N (e_Z - mu_f sigma) - R, and a_t = W_t. of it */
  const double x = -N * mu_f * c - R[0], y = -N * mu_f * s - R[1], z = N - R[2];
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

/* S on the plane with its slip at round-off, at (t, s->q): the slip set to 0 (by an impulse
   at S, crt_rough_stop_slip); then CRT_MODE_STICKING when the sticking reaction R is inside
   the cone, CRT_MODE_FLIGHT when R_Z <= 0, else CRT_MODE_SLIDING from rest along the
   direction the slip takes (crt_rough_onset; the mode is set), or CRT_MODE_FLIGHT where no
   direction can slide and S leaves the plane unpushed, or status painleve where it cannot */
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

/* Enter contact at (t, s->q) (the hook crt_contact_enter): S put on the plane and the normal
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

/* The frictional impact at (t, s->q) (crt_contact_impact; S on the plane approaching at
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
  const double mu_c = crt_couple_bound(s, c), before = crt_norm_of(dim, w->u + first);
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
    if (Tn <= mu_c * w2.N) {
      crt_couples_reaim(s, t);
      ++s->stat[CRT_STAT_COUPLE_STOPS];
      crt_rough_mark(s, o, t, c ? CRT_EV_ROLL_STOP : CRT_EV_SPIN_STOP, Tn / (mu_c * w2.N),
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
  crt_rough_mark(s, o, t, c ? CRT_EV_ROLL_START : CRT_EV_SPIN_START, Tn / (mu_c * w2.N), before,
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
    double N, before, slip_value;
    int mode;
    crt_rough_sliding(s, t, s->q, dq, &N, v);
    before = sqrt(v[0] * v[0] + v[1] * v[1]);
    slip_value = crt_rough_slip_value(s, v);
    if (!s->fr.couples && !s->fr.armed && before > 0.0
        && crt_rough_arm_value(s, v) < crt_min(N / F, slip_value)) {
      /* a slip from rest at v_freeze (crt_rough_arm_value): armed along itself, no event;
         sliding along the slip must leave N its coefficient (else painleve, as where the
         end of a step arms it: crt_rough_after_step) */
      s->fr.dir[0] = v[0] / before; s->fr.dir[1] = v[1] / before;
      s->fr.armed = 1;
      crt_changed(s);
      s->g_valid = 0;
      crt_rough_sliding(s, t, s->q, dq, &N, v);
      crt_rough_consistent(s, t, N);
      return;
    }
    if (N / F <= crt_rough_slip_value(s, v)) { crt_lift_off(s, o, t, N); return; }
    /* the slip reached 0 */
    crt_project(s, t, s->q, 1);
    crt_emit(o, t, s->q, CRT_ROW_BEFORE_EVENT);
    crt_rough_scales(s, t);
    mode = crt_rough_at_rest(s, t, R);
    if (mode == CRT_MODE_FLIGHT) {
      s->phase = CRT_FLIGHT;
      s->last_flight = 0.0;
      ++s->stat[CRT_STAT_LIFT_OFFS];
      crt_rough_mark(s, o, t, CRT_EV_LIFT_OFF, R[2], before, CRT_MODE_FLIGHT);
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
  const double t = s->t, mu_f = s->prm[CRT_P_friction];
  double dq[NQ], v[3], normal, ratio;
  if (s->fr.couples) crt_couples_after_step(s);
  if (s->fr.mode == CRT_MODE_STICKING) {
    double R[3];
    crt_rough_stop_slip(s, t, s->q);
    crt_rough_sticking(s, t, s->q, dq, R);
    normal = R[2];
    ratio = R[2] > 0.0 ? sqrt(R[0] * R[0] + R[1] * R[1]) / (mu_f * R[2]) : HUGE_VAL;
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

/* ---- the hooks (crt_contact.h: what the runtime calls, in every contact variant) ------- */
/* the right-hand side where S is held on the plane (sliding or sticking): 1, else 0 */
static int crt_contact_rhs(crt_session *s, double t, const double *u, const double *q,
                           double *dq)
{
  (void)u;
  if (s->phase != CRT_CONTACT) return 0;
  crt_rough_rhs(s, t, q, dq);
  return 1;
}

/* the event function in contact: zero at the modes' transitions (*deriv: not used, 0) */
static double crt_contact_event_value(crt_session *s, double t, const double *y,
                                      double *deriv)
{
  *deriv = 0.0;
  return crt_rough_event_value(s, t, y);
}

/* with couples the event function is the least of values of other scales (a kink where
   the least changes): crt_root bisects where the secant stalls on one side */
static int crt_contact_kinked(const crt_session *s)
{
  return s->fr.couples;
}

/* crt_init: which couples are on, none held */
static void crt_contact_start(crt_session *s)
{
  s->fr.spin.on = s->prm[CRT_P_spin_friction] > 0.0;
  s->fr.roll.on = s->prm[CRT_P_rolling_resistance] > 0.0;
  s->fr.couples = s->fr.spin.on || s->fr.roll.on;
  s->fr.spin.held = s->fr.roll.held = 0;
}

/* enter persistent contact (crt_rough_enter_contact) */
static void crt_contact_enter(crt_session *s, crt_out *o, double t, double v_cut,
                              double t_accumulation)
{
  crt_rough_enter_contact(s, o, t, v_cut, t_accumulation);
}

/* The impact at (t, s->q), S approaching at v_n: Darboux-Keller's; the state after into
   q_plus, the normal velocity of S after into *v_plus, the event row.  0 when refused
   (s->status says why). */
static int crt_contact_impact(crt_session *s, crt_out *o, double t, double v_n,
                              double *q_plus, double *v_plus)
{
  crt_dk_result dk;
  double impulse, gap2;
  if (!crt_rough_impact(s, t, q_plus, &dk)) return 0;
  impulse = dk.P[2];
  crt_gap(s, t, q_plus, &gap2, v_plus);
  crt_rough_event(s, o, t, CRT_EV_IMPACT, impulse, v_n, *v_plus, 0.0, CRT_MODE_FLIGHT, &dk);
  return 1;
}

/* the event function reached 0 inside a step, at (t, s->q): lift-off, stick, slip, ... */
static void crt_contact_transition(crt_session *s, crt_out *o, double t)
{
  crt_rough_transition(s, o, t);
}

/* A transition due at the start of a step (the event function already non-positive):
   applied.  CRT_DUE_NONE, or CRT_DUE_SILENT: the controller of a closed loop is not
   called after it (a rough contact's transition at a step's start never was). */
static int crt_contact_due(crt_session *s, crt_out *o)
{
  if (crt_rough_event_value(s, s->t, s->q) > 0.0) return CRT_DUE_NONE;
  crt_rough_transition(s, o, s->t);
  return CRT_DUE_SILENT;
}

/* after an accepted step in contact (S projected onto the plane): crt_rough_after_step;
   0 when the sliding turned inconsistent (status painleve) */
static int crt_contact_after_step(crt_session *s)
{
  crt_rough_after_step(s);
  return s->status >= 0;
}

#endif /* CRT_ROUGH_H */
