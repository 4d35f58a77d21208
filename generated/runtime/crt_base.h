/*
 * crt_base.h: the loop of the base model (crt_integrate for MODEL_BASE, in crt_loop.h's
 * place): a body on its face that sticks and slips, with exact events (issue 33).
 *
 * Hand-written C: this file is templates/runtime/crt_base.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * Four modes (s->bs.mode):
 *  - rest: the body is at rest at t; sticking holds if the gauge gamma of the wrench the
 *    rest needs (crt_face_gauge, mu_s) is below 1 (or at 1 and not rising); else the slip
 *    starts against the gauge's maximiser, along the stable direction of the slip's flow:
 *    where the flow turns off that direction, along its slow manifold to a twist of 1e-6
 *    v_scale (crt_base_onset_far: the stiff phase of a slip from rest, skipped); else (a
 *    slip along a line, or that start not exact or over an event) by its Taylor series
 *    (twist = G0 d + G1 d^2/2 until it reaches 1e2 eps); the edge and kern margins then
 *    of the mode taken (the rest's cp where it sticks, the slip's own where it slips);
 *  - stick: the state is constant; the event functions 1 - gamma, N, the centre of
 *    pressure's edge margin and (linear pressure) its kern margin are sampled every
 *    opt[CRT_OPT_HMAX]/8 (gamma by the gauge's bounds where they put it below 1 - 1e-3)
 *    and a sign change is located by the Illinois method
 *    (break-away: the slip starts; N: status lift_off; the edge: status tipping; the kern:
 *    status face_lifting); a root of the gauge or a margin located where N is below
 *    crt_base_n_res is N's (crt_base_tie): there gamma (the friction the rest needs over
 *    mu N) is round-off, infinite at N = 0, so its root is N's give or take round-off,
 *    and a slip started there by that round-off's sign ran on past the lift-off (a
 *    lift-off 1.9e-6 s late, at -O1 only);
 *  - translation: a slip along a line that does not turn (psi' = 0, no yaw or lateral
 *    rate) is a quadrature of the law (crt_base_flow.h's crt_base_tr_*: the horizontal
 *    momentum changes by -mu N e alone), so its state at any t is the law's values there;
 *    its functions (the signed speed, N, the margins) are sampled and located as the
 *    stick's (crt_base_sample_step), the speed's root its stop; where a sample finds the
 *    flow off the line (crt_base_line_flow's test), the slip's steps below go on from the
 *    last sample;
 *  - slip, along a line (s->bs.line): while the scaled twist xi = (V_O, ell psi') keeps
 *    its direction d (a translation along a fixed line, a spin in place: the flow's part
 *    off d below 1e-12 of it at every stage), integrated in t with the friction of d held,
 *    which is the slip's own friction while xi.d > 0 and smooth through 0, so the stop is
 *    the sign change of xi.d, located as the other events, and xi = 0 there (under linear
 *    pressure the friction of d at its consistent centre of pressure, as in s);
 *  - slip, else: integrated in the time s with dt/ds = rho = |xi| (the state z = (t, q)),
 *    so the end of the slip is approached without the friction's direction flipping: rho
 *    decays exponentially in s, the event rho = eps (1e-11 sqrt(g ell)) ends it and the
 *    linear decay's last rho/|rho'| is added.  A slip starts along a line and goes on in s
 *    from the first step whose flow turns off it.
 *    After a stop: rest (a stick, or a reversal).  Each step DOP853 (the tableau of
 *    crt_base_steps.h, Hairer's error norm and step control) with the error of rtol, atol
 *    on z at the body's own scales (crt_base_step), the first step of a slip along a line
 *    the last such slip's; the events (t_end, the stop, N, the edge, the kern) located
 *    inside a step on DOP853's dense output (Illinois on the step's fraction), the state
 *    at an event the dense output's there.
 * A run never goes on past lift-off, tipping or the face lifting: it stops there with that
 * status and an event at its time.  The closed loop (crt_set_control) is refused
 * (CRT_BAD_CONTROL).
 */
