/*
 * crt_events.h: events -- where in a step S reaches the plane or the contact's event
 * function reaches zero (crt_search, crt_root on the dense output), and what happens there
 * (crt_collide in flight: impact, entry into contact or graze; the contact's transition in
 * contact), with the loop's hooks crt_events_due, crt_events_in_step and
 * crt_events_after_step, which a model without the plane has as no-ops.
 *
 * Hand-written C: this file is templates/runtime/crt_events.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_EVENTS_H
#define CRT_EVENTS_H

#include "crt_step.h"

#define CRT_MAX_SUB 32                    /* sub-intervals of the event search per step */

/* What the event search found in a step (crt_search), and what crt_events_in_step did:
   no event (accept the step), an event applied, a retry of a shorter step, or a stop (an
   event exhausted the run's budget or was refused, or no room for its rows) */
enum { CRT_STEP_CLEAR = 0, CRT_STEP_EVENT = 1, CRT_STEP_RETRY = 2, CRT_STEP_STOP = 3 };

#if MODEL_HAS_PLANE
/* the value of the event function: the gap in flight (and its rate), in contact the
   contact's (its reaction N, or the rough contact's transitions) */
static double crt_event_value(crt_session *s, double t, const double *y, double *deriv)
{
  if (s->phase == CRT_FLIGHT) {
    double h;
    crt_gap(s, t, y, &h, deriv);
    return h;
  }
  return crt_contact_event_value(s, t, y, deriv);
}

static double crt_event_value_dense(crt_session *s, double t, double *deriv)
{
  double y[NQ];
  crt_dense_at(s, t, y);
  return crt_event_value(s, t, y, deriv);
}

/* bracketing root finder (Anderson-Bjorck variant of regula falsi) on [a, b] with
   g(a) > 0 >= g(b), on the dense output; returns a time within tol of the root, on the
   g <= 0 side */
static double crt_root(crt_session *s, double a, double ga, double b, double gb, double tol)
{
  double dummy;
  int side = 0, it, repeats = 0;
  for (it = 0; it < 200 && b - a > tol; ++it) {
    double c = (a * gb - b * ga) / (gb - ga);
    double gc;
    if (!(c > a && c < b)) c = 0.5 * (a + b);
    /* a kinked event function (the least of values of other scales: the rough contact
       with couples) can stall the secant on one side: there every third point is the
       middle */
    if (crt_contact_kinked(s) && repeats >= 2) c = 0.5 * (a + b);
    if (c - a < 0.25 * tol) c = a + 0.5 * tol;
    if (b - c < 0.25 * tol) c = b - 0.5 * tol;
    gc = crt_event_value_dense(s, c, &dummy);
    if (gc > 0.0) {
      if (side == 1) { const double m = 1.0 - gc / ga; gb *= m > 0.0 ? m : 0.5; }
      repeats = side == 1 ? repeats + 1 : 0;
      a = c; ga = gc; side = 1;
    } else {
      if (side == -1) { const double m = 1.0 - gc / gb; ga *= m > 0.0 ? m : 0.5; }
      repeats = side == -1 ? repeats + 1 : 0;
      b = c; gb = gc; side = -1;
    }
  }
  return b;
}

/* The first time in (t0, t1] of the current step where the event function becomes
   non-positive: in flight the first downward crossing of the plane by S, in contact the
   first zero of N.  The step is cut into sub-intervals (more when the body turns fast);
   where the cubic through the values and rates at the ends of a sub-interval dips below
   zero it is subdivided again (depth 3), so two roots in one step are not missed.
   In flight the search is armed once S has been seen above the plane (after an impact,
   a graze or a lift-off it starts on the plane).  Returns CRT_STEP_EVENT with a bracket,
   CRT_STEP_RETRY when the step ends too far below the plane with no crossing found (a hop
   shorter than a sub-interval: retry a shorter step), or CRT_STEP_CLEAR. */
