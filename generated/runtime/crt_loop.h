/*
 * crt_loop.h: the loop of crt_advance (crt_integrate).
 *
 * Hand-written C: this file is templates/runtime/crt_loop.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * Each pass: room for a step's rows (crt_loop_room); an event due at the start of the step,
 * applied (a contact's transition, crt_contact_due; a collision in flight,
 * crt_events_collide_now); the step's size (the control's, the method's limit, a table's
 * knots, the loop's stops, t_end); the step (crt_step), kept or refused (crt_loop_refused);
 * the first event in it, located and applied (crt_events_in_step), or else the step
 * accepted: the session at its end, in contact S put back on the plane
 * (crt_events_after_step), its rows; the loop's stop acted on; the next step's size
 * (crt_loop_next_size).  Before and after the loop, crt_loop_begin and crt_loop_end.  The
 * stages are reached through their hooks (crt_contact.h; crt_events.h, no-ops without the
 * plane; crt_step.h; crt_control.h).
 *
 * The loop's statements are where they are for a reason beyond reading: the runtime is
 * compiled with -O3 -ffp-contract=fast, and which products GCC fuses into multiply-adds
 * in the code inlined here (the Lie methods' attitude at the end of a step, R^T K) follows
 * this function's whole shape.  Moving a block into a helper or out of one changed the
 * last bit of some runs; this arrangement keeps every run of the runtime as it was, bit
 * for bit.  Check a change with a step-by-step comparison of sessions before and after.
 */
#ifndef CRT_LOOP_H
#define CRT_LOOP_H

#include "crt_events.h"
#include "crt_control.h"

/* What a named step of the loop leads to: go on with this pass, start the next pass, or
   leave the loop (s->status says why; or a buffer is full) */
enum crt_next { CRT_NEXT_GO = 0, CRT_NEXT_PASS = 1, CRT_NEXT_STOP = 2 };

/* crt_advance's start: the initial row (on the first call), the controller's first call
   (at t0), the output rows of the last step that the last call had no room for.  0 when
   the call ends there. */
static int crt_loop_begin(crt_session *s, crt_out *o, double t_end)
{
  const double out_dt = s->opt[CRT_OPT_OUTPUT_DT];
  if (!s->rows_started) {                  /* the initial row; the grid's first after it */
    crt_emit(o, s->t, s->q, CRT_ROW_STEP);
    s->rows_started = 1;
    s->out_k = s->out_origin > s->t ? 0.0 : 1.0;
    s->next_output = out_dt > 0.0 ? s->out_origin + s->out_k * out_dt : s->t;
  }
  if (s->ctl && !s->ctl->started) {        /* the loop's first call, at t0 */
    const int stop = crt_control_call(s, CRT_CALL_START, 0);
    s->ctl->started = 1;
    if (stop) { s->status = stop; return 0; }
  }
  if (s->out_pending && !crt_flush_outputs(s, o, s->out_until, s->out_until >= t_end)) {
    return 0;
  }
  return 1;
}

/* room for a step's rows and events and for the controller's log, and steps left (else
   status CRT_MAX_STEPS): 1, else 0 */
static int crt_loop_room(crt_session *s, const crt_out *o)
{
  if (o->n + CRT_MIN_ROWS > o->cap || o->ev_n + CRT_MIN_EVENTS > o->ev_cap) return 0;
  if (s->ctl && s->ctl->log_n + CRT_CTL_MAX_KNOTS > s->ctl->log_cap) return 0;
  if ((double)s->stat[CRT_STAT_STEPS] >= s->opt[CRT_OPT_MAX_STEPS]) {
    s->status = CRT_MAX_STEPS;
    return 0;
  }
  return 1;
}

/* crt_advance's end: the controller's law in use logged; CRT_DONE at t_end, with the
   final state as a row (the output_dt grid need not land on t_end) */
static void crt_loop_end(crt_session *s, crt_out *o, double t_end)
{
  const double out_dt = s->opt[CRT_OPT_OUTPUT_DT];
  if (s->ctl && s->status != CRT_PAUSED) crt_control_log_law(s->ctl, s->t);
  if (s->status == CRT_PAUSED && s->t >= t_end && !s->out_pending) {
    s->status = CRT_DONE;
    if (s->ctl) crt_control_log_law(s->ctl, s->t);
    if (out_dt > 0.0 && (o->n == 0 || o->t[o->n - 1] < s->t))
      crt_emit(o, s->t, s->q, CRT_ROW_STEP);
  }
}