#ifndef CRT_BASE_H
#define CRT_BASE_H

#include "crt_base_flow.h"      /* the flow, its step, events and the slip's start */

/* crt_init: the body on its face (a fault: CRT_BAD_PARAMETERS), the mode of the start */
static void crt_contact_start(crt_session *s)
{
  const int fault = crt_base_body_set(&s->bs.body, s->prm);
  s->bs.stamp = -1;
  s->bs.xi[0] = s->bs.xi[1] = s->bs.xi[2] = 0.0;
  s->bs.eps = 1e-11 * s->bs.body.v_scale;
  /* a twist below the slip's end (round-off of a start at rest: C's velocity less the
     bodies' share) is the end's: at rest (a slip from it would stop before a step) */
  if (crt_base_rho(&s->bs.body, s->q) <= s->bs.eps) s->q[3] = s->q[4] = s->q[5] = 0.0;
  s->bs.mode = crt_base_rho(&s->bs.body, s->q) > 0.0 ? CRT_BASE_SLIP : CRT_BASE_REST;
  s->bs.hs = 0.0;
  s->bs.ht = 0.0;
  s->bs.fsal = 0;
  crt_base_line_start(s);
  s->phase = CRT_CONTACT;
  if (fault >= 0) {
    s->bad_parameter = fault;
    s->status = CRT_BAD_PARAMETERS;
  }
}

/* the first step (the slip's own is set where a slip starts) */
static double crt_first_step(crt_session *s)
{
  return 1e-3 * s->bs.body.t_scale;
}

/* stop the run at t with a status and its event, after the row the caller wrote at t */
static void crt_base_stop(crt_session *s, crt_out *o, int status, int event, double value)
{
  crt_event(o, s->t, event, value, 0.0, 0.0, 0.0);
  if (event == CRT_EV_LIFT_OFF) ++s->stat[CRT_STAT_LIFT_OFFS];
  s->status = status;
}

/* stop the run at t with a status and its event: the row before it, then the stop */
static void crt_base_end(crt_session *s, crt_out *o, int status, int event, double value)
{
  crt_emit(o, s->t, s->q, CRT_ROW_BEFORE_EVENT);
  crt_base_stop(s, o, status, event, value);
}

/* the row at a step's end, as crt_loop.h writes it: every step's without output_dt; with
   it only a grid time the step ends on (crt_base_rows leaves that one to the step's own
   row) and the end time, so that the rows between events are the grid's alone */
static void crt_base_step_row(crt_session *s, crt_out *o, double t_end)
{
  const double out_dt = s->opt[CRT_OPT_OUTPUT_DT];
  if (!(out_dt > 0.0) || s->t >= t_end || s->out_origin + (s->out_k - 1.0) * out_dt == s->t)
    crt_emit(o, s->t, s->q, CRT_ROW_STEP);
}

/* At rest at s->t (after a stop of the slip when after_stop, else at the start): stick,
   or slip off (a slip, or a reversal after a stop), or stop (lift-off, tipping, the face
   lifting).  The mode first, then the margins of the reaction of the mode taken: the
   rest's centre of pressure only where the rest holds (a rest that cannot hold has no
   reaction: a reversal's new slip has its own cp, which its first step's margins test,
   crt_base_slip_step); N is the same in both. */