static int crt_search(crt_session *s, double t1, const double *y1, double rate,
                      double *ta, double *ga_out, double *tb, double *gb_out)
{
  double sa[CRT_MAX_SUB + 4], sga[CRT_MAX_SUB + 4], sda[CRT_MAX_SUB + 4];
  double sb[CRT_MAX_SUB + 4], sgb[CRT_MAX_SUB + 4], sdb[CRT_MAX_SUB + 4];
  int sdep[CRT_MAX_SUB + 4];
  double ts[CRT_MAX_SUB + 1], gs[CRT_MAX_SUB + 1], ds[CRT_MAX_SUB + 1];
  const double t0 = s->t, L = t1 - t0;
  const int flight = s->phase == CRT_FLIGHT;
  const double h_pen = flight ? crt_penetration_tolerance(s, y1) : 0.0;
  /* interior samples come from the dense output, whose error is of the tolerance's
     order: only the step's end (the method's own solution) is held to h_pen */
  const double h_dense = flight ? crt_max(h_pen, crt_height_resolution(s, y1)) : 0.0;
  int top = 0, k, sub, armed;
  double g0 = s->g_start, d0 = s->d_start;
  if (!s->g_valid) g0 = crt_event_value(s, t0, s->q, &d0);
  /* the end of the step is the method's own solution */
  gs[0] = g0; ds[0] = d0; ts[0] = t0;
  {
    double g1, d1;
    g1 = crt_event_value(s, t1, y1, &d1);
    s->g_start = g1; s->d_start = d1; s->g_valid = 1;
    if (flight && s->stat[CRT_STAT_LAW_CHANGES] == 0) {
      /* far from the plane: in flight Z_C'' = -g (E1.2), so Z_C is concave and above
         the lower of its ends over the whole step, and h = Z_C + n.CS with |n.CS| at
         most L_S (a margin of 1e-3 L_S for the sampled reach of the law): h cannot
         reach zero inside the step.  L_S bounds the scene's own law only: once a
         controller has set another (crt_control.h), which may reach further, every
         step is sampled (a per-hop controller's wider gait had let S pass 2.6 mm
         below the plane inside a step, the impact found only at its end) */
      const double low = crt_min(s->q[MODEL_Z], y1[MODEL_Z]);
      if (low > 1.001 * s->opt[CRT_OPT_LENGTH_SCALE]) return CRT_STEP_CLEAR;
    }
    sub = 4;
    if (flight && rate * L > 1.6) sub = (int)crt_min(CRT_MAX_SUB, ceil(rate * L / 0.4));
    ts[sub] = t1; gs[sub] = g1; ds[sub] = d1;
  }
  for (k = 1; k < sub; ++k) {
    ts[k] = t0 + L * (double)k / sub;
    gs[k] = crt_event_value_dense(s, ts[k], &ds[k]);
  }
  armed = !flight || g0 > 0.0;
  for (k = 0; k < sub; ++k) {
    if (!armed) {
      /* leaving the plane: arm once S is seen above it; a sample far below it means
         S came back within the sub-interval */
      if (gs[k + 1] > 0.0) { armed = 1; continue; }
      if (k + 1 < sub && gs[k + 1] < -h_dense) return CRT_STEP_RETRY;
      if (k + 1 == sub && gs[k + 1] < -h_pen) return CRT_STEP_RETRY;
      continue;
    }
    sa[top] = ts[k]; sga[top] = gs[k]; sda[top] = ds[k];
    sb[top] = ts[k + 1]; sgb[top] = gs[k + 1]; sdb[top] = ds[k + 1];
    sdep[top] = 0; ++top;
    if (flight && k > 0) crt_track_height(s, ts[k], gs[k]);   /* before any event */
    /* examine this sub-interval (and its subdivisions) before the next one */
    while (top > 0) {
      double A, GA, DA, B, GB, DB;
      int dep;
      --top;
      A = sa[top]; GA = sga[top]; DA = sda[top];
      B = sb[top]; GB = sgb[top]; DB = sdb[top]; dep = sdep[top];
      if (GA > 0.0 && GB <= 0.0) {
        *ta = A; *ga_out = GA; *tb = B; *gb_out = GB;
        return CRT_STEP_EVENT;
      }
      if (flight && GA > 0.0 && GB > 0.0 && DA < 0.0 && DB > 0.0 && dep < 3) {
        /* minimum of the cubic Hermite interpolant of (h, h') on [A, B] */
        const double W = B - A;
        double best = GA < GB ? GA : GB;
        int j;
        for (j = 1; j < 8; ++j) {
          const double u = (double)j / 8.0, u2 = u * u, u3 = u2 * u;
          const double p = (2 * u3 - 3 * u2 + 1) * GA + (u3 - 2 * u2 + u) * W * DA
                           + (-2 * u3 + 3 * u2) * GB + (u3 - u2) * W * DB;
          if (p < best) best = p;
        }
        if (best < 0.25 * (GA < GB ? GA : GB) && top + 4 <= CRT_MAX_SUB + 4) {
          double tt[5], gg[5], dd[5];
          int m;
          tt[0] = A; gg[0] = GA; dd[0] = DA;
          tt[4] = B; gg[4] = GB; dd[4] = DB;
          for (m = 1; m < 4; ++m) {
            tt[m] = A + W * (double)m / 4.0;
            gg[m] = crt_event_value_dense(s, tt[m], &dd[m]);
          }
          for (m = 3; m >= 0; --m) {
            sa[top] = tt[m]; sga[top] = gg[m]; sda[top] = dd[m];
            sb[top] = tt[m + 1]; sgb[top] = gg[m + 1]; sdb[top] = dd[m + 1];
            sdep[top] = dep + 1; ++top;
          }
        }
      }
    }
  }
  if (flight && gs[sub] < -h_pen) return CRT_STEP_RETRY;
  return CRT_STEP_CLEAR;
}