/* the next step's size after the accepted step h (h_wanted before knots and stops cut
   it; err its error norm) */
static void crt_loop_next_size(crt_session *s, double h, double h_wanted, double err,
                               int adaptive, int order)
{
  if (!adaptive) {
    /* RK4: back to the nominal step after a hop or a retry shortened it */
    s->h = crt_min(2.0 * s->h, s->opt[CRT_OPT_RK4_STEP]);
  } else {
    /* PI step-size control (Hairer's beta = 0.04 for DOPRI5 and for the Lie methods:
       with the attitude alone integrated, the 8th-order estimate can swing by an order
       of magnitude from step to step, and the PI term damps the rejections it causes) */
    const double beta = (order == 5 || crt_lie_active(s)) ? 0.04 : 0.0;
    const double alpha = 1.0 / order - 0.75 * beta;
    double fac = 0.9 * pow(crt_max(err, 1e-10), -alpha) * pow(s->err_old, beta);
    fac = crt_min(crt_max(fac, 0.2), 10.0);
    s->err_old = crt_max(err, 1e-4);
    s->h = h * fac;
    /* a step cut short by a knot says nothing against the step wanted */
    if (h < h_wanted && fac >= 1.0) s->h = crt_max(s->h, h_wanted);
  }
}

/* The step of h just taken (crt_step: y1, f1, its error norm err) refused, or not: not
   finite (retried a quarter as long, or status CRT_NONFINITE at the least step), or its
   error above 1 (retried shorter: s->h, or status CRT_STEP_UNDERFLOW).  CRT_NEXT_GO when
   it stands, CRT_NEXT_PASS when it is retried, CRT_NEXT_STOP. */
static enum crt_next crt_loop_refused(crt_session *s, double h, double h_min, int adaptive,
                                      int order, const double *y1, const double *f1,
                                      double err)
{
  if (!crt_finite(y1) || !crt_finite(f1)) {
    if (h > h_min) { s->h = 0.25 * h; ++s->stat[CRT_STAT_REJECTED]; return CRT_NEXT_PASS; }
    s->status = CRT_NONFINITE;
    return CRT_NEXT_STOP;
  }
  if (adaptive && err > 1.0) {
    const double fac = crt_max(0.2, 0.9 * pow(err, -1.0 / order));
    s->h = h * fac;
    ++s->stat[CRT_STAT_REJECTED];
    if (s->h < h_min) { s->status = CRT_STEP_UNDERFLOW; return CRT_NEXT_STOP; }
    return CRT_NEXT_PASS;
  }
  return CRT_NEXT_GO;
}

/* the controller of a closed loop told of the event just applied (before: the counters
   before it): 1, or 0 when it stops the run */
static int crt_loop_tell(crt_session *s, const long *before)
{
  if (s->ctl) {
    const int halt = crt_control_after_event(s, before);
    if (halt) { s->status = halt; return 0; }
  }
  return 1;
}

/* crt_advance's work, its arguments checked: steps until t_end, a stop, an error or a
   full buffer; the code in s->status */