static void crt_base_settle(crt_session *s, crt_out *o, int after_stop)
{
  double g[CRT_BASE_NG_STICK], later[CRT_BASE_NG_STICK], xi[3];
  int i, stick;
  void (*const end)(crt_session *, crt_out *, int, int, double)
      = after_stop ? crt_base_stop : crt_base_end;  /* (after a stop: its row is written) */
  crt_base_stick_g(s, s->t, g, s->bs.xi);
  if (g[1] <= 0.0) { end(s, o, CRT_LIFT_OFF, CRT_EV_LIFT_OFF, g[1]); return; }
  stick = g[0] > 1e-12;
  if (!stick && g[0] >= -1e-12) {          /* at 1: sticks unless the gauge is rising */
    for (i = 0; i < 3; ++i) xi[i] = s->bs.xi[i];
    crt_base_stick_g(s, s->t + 1e-6 * s->bs.body.t_scale, later, xi);
    stick = !(later[0] < g[0]);
  }
  if (!stick) {
    const double t_before = s->t;
    if (after_stop) {
      crt_event(o, s->t, CRT_EV_REVERSAL, 1.0 - g[0], 0.0, 0.0, 0.0);
      ++s->stat[CRT_STAT_REVERSALS];
    } else {
      crt_emit(o, s->t, s->q, CRT_ROW_BEFORE_EVENT);
      crt_event(o, s->t, CRT_EV_SLIP, 1.0 - g[0], 0.0, 0.0, 0.0);
      ++s->stat[CRT_STAT_SLIPS];
    }
    if (crt_base_onset(s, o)) {
      crt_emit(o, s->t, s->q, CRT_ROW_AFTER_EVENT);
      return;
    }
    s->t = t_before;                       /* the flow points back: it stays */
  }
  if (crt_base_tie(&s->bs.body, g[1])) {}  /* (cp unknown: N's root is the stick's) */
  else if (g[2] <= 0.0) { end(s, o, CRT_TIPPING, CRT_EV_TIPPING, g[2]); return; }
  else if (g[3] <= 0.0) {
    end(s, o, CRT_FACE_LIFTING, CRT_EV_FACE_LIFTING, g[3]);
    return;
  }
  if (after_stop) {
    crt_event(o, s->t, CRT_EV_STICK, 1.0 - g[0], 0.0, 0.0, 0.0);
    ++s->stat[CRT_STAT_STICKS];
  }
  s->bs.mode = CRT_BASE_STICK;
  s->bs.has_p = 0;
  for (i = 0; i < CRT_BASE_NG_STICK; ++i) s->bs.g[i] = g[i];
}

/* The stick's and the translation's functions at t (crt_base_stick_g, crt_base_tr_g): aux
   the gauge's maximiser (the stick: warm in, out) or the state at t (the translation) */
static void crt_base_sample_g(crt_session *s, double t, double *g, double *aux)
{
  if (s->bs.mode == CRT_BASE_STICK) crt_base_stick_g(s, t, g, aux);
  else crt_base_tr_g(s, t, g, aux);
}

/* One sample of the stick or of the translation: its events located in [t, t + h].  Their
   functions (the stick's 1 - gamma, N, the margins; the translation's signed speed, N,
   the margins) depend on t alone, and a short excursion of one below 0 (a break of a few
   ms, gamma just past 1 near its maximum) must not fall between two samples.  Two rules,
   from the samples themselves:
   - the step: h <= 2 g_k / r_k for every g_k > 0 falling at the observed rate r_k (the
     secant of the last two samples; at a stick's start the previous one is taken 1/100
     of a sample earlier).  At the linear rate the sample lands where g_k = -g_k, past a
     crossing; approaching a minimum (g_k convex) the secant is steeper than the tangent,
     so the sample lands before the tangent's g = -g_k: for g = b (t - tm)^2 - a the
     tangent's step from tm - T ends at tm - a/(b T), inside the excursion |t - tm| <
     sqrt(a/b) whenever T is past it; the steps shrink towards a minimum and grow past it
     (at least 1e-6 of a sample: a tangency g_min = 0 exactly is not stepped into forever);
   - the minimum: where the parabola through the last three samples has its minimum
     inside the step, g is evaluated there too, and a value <= 0 is a crossing before it
     (an excursion the step spans whole).
   A sample is at most opt[CRT_OPT_HMAX]/8 long.  The translation's first root of the
   speed is its stop (a stick or a reversal, crt_base_settle); where its flow leaves the
   line inside a sample (s->bs.turned) the slip's DOP853 steps go on from the sample's
   start, whose state is exact. */