/* S touches the plane at (t, q) in flight.  S is put exactly on the plane (the row
   "before_event" shows that state), then: the impact map if S approaches faster than
   the resolution (then, if impacts accumulate, persistent contact); resting contact if
   S is pressed onto the plane and leaves too slowly to be resolved; a graze otherwise.
   A face coming down flat, its corners (a disc's rim) within the height resolution of
   each other (model_face_spread), is no one-point impact: every corner touches at once,
   a multi-point impact no model makes (its S, the support point of a face, is the face's
   centre by convention only).  There the run stops, status CRT_FLAT_LANDING, with an
   event flat_landing (value: the spread, v_n- the v_n it lands with, v_n+ NaN: no impact
   applied) and no row after it: the rule the driver had applied to a base run's flight
   alone (derive/docs/bodies.md, "Landing flat"). */
static void crt_collide(crt_session *s, crt_out *o, double t, const double *q)
{
  double gap, v_n, N, a_free, h_res;
  int i;
  for (i = 0; i < NQ; ++i) s->q[i] = q[i];
  crt_project(s, t, s->q, 0);
  crt_gap(s, t, s->q, &gap, &v_n);
  crt_contact_state(s, t, s->q, &N, &a_free);
  crt_track_height(s, t, 0.0);
  crt_emit(o, t, s->q, CRT_ROW_BEFORE_EVENT);
  s->last_event_t = t;
  h_res = crt_height_resolution(s, s->q);
  if (v_n < -crt_speed_noise(s, t, s->q)) {
    double q_plus[NQ], v_plus;
    const double spread = model_face_spread(s->prm, crt_u(s, t), s->q);
    if (spread <= h_res) {
      crt_event(o, t, CRT_EV_FLAT_LANDING, spread, v_n, NAN, 0.0);
      s->status = CRT_FLAT_LANDING;
      return;
    }
    if (!crt_contact_impact(s, o, t, v_n, q_plus, &v_plus)) return;   /* refused */
    ++s->stat[CRT_STAT_IMPACTS];
    for (i = 0; i < NQ; ++i) s->q[i] = q_plus[i];
    crt_contact_state(s, t, s->q, &N, &a_free);
    if (a_free < 0.0) {
      /* pressed onto the plane: the next hop lasts 2 v+/|a| and rises v+^2/(2|a|); the
         hops shrink by the ratio r of successive flights (e for a constant a), so the
         remaining flights sum to tau/(1 - r) */
      const double vp = crt_max(v_plus, 0.0);
      const double tau = 2.0 * vp / -a_free;
      const double apex = vp * vp / (2.0 * -a_free);
      const double since = t - s->last_impact_t;
      double ratio = s->prm[CRT_P_e], remaining;
      if (s->last_flight > 0.0 && since > 0.0) ratio = tau / since;
      remaining = ratio < 1.0 ? tau / (1.0 - ratio) : HUGE_VAL;
      if (apex <= h_res || remaining <= s->opt[CRT_OPT_ZENO_DT] * s->opt[CRT_OPT_TIME_SCALE]) {
        crt_contact_enter(s, o, t, v_plus, t + (remaining < HUGE_VAL ? remaining : 0.0));
      } else if (s->h > 0.25 * tau) {
        s->h = 0.25 * tau;       /* a hop shorter than the step: resolve it */
      }
      s->last_flight = since > 0.0 ? since : 0.0;
    } else {
      s->last_flight = 0.0;
    }
    s->last_impact_t = t;
    return;
  }
  /* touching: resting if pressed and leaving too slowly to rise above h_res */
  if (a_free < 0.0 && v_n * v_n <= 2.0 * -a_free * h_res) {
    crt_contact_enter(s, o, t, v_n, t);
    return;
  }
  crt_event(o, t, CRT_EV_GRAZE, 0.0, v_n, v_n, 0.0);
  ++s->stat[CRT_STAT_GRAZES];
  if (a_free < 0.0 && v_n > 0.0 && s->h > 0.5 * v_n / -a_free)
    s->h = 0.5 * v_n / -a_free;              /* a quarter of the hop that follows */
}