static void crt_integrate(crt_session *s, double t_end, crt_out *o)
{
  double y1[NQ], f1[NQ];
  const double scale = s->opt[CRT_OPT_TIME_SCALE];
  const double h_min = 1e-14 * crt_max(scale, fabs(s->t));
  const double out_dt = s->opt[CRT_OPT_OUTPUT_DT];
  const int adaptive = (int)s->opt[CRT_OPT_METHOD] != CRT_RK4;
  const int order = crt_order(s);
  if (!crt_loop_begin(s, o, t_end)) return;
  while (s->t < t_end) {
    double h, h_wanted, knot, err, t1, stop = HUGE_VAL;
    enum crt_next next;
    if (!crt_loop_room(s, o)) break;
    if (s->plane && s->phase == CRT_CONTACT) {
      /* in contact, a transition due now: its event value already not positive */
      const int due = crt_contact_due(s, o);
      if (due != CRT_DUE_NONE) {
        if (crt_events_exhausted(s)) break;
        if (s->ctl && due == CRT_DUE_TELL) {
          const int halt = crt_control_call(s, CRT_CALL_EVENT, CRT_EV_LIFT_OFF);
          if (halt) { s->status = halt; break; }
        }
        continue;
      }
    }
    if (s->plane && s->phase == CRT_FLIGHT) {     /* in flight, S down onto the plane now */
      long before[3];
      crt_control_counters(s, before);
      if (crt_events_collide_now(s, o)) {
        if (crt_events_exhausted(s) || !crt_loop_tell(s, before)) break;
        continue;
      }
    }
    if (!s->f_valid && !crt_lie_active(s)) { crt_rhs(s, s->t, s->q, s->f); s->f_valid = 1; }
    /* the step's size */
    h = crt_min(crt_min(s->h, s->opt[CRT_OPT_HMAX]), crt_step_limit(s));
    h_wanted = h;
    knot = crt_law_next_knot(&s->law, s->t);     /* steps end on a table's knots */
    if (s->t + h > knot) h = knot - s->t;
    if (s->ctl) {                                /* and on the loop's samples and pushes */
      stop = crt_control_next_stop(s);
      if (stop < s->t + h_min) {                 /* due now (a push at an event's time) */
        const int halt = crt_control_at_stop(s, o, s->t + h_min);
        if (halt) { s->status = halt; break; }
        continue;
      }
      /* a knot a rounding error before the stop is the stop: no step of 1e-16 s */
      if (s->t + h >= stop || stop - (s->t + h) < h_min) h = stop - s->t;
    }
    if (s->t + h > t_end) h = t_end - s->t;
    if (h < h_min && s->t + h < t_end) { s->status = CRT_STEP_UNDERFLOW; break; }
    err = crt_step(s, s->t, s->q, s->f, h, y1, f1, 1);   /* the step */
    next = crt_loop_refused(s, h, h_min, adaptive, order, y1, f1, err);
    if (next != CRT_NEXT_GO) { if (next == CRT_NEXT_STOP) break; continue; }
    t1 = s->t + h;
    {
      long before[3];
      int found;
      crt_control_counters(s, before);
      found = crt_events_in_step(s, o, t1, y1);  /* the first event in the step */
      if (found == CRT_STEP_EVENT) {
        if (!crt_loop_tell(s, before)) break;
        continue;
      }
      if (found == CRT_STEP_STOP) break;
      if (found == CRT_STEP_RETRY) {
        ++s->stat[CRT_STAT_REJECTED];
        if (0.25 * h < h_min) { s->status = CRT_PENETRATION; break; }
        s->h = 0.25 * h;
        continue;
      }
    }
    /* no event: the step accepted */
    ++s->stat[CRT_STAT_STEPS];
    if (h == stop - s->t) t1 = stop;             /* exactly at the loop's stop */
    {
      int i;
      s->t = t1;
      for (i = 0; i < NQ; ++i) { s->q[i] = y1[i]; s->f[i] = f1[i]; }
    }
    s->f_valid = 1;
    if (crt_lie_active(s)) crt_lie_accept(s);   /* on SO(3) already: no projection */
    else if (s->opt[CRT_OPT_ORTHONORMAL] != 0.0) {
      model_normalize(s->q);
      crt_changed(s);
      s->g_valid = 0;
    }
    if (!crt_events_after_step(s)) break;       /* in contact: S back on the plane */
    if (out_dt <= 0.0) crt_emit(o, s->t, s->q, CRT_ROW_STEP);
    else if (!crt_flush_outputs(s, o, s->t, s->t >= t_end)) {
      /* the rest on the next call */
    }
    if (s->ctl && s->t >= stop) {                /* a sample, a push: the loop acts */
      const int halt = crt_control_at_stop(s, o, s->t + h_min);
      if (halt) { s->status = halt; break; }
    }
    crt_loop_next_size(s, h, h_wanted, err, adaptive, order);
    if (s->out_pending) break;
  }
  crt_loop_end(s, o, t_end);
}

#endif /* CRT_LOOP_H */