static void crt_base_sample_step(crt_session *s, crt_out *o, double t_end)
{
  const double hmax = s->opt[CRT_OPT_HMAX] / 8.0;
  const int stick = s->bs.mode == CRT_BASE_STICK;
  double h = crt_min(hmax, t_end - s->t), t1, tol, shrink;
  double g1[CRT_BASE_NG_STICK], a1[NQ], aux[NQ], first = HUGE_VAL, g[CRT_BASE_NG_STICK];
  double qi[NQ], *const chain = stick ? a1 : qi;   /* (Illinois': the maximiser warm) */
  int k, which = -1, i;
  for (i = 0; i < 3; ++i) a1[i] = s->bs.xi[i];
  if (!s->bs.has_p) {                      /* the previous sample: 1/100 of one earlier */
    s->bs.tp = s->t - 1e-2 * hmax;
    crt_base_sample_g(s, s->bs.tp, s->bs.gp, a1);
    s->bs.has_p = 1;
  }
  for (k = 0; k < CRT_BASE_NG_STICK; ++k) {
    const double r = (s->bs.gp[k] - s->bs.g[k]) / (s->t - s->bs.tp);
    if (s->bs.g[k] > 0.0 && r > 0.0) h = crt_min(h, crt_max(2.0 * s->bs.g[k] / r, 1e-6 * hmax));
  }
  while (!crt_base_rows_fit(s, o, crt_base_rows_before(s, s->t + h, o->cap), &shrink)) {
    if (shrink == 1.0) return;             /* (taken again, the same, with room) */
    h *= shrink;                           /* (no buffer holds its rows: a shorter sample,
                                              counted again: the count stops at cap + 1) */
  }
  t1 = s->t + h;
  tol = 1e-15 * crt_max(1.0, fabs(t1)) + 1e-15 * s->bs.body.t_scale;
  crt_base_sample_g(s, t1, g1, a1);
  for (k = 0; k < CRT_BASE_NG_STICK; ++k) {
    double end = t1, gend = g1[k], root;
    if (!(s->bs.g[k] > 0.0)) continue;
    if (gend > 0.0) {                      /* a minimum inside the step: g there */
      const double d1 = (s->bs.g[k] - s->bs.gp[k]) / (s->t - s->bs.tp);
      const double d2 = (g1[k] - s->bs.g[k]) / h, a = (d2 - d1) / (t1 - s->bs.tp);
      const double tv = a > 0.0 ? 0.5 * (s->t + t1) - d2 / (2.0 * a) : s->t;
      if (tv > s->t && tv < t1) {
        double gv[CRT_BASE_NG_STICK];
        for (i = 0; i < 3; ++i) aux[i] = a1[i];
        crt_base_sample_g(s, tv, gv, aux);
        end = tv;
        gend = gv[k];
      }
    }
    if (gend <= 0.0) {
#define CRT_BASE_SAMPLE_EVAL(x) (crt_base_sample_g(s, (x), g, chain), g[k])
      CRT_BASE_ILLINOIS(s->t, s->bs.g[k], end, gend, root, tol, CRT_BASE_SAMPLE_EVAL);
#undef CRT_BASE_SAMPLE_EVAL
      if (k != 1 && (stick || k != 0)) {   /* N there: a break, a tip or the lift-off */
        double gr[CRT_BASE_NG_STICK];
        for (i = 0; i < 3; ++i) aux[i] = chain[i];
        crt_base_sample_g(s, root, gr, aux);
        if (crt_base_tie(&s->bs.body, gr[1])) continue;  /* (N's root: located, or later) */
      }
      if (root < first) { first = root; which = k; }
    }
  }
  if (!stick && s->bs.turned) {            /* off the line: the slip's steps from s->t */
    s->bs.mode = CRT_BASE_SLIP;
    s->bs.hs = 0.0;
    s->bs.fsal = 0;
    return;
  }
  crt_base_rows(s, o, which < 0 ? t1 : first, 0, 0);
  ++s->stat[CRT_STAT_STEPS];
  if (which < 0) {
    s->bs.tp = s->t;
    for (i = 0; i < CRT_BASE_NG_STICK; ++i) s->bs.gp[i] = s->bs.g[i];
    s->t = t1;
    for (i = 0; i < CRT_BASE_NG_STICK; ++i) s->bs.g[i] = g1[i];
    if (stick) for (i = 0; i < 3; ++i) s->bs.xi[i] = a1[i];
    else { for (i = 0; i < NQ; ++i) s->q[i] = a1[i]; crt_changed(s); }
    crt_base_step_row(s, o, t_end);
    return;
  }
  s->t = first;
  for (i = 0; i < 3; ++i) aux[i] = s->bs.xi[i];
  crt_base_sample_g(s, s->t, g, aux);      /* the maximiser, or the state, at the event */
  if (stick) for (i = 0; i < 3; ++i) s->bs.xi[i] = aux[i];
  else { for (i = 0; i < NQ; ++i) s->q[i] = aux[i]; crt_changed(s); }
  if (which == 1) { crt_base_end(s, o, CRT_LIFT_OFF, CRT_EV_LIFT_OFF, g[1]); return; }
  if (which == 2) { crt_base_end(s, o, CRT_TIPPING, CRT_EV_TIPPING, g[2]); return; }
  if (which == 3) { crt_base_end(s, o, CRT_FACE_LIFTING, CRT_EV_FACE_LIFTING, g[3]); return; }
  crt_emit(o, s->t, s->q, CRT_ROW_BEFORE_EVENT);
  if (!stick) {                            /* the translation's stop: V_O = 0 */
    s->q[3] = s->q[4] = 0.0;
    crt_changed(s);
    s->bs.mode = CRT_BASE_REST;
    crt_base_settle(s, o, 1);
    if (s->status == CRT_PAUSED && s->bs.mode == CRT_BASE_STICK)
      crt_emit(o, s->t, s->q, CRT_ROW_AFTER_EVENT);
    return;
  }
  crt_event(o, s->t, CRT_EV_SLIP, 1.0 - g[0], 0.0, 0.0, 0.0);
  ++s->stat[CRT_STAT_SLIPS];
  if (!crt_base_onset(s, o)) {                /* no slip after all: the stick goes on */
    s->bs.has_p = 0;
    for (i = 0; i < CRT_BASE_NG_STICK; ++i) s->bs.g[i] = g[i];
    s->bs.g[0] = crt_max(g[0], 0.0);
    return;
  }
  crt_emit(o, s->t, s->q, CRT_ROW_AFTER_EVENT);
}