/* the last Newton correction of an event's time is a Taylor step when below this times
   sqrt(rtol) of the re-step (crt_handle_event) */
#define CRT_TAYLOR_DT 1e-3

/* What crt_handle_event did. */
enum crt_handled {
  CRT_HANDLED_GO_ON = 0,        /* the event applied: take the next step */
  CRT_HANDLED_STOP = 1,         /* the event applied and the run stops (max_events) */
  CRT_HANDLED_BUFFER_FULL = 2   /* no room for the event's rows: nothing changed, the step
                                   is redone on the next call */
};

/* Locate the event in [ta, tb], move the session there and apply it: an impact, a graze
   or an entry into contact in flight (crt_collide), a lift-off in contact. */
static enum crt_handled crt_handle_event(crt_session *s, crt_out *o, double ta, double ga,
                                         double tb, double gb)
{
  const double tol = s->opt[CRT_OPT_EVENT_TOL] * crt_max(s->opt[CRT_OPT_TIME_SCALE], fabs(tb));
  double t_ev;
  if (s->dense.pending) crt_dense_complete(s);   /* before a re-step reuses the stages */
  t_ev = crt_root(s, ta, ga, tb, gb, tol);
  double q_ev[NQ], f_ev[NQ], gap, v_n;
  int it;
  /* re-step from the start of the step to the event: the state there carries the
     method's own error, not the interpolant's; then Newton on the gap */
  for (it = 0; it < 4; ++it) {
    crt_step(s, s->t, s->q, s->f, t_ev - s->t, q_ev, f_ev, 0);
    if (s->phase != CRT_FLIGHT) break;
    crt_gap(s, t_ev, q_ev, &gap, &v_n);
    if (!(v_n < 0.0)) break;
    {
      const double dt = -gap / v_n;
      if (fabs(dt) <= 4.0 * tol || !(t_ev + dt > s->t) || fabs(dt) > (tb - ta) + tol) break;
      if (fabs(dt) <= CRT_TAYLOR_DT * sqrt(crt_kept_rtol(s)) * (t_ev - s->t)) {
        /* a correction this small (the interpolant's root against the method's own: a
           few 1e-11 s) by a Taylor step of first order from the re-step's end, whose
           remainder dt^2 q''/2 is below 1e-6 rtol of the step's own change (RK4: of
           round-off, crt_kept_rtol), instead of a second whole step of the method */
        double dq[NQ];
        int i;
        crt_rhs(s, t_ev, q_ev, dq);
        for (i = 0; i < NQ; ++i) q_ev[i] += dt * dq[i];
        t_ev += dt;
        break;
      }
      t_ev += dt;
      /* the last correction: step there too, so that the state is the one at t_ev */
      if (it == 3) crt_step(s, s->t, s->q, s->f, t_ev - s->t, q_ev, f_ev, 0);
    }
  }
  if (!crt_flush_outputs(s, o, t_ev, 0)) return CRT_HANDLED_BUFFER_FULL;
  if (o->n + 3 > o->cap || o->ev_n + 3 > o->ev_cap) return CRT_HANDLED_BUFFER_FULL;
  ++s->stat[CRT_STAT_STEPS];
  if (s->phase == CRT_FLIGHT) {
    crt_collide(s, o, t_ev, q_ev);
    if (s->status != CRT_FLAT_LANDING) crt_emit(o, t_ev, s->q, CRT_ROW_AFTER_EVENT);
    crt_changed(s);
    s->g_valid = 0;
  } else {
    for (it = 0; it < NQ; ++it) s->q[it] = q_ev[it];
    crt_contact_transition(s, o, t_ev);   /* lift-off; the rough contact's stick, slip, ... */
  }
  s->t = t_ev;
  return crt_events_exhausted(s) ? CRT_HANDLED_STOP : CRT_HANDLED_GO_ON;
}