/* one step of the slip in s, its events located */
static void crt_base_slip_step(crt_session *s, crt_out *o, double t_end)
{
  double z0[CRT_BASE_NZ], f0[CRT_BASE_NZ], z1[CRT_BASE_NZ], f1[CRT_BASE_NZ], zt[CRT_BASE_NZ];
  double ft[CRT_BASE_NZ], k[16][CRT_BASE_NZ], F[7][CRT_BASE_NZ], g0[CRT_BASE_NG];
  double g1[CRT_BASE_NG], gt[CRT_BASE_NG], N, cp[2], rho, err, hs, wanted, span;
  double first = HUGE_VAL;
  int k_, which = -1, i, dense = 0, same, cut = 0;
  z0[0] = s->t;
  for (i = 0; i < NQ; ++i) z0[1 + i] = s->q[i];
  s->bs.lateral = 0.0;
  same = s->bs.fsal;                       /* the last step ended here: its rate (FSAL) */
  for (i = 0; same && i < CRT_BASE_NZ; ++i) same = s->bs.fz[i] == z0[i];
  if (same) {
    for (i = 0; i < CRT_BASE_NZ; ++i) f0[i] = s->bs.ff[i];
    N = s->bs.fN; cp[0] = s->bs.fcp[0]; cp[1] = s->bs.fcp[1]; rho = s->bs.frho;
  } else {
    crt_base_zrhs(s, z0, f0, &N, cp, &rho);
  }
  s->bs.fsal = 0;
  crt_base_slip_g(s, t_end, z0, N, cp, rho, g0);
  /* a stop already reached where the step starts: N or cp jumped there (the friction of
     a slip's onset against the rest's wrench moves cp at once) */
  if (g0[CRT_BASE_LIFT] <= 0.0) { crt_base_end(s, o, CRT_LIFT_OFF, CRT_EV_LIFT_OFF, N); return; }
  if (crt_base_tie(&s->bs.body, N)) {}     /* (cp unknown: N's root is the step's) */
  else if (g0[CRT_BASE_TIP] <= 0.0) {
    crt_base_end(s, o, CRT_TIPPING, CRT_EV_TIPPING, g0[CRT_BASE_TIP]);
    return;
  } else if (g0[CRT_BASE_KERN] <= 0.0) {
    crt_base_end(s, o, CRT_FACE_LIFTING, CRT_EV_FACE_LIFTING, g0[CRT_BASE_KERN]);
    return;
  }
  if (!(s->bs.hs > 0.0))                   /* a slip's first step: along a line the last
                                              slip's, else a thousandth of the time scale */
    s->bs.hs = s->bs.line ? (s->bs.ht > 0.0 ? s->bs.ht : 1e-3 * s->bs.body.t_scale)
                          : 1e-3 * s->bs.body.t_scale / crt_max(rho, 1e-300);
  /* at most opt[CRT_OPT_HMAX] of time at the start's rate dt/ds (1 along a line, rho in
     s): the step is clipped there, not taken longer and refused (below) */
  hs = wanted = crt_min(s->bs.hs, s->opt[CRT_OPT_HMAX] / crt_max(f0[0], 1e-300));
  if (s->bs.line && crt_law_next_knot(&s->law, s->t) < s->t + hs) {
    hs = crt_law_next_knot(&s->law, s->t) - s->t;  /* in t: steps end on a table's knots */
    cut = 1;
  }
  for (;;) {
    err = crt_base_step(s, z0, f0, hs, k, z1, f1, &N, cp, &rho);
    if (s->bs.line && s->bs.lateral > 1e-24) {   /* (lateral: the turn squared) */
      /* the flow turns off the line: this slip in s from here (the step in s that covers
         as much time at the start's rate, at most a slip's first step: a slip from rest
         starts at rho ~ 1e-9, and grows exponentially in s) */
      s->bs.line = 0;
      s->bs.fsal = 0;
      s->bs.hs = crt_min(hs, 1e-3 * s->bs.body.t_scale)
                 / crt_max(crt_base_rho(&s->bs.body, s->q), 1e-300);
      return;
    }
    /* a step covers at most opt[CRT_OPT_HMAX] of time: in s, a step from a slip's tiny
       start (rho ~ 1e-9: a slip from rest that turned off its line at once) can cover an
       exponential growth of rho in s, to 1e89 with an error norm below 1 (relative to
       z1's own size); a longer one is shrunk by hmax over its time (less than the share
       that fits: t grows faster than linearly in s while rho grows), by 1e-3 at most */
    span = s->bs.line ? hs : z1[0] - z0[0];   /* (along a line: hs, not its round-off) */
    if (err <= 1.0 && crt_finite(z1 + 1) && span - span == 0.0 && span <= s->opt[CRT_OPT_HMAX])
      break;
    ++s->stat[CRT_STAT_REJECTED];
    cut = 0;                               /* (shrunk by its error: no knot's cut now) */
    if (span - span == 0.0 && span > s->opt[CRT_OPT_HMAX])
      hs *= crt_max(1e-3, crt_min(0.9 * s->opt[CRT_OPT_HMAX] / span, 0.9));
    else
      hs *= (err > 1.0 && err - err == 0.0) ? crt_max(0.2, 0.9 * pow(err, -0.125)) : 0.25;
    if (hs * crt_max(f0[0], 1e-300) < 1e-14 * s->bs.body.t_scale) {
      s->status = CRT_STEP_UNDERFLOW;
      return;
    }
  }
  crt_base_slip_g(s, t_end, z1, N, cp, rho, g1);
  for (k_ = 0; k_ < CRT_BASE_NG; ++k_) {   /* located on the dense output */
    if (g0[k_] > 0.0 && g1[k_] <= 0.0) {
      double root;
      if (!dense) crt_base_dense(s, z0, z1, hs, k, F);
      dense = 1;
#define CRT_BASE_SLIP_EVAL(x) (crt_base_interp(z0, F, (x), zt), \
                               crt_base_slip_g_at(s, t_end, zt, k_, ft, gt))
      CRT_BASE_ILLINOIS(0.0, g0[k_], 1.0, g1[k_], root, 1e-15, CRT_BASE_SLIP_EVAL);
#undef CRT_BASE_SLIP_EVAL
      if (k_ == CRT_BASE_TIP || k_ == CRT_BASE_KERN) {   /* N there: a tip or the lift-off */
        crt_base_interp(z0, F, root, zt);
        if (crt_base_tie(&s->bs.body, crt_base_slip_g_at(s, t_end, zt, CRT_BASE_LIFT, ft, gt)))
          continue;                        /* (N's root: located, or the next step's) */
      }
      if (root < first) { first = root; which = k_; }
    }
  }
  {                                        /* the grid rows up to the step's end or event */
    double until = z1[0], shrink;
    long n;
    if (which >= 0) {
      crt_base_interp(z0, F, first, zt);
      until = zt[0];
    }
    n = crt_base_rows_before(s, until, o->cap);
    if (!crt_base_rows_fit(s, o, n, &shrink)) {
      s->bs.fsal = same;                   /* the step again: the same start and step */
      if (shrink < 1.0) s->bs.hs = hs * shrink;
      return;
    }
    if (n > 0 && !dense) crt_base_dense(s, z0, z1, hs, k, F);
    dense = 1;
    crt_base_rows(s, o, until, z0, F);
  }
  ++s->stat[CRT_STAT_STEPS];
  {                                        /* PI control (Hairer's beta = 0.04, as the
                                              flight's Lie steps, crt_loop_next_size) */
    const double beta = 0.04, alpha = 0.125 - 0.75 * beta;
    const double fac = 0.9 * pow(crt_max(err, 1e-10), -alpha) * pow(s->err_old, beta);
    s->bs.hs = hs * crt_min(6.0, crt_max(0.333, fac));
    if (cut && fac >= 1.0) s->bs.hs = crt_max(s->bs.hs, wanted);   /* (a knot's cut) */
    s->err_old = crt_max(err, 1e-4);
  }
  if (which < 0) {
    if (s->bs.line) s->bs.ht = s->bs.hs;
    s->bs.fsal = 1;
    for (i = 0; i < CRT_BASE_NZ; ++i) { s->bs.fz[i] = z1[i]; s->bs.ff[i] = f1[i]; }
    s->bs.fN = N; s->bs.fcp[0] = cp[0]; s->bs.fcp[1] = cp[1]; s->bs.frho = rho;
    s->t = z1[0];
    for (i = 0; i < NQ; ++i) s->q[i] = z1[1 + i];
    crt_changed(s);
    crt_base_step_row(s, o, t_end);
    return;
  }
  crt_base_interp(z0, F, first, zt);       /* the state there, its rate, N and cp */
  crt_base_zrhs(s, zt, ft, &N, cp, &rho);
  s->t = zt[0];
  for (i = 0; i < NQ; ++i) s->q[i] = zt[1 + i];
  crt_changed(s);
  if (which == CRT_BASE_END) {
    s->t = t_end;
    crt_emit(o, s->t, s->q, CRT_ROW_STEP);
  } else if (which == CRT_BASE_LIFT) {
    crt_base_end(s, o, CRT_LIFT_OFF, CRT_EV_LIFT_OFF, N);
  } else if (which == CRT_BASE_TIP) {
    crt_base_end(s, o, CRT_TIPPING, CRT_EV_TIPPING,
                 crt_face_edge_margin(&s->bs.body.face, cp[0], cp[1]));
  } else if (which == CRT_BASE_KERN) {
    crt_base_end(s, o, CRT_FACE_LIFTING, CRT_EV_FACE_LIFTING,
                 crt_face_kern_margin(&s->bs.body.face, cp[0], cp[1]));
  } else if (s->bs.line) {                 /* the stop of a slip along a line: xi = 0 */
    crt_emit(o, s->t, s->q, CRT_ROW_BEFORE_EVENT);
    for (i = 3; i < NQ; ++i) s->q[i] = 0.0;
    crt_changed(s);
    s->bs.mode = CRT_BASE_REST;
    crt_base_settle(s, o, 1);
    if (s->status == CRT_PAUSED && s->bs.mode == CRT_BASE_STICK)
      crt_emit(o, s->t, s->q, CRT_ROW_AFTER_EVENT);
  } else {                                 /* the stop: the linear decay's last part */
    const double rate = ft[0] > 0.0
        ? (s->q[3] * ft[4] + s->q[4] * ft[5] + s->bs.body.ell * s->bs.body.ell * s->q[5]
           * ft[6]) / (ft[0] * rho) : 0.0;       /* (dq/dt = ft[1..]/rho) . xi / rho */
    const double dt = rate < 0.0 ? -rho / rate : 0.0;
    crt_emit(o, s->t, s->q, CRT_ROW_BEFORE_EVENT);
    for (i = 0; i < 3; ++i) {
      s->q[i] += 0.5 * dt * s->q[3 + i];
      s->q[3 + i] = 0.0;
    }
    s->t += dt;
    crt_changed(s);
    s->bs.mode = CRT_BASE_REST;
    crt_base_settle(s, o, 1);
    if (s->status == CRT_PAUSED && s->bs.mode == CRT_BASE_STICK)
      crt_emit(o, s->t, s->q, CRT_ROW_AFTER_EVENT);
  }
}