/* ---- the loop's hooks ---------------------------------------------------------------- */
/* At s->t, before a step, in flight: S on (or, after round-off, just below) the plane and
   moving down collides now (once: not again at the time of the event that put it there).
   1 if it did (crt_collide: an impact, an entry into contact or a graze), else 0. */
static int crt_events_collide_now(crt_session *s, crt_out *o)
{
  double g0 = s->g_start, d0 = s->d_start;
  int now;
  if (!s->g_valid) {
    crt_gap(s, s->t, s->q, &g0, &d0);
    s->g_start = g0; s->d_start = d0; s->g_valid = 1;
  }
  now = g0 <= 0.0 && d0 < 0.0;
  if (!now && s->opt[CRT_OPT_START_ON_PLANE] != 0.0 && s->stat[CRT_STAT_STEPS] == 0
      && s->last_event_t == -HUGE_VAL && g0 <= crt_height_resolution(s, s->q)) {
    /* S put on the plane at the start ([initial].on_plane): pressed onto it and not
       leaving faster than round-off, the run begins in contact (crt_collide's touching
       branch: no impact, nothing approached), where it had fallen by round-off for a
       microsecond and hit the plane at g t */
    double N, a_free;
    crt_contact_state(s, s->t, s->q, &N, &a_free);
    now = a_free < 0.0 && d0 <= crt_speed_noise(s, s->t, s->q);
  }
  if (now && s->t != s->last_event_t) {
    double q_now[NQ];
    int i;
    for (i = 0; i < NQ; ++i) q_now[i] = s->q[i];
    crt_collide(s, o, s->t, q_now);
    if (s->status != CRT_FLAT_LANDING) crt_emit(o, s->t, s->q, CRT_ROW_AFTER_EVENT);
    crt_changed(s);
    s->g_valid = 0;
    return 1;
  }
  return 0;
}

/* After a step tried from s->t to t1 (y1 its end): the first event in it, located and
   applied (the session is then at the event).  CRT_STEP_CLEAR (no event: accept the
   step), CRT_STEP_EVENT, CRT_STEP_RETRY (the step ends too far below the plane: retry a
   shorter one) or CRT_STEP_STOP. */
static int crt_events_in_step(crt_session *s, crt_out *o, double t1, const double *y1)
{
  double ta = 0.0, tb = 0.0, ga = 0.0, gb = 0.0;
  enum crt_handled handled;
  int found;
  if (!s->plane) return CRT_STEP_CLEAR;
  found = crt_search(s, t1, y1, model_rate(s->prm, crt_u(s, t1), y1), &ta, &ga, &tb, &gb);
  if (found == CRT_STEP_RETRY) {
    s->g_valid = 0;
    return CRT_STEP_RETRY;
  }
  if (found != CRT_STEP_EVENT) {
    if (s->phase == CRT_FLIGHT) crt_track_height(s, t1, s->g_start);
    return CRT_STEP_CLEAR;
  }
  handled = crt_handle_event(s, o, ta, ga, tb, gb);
  if (handled == CRT_HANDLED_BUFFER_FULL) { s->g_valid = 0; return CRT_STEP_STOP; }
  if (handled == CRT_HANDLED_STOP) return CRT_STEP_STOP;
  return CRT_STEP_EVENT;
}

/* After an accepted step in contact: a surface that is not strictly convex checked for a
   jump of S (status CRT_SURFACE_JUMP), S put back on the plane, the contact's bookkeeping
   (crt_contact_after_step).  0 when the run stops. */
static int crt_events_after_step(crt_session *s)
{
  int ok;
  if (s->phase != CRT_CONTACT) return 1;
  if (model_surface_may_jump(s->prm) && crt_surface_jumped(s, s->t, s->q)) {
    s->status = CRT_SURFACE_JUMP;
    return 0;
  }
  crt_project(s, s->t, s->q, 1);
  ok = crt_contact_after_step(s);
  crt_changed(s);
  s->g_valid = 0;
  return ok;
}
#else
/* ---- no plane: no events ---------------------------------------------------------------- */
static int crt_events_collide_now(crt_session *s, crt_out *o)
{
  (void)s; (void)o;
  return 0;
}

static int crt_events_in_step(crt_session *s, crt_out *o, double t1, const double *y1)
{
  (void)s; (void)o; (void)t1; (void)y1;
  return CRT_STEP_CLEAR;
}

static int crt_events_after_step(crt_session *s)
{
  (void)s;
  return 1;
}
#endif /* MODEL_HAS_PLANE */

#endif /* CRT_EVENTS_H */