/* crt_advance's loop for the base model */
static void crt_integrate(crt_session *s, double t_end, crt_out *o)
{
  if (s->ctl) {                            /* the closed loop is not run on a face */
    (void)crt_control_at_stop;
    (void)crt_control_after_event;
    (void)crt_control_counters;
    (void)crt_control_next_stop;
    (void)model_normalize;                 /* (no attitude: nothing to keep orthonormal) */
    s->status = CRT_BAD_CONTROL;
    return;
  }
  if (!s->rows_started) {                  /* the initial row; the grid's first after it */
    crt_emit(o, s->t, s->q, CRT_ROW_STEP);
    s->rows_started = 1;
    s->out_k = s->out_origin > s->t ? 0.0 : 1.0;
    s->next_output = s->out_origin + s->out_k * s->opt[CRT_OPT_OUTPUT_DT];
  }
  s->bs.full = 0;
  s->bs.t_end = t_end;
  while (s->t < t_end && s->status == CRT_PAUSED && !s->bs.full) {
    if (o->n + CRT_MIN_ROWS > o->cap || o->ev_n + CRT_MIN_EVENTS > o->ev_cap) return;
    if ((double)s->stat[CRT_STAT_STEPS] >= s->opt[CRT_OPT_MAX_STEPS]) {
      s->status = CRT_MAX_STEPS;
      return;
    }
    if (crt_events_exhausted(s)) return;
    if (s->bs.mode == CRT_BASE_REST) crt_base_settle(s, o, 0);
    else if (s->bs.mode == CRT_BASE_STICK || s->bs.mode == CRT_BASE_TRANSLATION)
      crt_base_sample_step(s, o, t_end);
    else if (s->bs.tr_try) crt_base_tr_start(s);
    else crt_base_slip_step(s, o, t_end);
    if (!crt_finite(s->q)) s->status = CRT_NONFINITE;
  }
  if (s->status == CRT_PAUSED && s->t >= t_end) s->status = CRT_DONE;
}

#endif /* CRT_BASE_H */
