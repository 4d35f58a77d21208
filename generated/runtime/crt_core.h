/*
 * crt_core.h: the event-driven runtime -- sessions, event location, impacts, persistent
 * contact, lift-off, output and the public API.  Included at the end of each model's file
 * (model_<kind>.c: with the headers it includes, the runtime's one translation unit).
 *
 * Hand-written C: this file is templates/runtime/crt_core.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.  The comments of this header are the
 * runtime's manual; the names of options, parameters, counters and return codes are in
 * crt_abi.h, rendered from derive/abi.py.
 *
 * ---- Use -----------------------------------------------------------------------------
 * A session lives in the caller's memory (crt_sizeof() bytes, aligned for a double);
 * nothing is allocated and nothing is global, so sessions are independent.  A run:
 *   crt_set_law_program or crt_set_law_table   the point law (kept for later runs;
 *                                              crt_set_law_bodies: several bodies' laws,
 *                                              evaluated but not yet run)
 *   crt_init(s, opt, prm, t0, q0)              options, parameters, the initial state
 *   crt_advance(s, t_end, rows, events)        again while it returns CRT_PAUSED
 *   crt_stats, crt_summary, crt_state, crt_time, crt_phase   what the run did
 * or crt_run (crt_init and crt_advance in one call), or crt_run_many (many runs of one
 * law in one call).  Each function below documents its inputs.
 *
 * ---- Return codes (enum crt_status in crt_abi.h; crt_status_name gives the name) ------
 * As in SUNDIALS' CVODE: zero is success, positive codes are stops that are not errors,
 * negative codes are errors.
 *   CRT_OK               0  crt_set_law_*: the law is accepted; crt_init: ready to advance
 *   CRT_PAUSED           1  crt_advance: an output buffer is full; read it, call again
 *   CRT_DONE             2  crt_advance: t_end reached
 *   CRT_MAX_EVENTS       3  crt_advance: opt[CRT_OPT_MAX_EVENTS] events happened (the
 *                           caller's own budget: a stop, as CVODE's root return)
 *   CRT_STOPPED          4  crt_advance: the controller of a closed loop stopped the run
 *                           (crt_control.h)
 *   CRT_MAX_STEPS       -1  crt_advance: opt[CRT_OPT_MAX_STEPS] steps before t_end (an
 *                           error, as CVODE's CV_TOO_MUCH_WORK)
 *   CRT_STEP_UNDERFLOW  -2  crt_advance: the step fell below 1e-14 of the time scale
 *   CRT_NONFINITE       -3  the state or the right-hand side is NaN or infinite (crt_init:
 *                           at t0; crt_advance: even after steps cut down to the minimum)
 *   CRT_PENETRATION     -4  crt_advance: S below the plane by more than h_pen and no
 *                           shorter step avoids it (the contact guarantees below)
 *   CRT_PAINLEVE        -5  crt_advance, friction models: sliding friction leaves no
 *                           consistent normal reaction (dv_n/dp <= 0 in an impact, or
 *                           k_f <= 0 while sliding: crt_friction.h)
 *   CRT_RESTITUTION_REFUSED -6  crt_advance, friction models: restitution_model newton at
 *                           an impact where it is not energy-consistent
 *   CRT_SURFACE_JUMP    -7  crt_advance: in contact, the lowest point S jumped (a
 *                           surface that is not strictly convex, as a capsule whose axis
 *                           passes the horizontal: the one-point contact cannot hold it)
 *   CRT_BAD_ARGUMENT   -20  crt_advance, crt_run, crt_run_many: cap < CRT_MIN_ROWS or
 *                           ev_cap < CRT_MIN_EVENTS.  Nothing is done, nothing written:
 *                           the session is as it was (call again with larger buffers)
 *   CRT_BAD_OPTIONS    -21  crt_init: an option breaks its rule (crt_abi.h);
 *                           crt_bad_option(s) gives its index CRT_OPT_*
 *   CRT_BAD_PARAMETERS -22  crt_init: a parameter is not finite, or shape is no
 *                           CRT_SHAPE_*; crt_bad_parameter(s) gives its index CRT_P_*
 *   CRT_BAD_LAW        -23  crt_set_law_*: the law is malformed (the session then has no
 *                           law); crt_init: no law is set, or a law of several bodies
 *   CRT_BAD_CONTROL    -24  crt_advance: the controller's law is refused (knots, or x or x'
 *                           not continuous at its start); crt_control_fault says why
 * After any code but CRT_OK, CRT_PAUSED and CRT_BAD_ARGUMENT, crt_advance returns that
 * code again, doing nothing, until the next crt_init.
 *
 * ---- The model -------------------------------------------------------------------------
 * A model file defines, before including this header:
 *   NQ, MODEL_NAME, MODEL_HAS_PLANE, MODEL_Z (index of Z_C), MODEL_ZD (index of Z_C'),
 *   model_rhs(p, u, q, dq)                   flight right-hand side
 *   model_normalize(q)                       projection keeping the attitude orthonormal
 *   MODEL_LIE: 1 when the momentum form applies (crt_lie.h), with
 *   model_lie_read(q, c0, omega, R, n_scale) and model_lie_state(p, c0, tau, omega, R,
 *   n_scale, q) between the state and (C at the flight start, omega, attitude)
 * and, when MODEL_HAS_PLANE:
 *   model_gap(p, u, q, h, v_n)               height of S and its rate (E1.14)
 *   model_impact(p, e, u, q, q_plus, I)      impact map (E1.10-E1.16), restitution e
 *   model_contact(p, u, q, dq, N, a_free)    persistent contact: S held on the plane
 *   model_surface_may_jump(p)                1 for a surface not strictly convex
 * and, when MODEL_FRICTION (Coulomb friction at S; crt_friction.h, which documents them):
 *   model_delassus, model_contact_velocity, model_apply_impulse, model_sliding,
 *   model_sticking, and the emitted impulse_slip_direction_rate, impulse_stick_rate,
 *   impulse_resliding.  crt_friction.h is called from eleven hooks in this file, each
 *   marked "friction hook N"; a model without friction compiles none of them.
 * p: the parameters (crt_parameter), u: the point law at t (crt_law.h).
 *
 * Contact guarantees (issue 11; tests/test_contact_properties.py checks them over random
 * scenes):
 *  - in flight every accepted step ends with the height h of S >= -h_pen, where
 *    h_pen = max(1e-10 L, 64 eps (|Z_C| + L)) (L = opt[CRT_OPT_LENGTH_SCALE], the
 *    largest |CS|); a step that would end lower is retried shorter, and if no step can
 *    avoid it the run stops with CRT_PENETRATION, never CRT_DONE;
 *  - S approaching the plane faster than round-off is an impact; heights below
 *    h_res = 10 (atol + rtol (|Z_C| + L)) are not resolved by the integrator;
 *  - an impact leaves S exactly on the plane; when impacts accumulate (after an impact
 *    the next hop's apex v+^2/(2|a|) is below h_res, or the remaining flights, a geometric
 *    series of ratio r, sum to less than zeno_dt times the time scale) S enters persistent
 *    contact; the event records the predicted accumulation time;
 *  - in contact S is held on the plane (h = 0, v_n = 0 after every step) and lifts off
 *    where the reaction N crosses zero.
 * Everything lives in the caller's crt_session: no heap, no mutable statics.
 */
#ifndef CRT_CORE_H
#define CRT_CORE_H

#define CRT_MAX_STAGES 16
#define CRT_EPS 2.220446049250313e-16     /* double precision unit round-off x 2 */
#define CRT_MAX_DENSE 7
#define CRT_MAX_SUB 32                    /* sub-intervals of the event search per step */

#if MODEL_FRICTION
#include "crt_friction_state.h"           /* friction hook 1: the type of s->fr */
#endif

typedef struct {
  double t0, h;
  int m;                                  /* number of F vectors */
  int pending;                            /* DOP853: extra stages not yet computed */
  double y0[NQ];
  double F[CRT_MAX_DENSE][NQ];
  int lie;                                /* a Lie step: F[.][0..2] interpolate W, and */
  double R0[9], k0[3];                    /* the attitude and K in body axes at t0, */
  double c0[6], t_f, n_scale;             /* the flight's constants (crt_lie.h) */
} crt_dense;

#if MODEL_LIE
/* The constants of a flight and the attitude, for the Lie methods (crt_lie.h). */
typedef struct {
  int valid;                              /* they describe the flight through s->t */
  double t_f;                             /* when they were set (an event, or the start) */
  double c0[6];                           /* C at t_f: X_C, Y_C, Z_C, X_C', Y_C', Z_C' */
  double K[3];                            /* K about C in fixed axes (E1.1) */
  double n_scale;                         /* |n| of the vertical model's state, else 1 */
  double quat[4];                         /* the attitude at s->t, a unit quaternion */
  double R[9];                            /* its matrix */
  double k[3];                            /* R^T K: K in body axes at s->t */
  double omega[3];                        /* omega at s->t */
  double quat_end[4], omega_end[3];       /* the same at the end of the last step tried */
} crt_lie;
#endif

typedef struct crt_control crt_control;      /* the closed loop: crt_control.h */

typedef struct {
  double opt[CRT_OPT_COUNT];
  double prm[CRT_P_COUNT];
  crt_law law;
  crt_control *ctl;                       /* the loop, or NULL (crt_set_control) */
  crt_law_work lw;
  double t, h;
  double q[NQ];
  double f[NQ];
  int f_valid;
  int g_valid;                            /* g_start, d_start: the event function at t */
  double g_start, d_start;
  int phase;
  int status;                             /* CRT_OK after crt_init, CRT_PAUSED while it
                                             runs, then the code that ended the run */
  int bad_option, bad_parameter;          /* crt_bad_option, crt_bad_parameter (-1: none) */
  int plane;                              /* MODEL_HAS_PLANE and opt[CRT_OPT_PLANE] */
  double err_old;
  double last_event_t;                    /* the time of the last event */
  double last_impact_t;                   /* accumulating impacts: the last impact, */
  double last_flight;                     /* and the flight before it (0: none yet) */
  double next_output;                     /* t_first + out_k output_dt, no accumulation */
  double t_first;
  double out_k;
  int out_pending;                        /* output rows of the last step still to write */
  double out_until;
  long stat[CRT_STAT_COUNT];
  double summary[CRT_SUMMARY_COUNT];
  double k[CRT_MAX_STAGES][NQ];           /* stage workspace */
  crt_dense dense;
#if MODEL_LIE
  crt_lie lie;
#endif
#if MODEL_FRICTION
  crt_friction fr;                        /* friction hook 2: the contact mode */
#endif
} crt_session;

#if MODEL_FRICTION
/* friction hook 2 (continued): what crt_rhs and crt_event_value call (crt_friction.h) */
static void crt_rough_rhs(crt_session *s, double t, const double *q, double *dq);
static double crt_rough_event_value(crt_session *s, double t, const double *y);
#endif

/* ---- small helpers ---------------------------------------------------------------------- */
static int crt_finite(const double *y)
{
  int i;
  for (i = 0; i < NQ; ++i) {
    if (!(y[i] - y[i] == 0.0)) return 0;  /* NaN or infinity */
  }
  return 1;
}

static double crt_max(double a, double b) { return a > b ? a : b; }
static double crt_min(double a, double b) { return a < b ? a : b; }

/* the state changed other than by a step (an event, a projection): what was computed
   from it is stale */
static void crt_changed(crt_session *s)
{
  s->f_valid = 0;
#if MODEL_LIE
  s->lie.valid = 0;
#endif
}

/* the point law at t (the last evaluation is reused) */
static const double *crt_u(crt_session *s, double t)
{
  return crt_law_eval(&s->law, &s->lw, t, &s->stat[CRT_STAT_LAW_EVALUATIONS]);
}

static void crt_rhs(crt_session *s, double t, const double *q, double *dq)
{
  const double *u = crt_u(s, t);
  ++s->stat[CRT_STAT_RHS_EVALUATIONS];
#if MODEL_FRICTION
  if (s->phase == CRT_CONTACT) {          /* friction hook 3: sliding or sticking */
    crt_rough_rhs(s, t, q, dq);
    return;
  }
#elif MODEL_HAS_PLANE
  if (s->phase == CRT_CONTACT) {
    double N, a_free;
    model_contact(s->prm, u, q, dq, &N, &a_free);
    return;
  }
#endif
  model_rhs(s->prm, u, q, dq);
}

#include "crt_integrators.h"
#include "crt_lie.h"

/* ---- output buffers ---------------------------------------------------------------------- */
typedef struct {
  double *t;
  double *q;
  int *kind;
  int cap, n;
  double *ev;                              /* rows of CRT_EVENT_COLUMNS */
  int ev_cap, ev_n;
} crt_out;

static int crt_emit(crt_out *o, double t, const double *q, int kind)
{
  int i;
  if (o->n >= o->cap) return 0;
  o->t[o->n] = t;
  for (i = 0; i < NQ; ++i) o->q[(long)o->n * NQ + i] = q[i];
  o->kind[o->n] = kind;
  ++o->n;
  return 1;
}

/* rows every output_dt from the dense output of the current step, before t_stop (up to
   and including it when inclusive); returns 0 when the buffer filled first */
static int crt_flush_outputs(crt_session *s, crt_out *o, double t_stop, int inclusive)
{
  const double out_dt = s->opt[CRT_OPT_OUTPUT_DT];
  const double slack = inclusive ? 1e-9 * out_dt : 0.0;
  double y[NQ];
  if (!(out_dt > 0.0)) return 1;
  while (s->next_output < t_stop || (inclusive && s->next_output <= t_stop + slack)) {
    const double at = s->next_output < t_stop ? s->next_output : t_stop;
    if (o->n + 4 > o->cap) {
      s->out_pending = 1;
      s->out_until = t_stop;
      return 0;
    }
    crt_dense_at(s, at, y);
    crt_emit(o, at, y, CRT_ROW_STEP);
    s->out_k += 1.0;
    s->next_output = s->t_first + s->out_k * out_dt;
  }
  s->out_pending = 0;
  return 1;
}

#if MODEL_HAS_PLANE
static void crt_event(crt_out *o, double t, int kind, double value, double a, double b,
                      double extra)
{
  double *row;
  int i;
  if (o->ev_n >= o->ev_cap) return;
  row = o->ev + (long)CRT_EVENT_COLUMNS * o->ev_n;
  row[0] = t; row[1] = (double)kind; row[2] = value; row[3] = a; row[4] = b; row[5] = extra;
  for (i = 6; i < CRT_EVENT_COLUMNS; ++i) row[i] = 0.0;   /* the friction models' columns */
  ++o->ev_n;
}

/* ---- the plane ------------------------------------------------------------------------------ */
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

/* heights below this are not resolved: the integrator's own error in Z_C, or round-off */
static double crt_height_resolution(const crt_session *s, const double *q)
{
  const double size = fabs(q[MODEL_Z]) + s->opt[CRT_OPT_LENGTH_SCALE];
  return 10.0 * crt_max(s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * size,
                        64.0 * CRT_EPS * size);
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
   sphere can drift by more in a step of fast sliding, and there S cannot jump). */
static int crt_surface_jumped(crt_session *s, double t, const double *q)
{
  double h, v_n;
  const double scale = sqrt(fabs(s->prm[CRT_P_g]) * s->opt[CRT_OPT_LENGTH_SCALE])
                       + fabs(q[MODEL_ZD]);
  crt_gap(s, t, q, &h, &v_n);
  return fabs(v_n) > crt_max(1e-3, 10.0 * s->opt[CRT_OPT_RTOL]) * scale;
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

/* the value of the event function: the gap in flight (and its rate), N in contact */
static double crt_event_value(crt_session *s, double t, const double *y, double *deriv)
{
  if (s->phase == CRT_FLIGHT) {
    double h;
    crt_gap(s, t, y, &h, deriv);
    return h;
  } else {
#if MODEL_FRICTION
    *deriv = 0.0;                         /* friction hook 4: the transitions' events */
    return crt_rough_event_value(s, t, y);
#else
    double N, a_free;
    crt_contact_state(s, t, y, &N, &a_free);
    *deriv = 0.0;
    return N;
#endif
  }
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
#if MODEL_FRICTION
    /* friction hook 4b: with couples the event function is the least of values of
       other scales (a kink where the least changes), which can stall the secant on one
       side: there every third point is the middle */
    if (s->fr.couples && repeats >= 2) c = 0.5 * (a + b);
#endif
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

enum { CRT_STEP_CLEAR = 0, CRT_STEP_EVENT = 1, CRT_STEP_RETRY = 2 };

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
    if (flight) {
      /* far from the plane: in flight Z_C'' = -g (E1.2), so Z_C is concave and above
         the lower of its ends over the whole step, and h = Z_C + n.CS with |n.CS| at
         most L_S (a margin of 1e-3 L_S for the sampled reach of the law): h cannot
         reach zero inside the step */
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

/* Lift off at (t, s->q) in contact, N the reaction that reached zero: S put on the plane
   with v_n = 0 (the contact constraint the phase ends with; N does not depend on Z_C and
   Z_C', which that changes), the rows before and after the event, the event, and the
   session in flight from t.  The one lift-off of the runtime: at the start of a step
   whose reaction is already non-positive (crt_advance), and where N crosses zero inside
   a step (crt_handle_event). */
static void crt_lift_off(crt_session *s, crt_out *o, double t, double N)
{
  s->last_event_t = t;
  crt_project(s, t, s->q, 1);
  crt_emit(o, t, s->q, CRT_ROW_BEFORE_EVENT);
  s->phase = CRT_FLIGHT;
  crt_event(o, t, CRT_EV_LIFTOFF, N, 0.0, 0.0, 0.0);
  ++s->stat[CRT_STAT_LIFTOFFS];
  s->last_flight = 0.0;
  crt_emit(o, t, s->q, CRT_ROW_AFTER_EVENT);
  crt_changed(s);
  s->g_valid = 0;
}

static int crt_events_exhausted(crt_session *s)
{
  const double n = (double)(s->stat[CRT_STAT_IMPACTS] + s->stat[CRT_STAT_CONTACTS]
                            + s->stat[CRT_STAT_LIFTOFFS] + s->stat[CRT_STAT_GRAZES]
                            + s->stat[CRT_STAT_STICKS] + s->stat[CRT_STAT_SLIPS]
                            + s->stat[CRT_STAT_REVERSALS] + s->stat[CRT_STAT_COUPLE_STOPS]
                            + s->stat[CRT_STAT_COUPLE_STARTS]);
  if (s->status < 0) return 1;            /* an event refused (friction: painleve, ...) */
  if (n >= s->opt[CRT_OPT_MAX_EVENTS]) {
    s->status = CRT_MAX_EVENTS;
    return 1;
  }
  return 0;
}

#if MODEL_FRICTION
#include "crt_friction.h"                 /* friction hook 5: the friction code */
#endif

/* Enter persistent contact at (t, s->q): S put on the plane, and its normal velocity
   v_cut (what the remaining hops would have carried) removed by a plastic impulse at S,
   -v_cut/k along n (the impact map with e = 0): it acts on omega through d as the
   remaining impacts would, so the state after the cut differs from the accumulated
   cascade only at second order. */
static void crt_enter_contact(crt_session *s, crt_out *o, double t, double v_cut,
                              double t_accumulation)
{
  double N, a_free, q_plastic[NQ], impulse;
  int i;
#if MODEL_FRICTION
  crt_rough_enter_contact(s, o, t, v_cut, t_accumulation);   /* friction hook 6 */
  return;
#endif
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

/* S touches the plane at (t, q) in flight.  S is put exactly on the plane (the row
   "before_event" shows that state), then: the impact map if S approaches faster than
   the resolution (then, if impacts accumulate, persistent contact); resting contact if
   S is pressed onto the plane and leaves too slowly to be resolved; a graze otherwise. */
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
    double q_plus[NQ], impulse, gap2, v_plus;
#if MODEL_FRICTION
    crt_dk_result dk;                     /* friction hook 7: Darboux-Keller's impact */
    if (!crt_rough_impact(s, t, q_plus, &dk)) return;
    impulse = dk.P[2];
    crt_gap(s, t, q_plus, &gap2, &v_plus);
    crt_rough_event(s, o, t, CRT_EV_IMPACT, impulse, v_n, v_plus, 0.0, CRT_MODE_FLIGHT, &dk);
#else
    model_impact(s->prm, s->prm[CRT_P_e], crt_u(s, t), s->q, q_plus, &impulse);
    crt_gap(s, t, q_plus, &gap2, &v_plus);
    crt_event(o, t, CRT_EV_IMPACT, impulse, v_n, v_plus, 0.0);
#endif
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
        crt_enter_contact(s, o, t, v_plus, t + (remaining < HUGE_VAL ? remaining : 0.0));
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
    crt_enter_contact(s, o, t, v_n, t);
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
      if (fabs(dt) <= CRT_TAYLOR_DT * sqrt(s->opt[CRT_OPT_RTOL]) * (t_ev - s->t)) {
        /* a correction this small (the interpolant's root against the method's own: a
           few 1e-11 s) by a Taylor step of first order from the re-step's end, whose
           remainder dt^2 q''/2 is below 1e-6 rtol of the step's own change, instead of
           a second whole step of the method */
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
    crt_emit(o, t_ev, s->q, CRT_ROW_AFTER_EVENT);
    crt_changed(s);
    s->g_valid = 0;
  } else {
    for (it = 0; it < NQ; ++it) s->q[it] = q_ev[it];
#if MODEL_FRICTION
    crt_rough_transition(s, o, t_ev);     /* friction hook 8: lift-off, stick, slip, ... */
#else
    {
      double N, a_free;
      crt_contact_state(s, t_ev, s->q, &N, &a_free);
      crt_lift_off(s, o, t_ev, N);
    }
#endif
  }
  s->t = t_ev;
  return crt_events_exhausted(s) ? CRT_HANDLED_STOP : CRT_HANDLED_GO_ON;
}
#endif

#include "crt_control.h"

static double crt_initial_step(crt_session *s)
{
  double d0 = 0.0, d1 = 0.0, d2 = 0.0, h0, h1, y1[NQ], f1[NQ];
  int i;
  const int order = crt_order(s);
  for (i = 0; i < NQ; ++i) {
    const double sc = s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * fabs(s->q[i]);
    d0 += (s->q[i] / sc) * (s->q[i] / sc);
    d1 += (s->f[i] / sc) * (s->f[i] / sc);
  }
  d0 = sqrt(d0 / NQ); d1 = sqrt(d1 / NQ);
  h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
  h0 = crt_min(h0, s->opt[CRT_OPT_HMAX]);
  for (i = 0; i < NQ; ++i) y1[i] = s->q[i] + h0 * s->f[i];
  crt_rhs(s, s->t + h0, y1, f1);
  for (i = 0; i < NQ; ++i) {
    const double sc = s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * fabs(s->q[i]);
    const double r = (f1[i] - s->f[i]) / sc;
    d2 += r * r;
  }
  d2 = sqrt(d2 / NQ) / h0;
  if (crt_max(d1, d2) <= 1e-15) h1 = crt_max(1e-6, h0 * 1e-3);
  else h1 = pow(0.01 / crt_max(d1, d2), 1.0 / (order + 1));
  return crt_min(crt_min(100.0 * h0, h1), s->opt[CRT_OPT_HMAX]);
}

/* ---- public API (its manual: the comment at the top of this file and those below) ---- */

/* the size of a session in bytes: the caller gives the memory (aligned for a double) */
int crt_sizeof(void) { return (int)sizeof(crt_session); }

/* the number of states of the model, and their names (crt_state_name, model_<kind>.c) */
int crt_nq(void) { return NQ; }

/* 1 when the model has the plane (impacts, contact), else 0 */
int crt_has_plane(void) { return MODEL_HAS_PLANE; }

/* 1 when the model has Coulomb friction at S (crt_friction.h), else 0 */
int crt_has_friction(void) { return MODEL_FRICTION; }

const char *crt_model_name(void) { return MODEL_NAME; }

/* the library's sizes (which: CRT_COUNT_*, crt_abi.h), 0 for an unknown one; Python
   compares them with derive/abi.py when it loads the library */
int crt_count(int which)
{
  switch (which) {
    case CRT_COUNT_OPTIONS: return CRT_OPT_COUNT;
    case CRT_COUNT_PARAMETERS: return CRT_P_COUNT;
    case CRT_COUNT_STATS: return CRT_STAT_COUNT;
    case CRT_COUNT_SUMMARY: return CRT_SUMMARY_COUNT;
    case CRT_COUNT_OPCODES: return CRT_OP_COUNT;
    case CRT_COUNT_EVENT_COLUMNS: return CRT_EVENT_COLUMNS;
    case CRT_COUNT_LAW_MAX_NODES: return CRT_LAW_MAX_NODES;
    case CRT_COUNT_LAW_MAX_POINTS: return CRT_LAW_MAX_POINTS;
    case CRT_COUNT_LAW_MAX_ROTORS: return CRT_LAW_MAX_ROTORS;
    case CRT_COUNT_MIN_ROWS: return CRT_MIN_ROWS;
    case CRT_COUNT_MIN_EVENTS: return CRT_MIN_EVENTS;
    case CRT_COUNT_CTL_MAX_KNOTS: return CRT_CTL_MAX_KNOTS;
    case CRT_COUNT_PUSH_COLUMNS: return CRT_PUSH_COLUMNS;
    case CRT_COUNT_LOG_COLUMNS: return CRT_LOG_COLUMNS;
    default: return 0;
  }
}

/* The law as an interpreted program: n_nodes (1 to CRT_LAW_MAX_NODES) rows (op, a, b) of
   code, the first n_const of them CRT_OP_CONST and no other; consts[n_consts]; out: the
   nodes of x, y, z.  Each node reads only nodes before it, each constant index is below
   n_consts.  The arrays are the caller's and must outlive the runs.  Returns CRT_OK, or
   CRT_BAD_LAW for a malformed program (the session then has no law: crt_init refuses to
   start until one is set). */
int crt_set_law_program(crt_session *s, int n_nodes, int n_const, const int *code,
                        const double *consts, int n_consts, const int *out)
{
  int k;
  s->law.kind = -1;
  if (!crt_law_program_ok(n_nodes, n_const, code, n_consts)) return CRT_BAD_LAW;
  for (k = 0; k < 3; ++k)
    if (out[k] < 0 || out[k] >= n_nodes) return CRT_BAD_LAW;
  s->law.n_points = 1;
  s->law.n_rotors = 0;
  s->law.n_nodes = n_nodes;
  s->law.n_const = n_const;
  s->law.code = code;
  s->law.consts = consts;
  for (k = 0; k < 3; ++k) s->law.out[k] = out[k];
  s->law.kind = CRT_LAW_PROGRAM;
  s->law.extend = 0;
  s->ctl = (crt_control *)0;               /* an open-loop law: crt_set_control again */
  crt_law_prepare(&s->law, &s->lw);
  return CRT_OK;
}

/* The law as a cubic spline: knots[0..n_knots-1] (n_knots >= 2) increasing, coef[(n_knots
   - 1) * 12] the coefficients of x, y, z on each interval (c0 s^3 + c1 s^2 + c2 s + c3,
   s = t - knot); periodic (0 or 1): the law repeats with period knots[n-1] - knots[0].
   The arrays are the caller's and must outlive the runs.  Returns CRT_OK, or CRT_BAD_LAW
   (fewer than two knots, or knots not increasing: the session then has no law). */
int crt_set_law_table(crt_session *s, int n_knots, const double *knots, const double *coef,
                      int periodic)
{
  int k;
  s->law.kind = -1;
  if (n_knots < 2) return CRT_BAD_LAW;
  for (k = 1; k < n_knots; ++k)
    if (!(knots[k] > knots[k - 1])) return CRT_BAD_LAW;
  s->law.n_points = 1;
  s->law.n_rotors = 0;
  s->law.n_knots = n_knots;
  s->law.n_columns = 3;
  s->law.knots = knots;
  s->law.coef = coef;
  s->law.periodic = periodic != 0;
  s->law.kind = CRT_LAW_TABLE;
  s->law.extend = 0;
  s->ctl = (crt_control *)0;               /* an open-loop law: crt_set_control again */
  crt_law_prepare(&s->law, &s->lw);
  return CRT_OK;
}

/* The law of several internal bodies: n_points points (0 to CRT_LAW_MAX_POINTS) and
   n_rotors rotors (0 to CRT_LAW_MAX_ROTORS); out[3 n_points + n_rotors] their outputs in
   the order of u (x, y, z of each point, then psi of each rotor), each a node of the
   program (>= 0) or -1 - c for column c of the table.  The program: n_nodes rows of code
   as crt_set_law_program's (0: none); the table: n_knots (0: none, else >= 2) increasing
   knots and coef[(n_knots - 1) * n_columns * 4], the coefficients of each column on each
   interval (c0 s^3 + c1 s^2 + c2 s + c3, s = t - knot), periodic as crt_set_law_table's.
   The arrays are the caller's and must outlive the runs.  Returns CRT_OK, or CRT_BAD_LAW
   for a malformed law (the session then has no law).  crt_law_at and crt_law_rows give
   its u (crt_law_width numbers, crt_law.h); crt_init refuses it (CRT_BAD_LAW): the
   models of this runtime read one point's u. */
int crt_set_law_bodies(crt_session *s, int n_points, int n_rotors, const int *out,
                       int n_nodes, int n_const, const int *code, const double *consts,
                       int n_consts, int n_knots, int n_columns, const double *knots,
                       const double *coef, int periodic)
{
  s->ctl = (crt_control *)0;               /* an open-loop law: crt_set_control again */
  return crt_law_set_bodies(&s->law, &s->lw, n_points, n_rotors, out, n_nodes, n_const,
                            code, consts, n_consts, n_knots, n_columns, knots, coef,
                            periodic);
}

/* the numbers of u for the law set: 9 for one point (x, y, z, x', y', z', x'', y'',
   z''), 9 per point and 3 per rotor for crt_set_law_bodies' (crt_law.h); 0 for none */
int crt_law_width(crt_session *s) { return crt_law_u_width(&s->law); }

/* the law at t: u[crt_law_width] (one point: x, y, z, x', y', z', x'', y'', z'') */
void crt_law_at(crt_session *s, double t, double *u)
{
  const int n = crt_law_u_width(&s->law);
  const double *v;
  int i;
  if (n == 0) return;
  v = crt_u(s, t);
  for (i = 0; i < n; ++i) u[i] = v[i];
}

/* the law along n times: u[width k + i], width = crt_law_width (outputs, and the law's
   benchmark) */
void crt_law_rows(crt_session *s, int n, const double *t, double *u)
{
  const int width = crt_law_u_width(&s->law);
  int k, i;
  if (width == 0) return;
  for (k = 0; k < n; ++k) {
    const double *v = crt_u(s, t[k]);
    for (i = 0; i < width; ++i) u[(long)width * k + i] = v[i];
  }
}

/* The first option that breaks its rule (the rules of crt_abi.h's enum crt_option), or
   -1.  Options without a rule take any value. */
static int crt_option_fault(const double *opt)
{
  const double method = opt[CRT_OPT_METHOD];
  if (!(method >= 0.0 && method < (double)CRT_METHOD_COUNT && (double)(int)method == method))
    return CRT_OPT_METHOD;
  if (!(opt[CRT_OPT_RTOL] > 0.0)) return CRT_OPT_RTOL;
  if (!(opt[CRT_OPT_ATOL] > 0.0)) return CRT_OPT_ATOL;
  if (!(opt[CRT_OPT_HMAX] > 0.0)) return CRT_OPT_HMAX;
  if (!(opt[CRT_OPT_TIME_SCALE] > 0.0)) return CRT_OPT_TIME_SCALE;
  if (!(opt[CRT_OPT_RK4_STEP] > 0.0)) return CRT_OPT_RK4_STEP;
  if (!(opt[CRT_OPT_OUTPUT_DT] >= 0.0)) return CRT_OPT_OUTPUT_DT;
  if (!(opt[CRT_OPT_EVENT_TOL] > 0.0)) return CRT_OPT_EVENT_TOL;
  if (!(opt[CRT_OPT_LENGTH_SCALE] >= 0.0)) return CRT_OPT_LENGTH_SCALE;
  if (!(opt[CRT_OPT_MAX_STEPS] >= 1.0)) return CRT_OPT_MAX_STEPS;
  if (!(opt[CRT_OPT_MAX_EVENTS] >= 1.0)) return CRT_OPT_MAX_EVENTS;
  return -1;
}

/* The first parameter that is not finite, or the shape when it names no surface
   (CRT_SHAPE_*), a negative friction coefficient or a restitution model that names
   none (CRT_RESTITUTION_*); or -1. */
static int crt_parameter_fault(const double *prm)
{
  const double law = prm[CRT_P_restitution_model];
  int i;
  for (i = 0; i < CRT_P_COUNT; ++i)
    if (!(prm[i] - prm[i] == 0.0)) return i;   /* NaN or infinite */
  if (!(prm[CRT_P_shape] >= 0.0 && prm[CRT_P_shape] < CRT_SHAPE_COUNT
        && prm[CRT_P_shape] == (double)(int)prm[CRT_P_shape]))
    return CRT_P_shape;
  if (!(prm[CRT_P_friction] >= 0.0)) return CRT_P_friction;
  if (!(prm[CRT_P_spin_friction] >= 0.0)) return CRT_P_spin_friction;
  if (!(prm[CRT_P_rolling_resistance] >= 0.0)) return CRT_P_rolling_resistance;
  if (!(law >= 0.0 && law < (double)CRT_RESTITUTION_COUNT && (double)(int)law == law))
    return CRT_P_restitution_model;
  return -1;
}

/* Start a run at (t0, q0[NQ]) with the options opt[CRT_OPT_COUNT] and the parameters
   prm[CRT_P_COUNT] (both copied: the caller may reuse its arrays); the law must be set.
   Returns CRT_OK when the run is ready to advance, else (and crt_advance then returns the
   same code until the next crt_init):
     CRT_BAD_LAW          no law is set, or the last crt_set_law_* refused its law, or
                          it is crt_set_law_bodies' (the models read one point);
     CRT_BAD_OPTIONS      an option breaks its rule: crt_bad_option(s) is its index;
     CRT_BAD_PARAMETERS   a parameter is not finite, or shape is no CRT_SHAPE_*:
                          crt_bad_parameter(s) is its index;
     CRT_NONFINITE        q0, or the right-hand side at (t0, q0), is not finite. */
int crt_init(crt_session *s, const double *opt, const double *prm, double t0, const double *q0)
{
  int i;
  for (i = 0; i < CRT_OPT_COUNT; ++i) s->opt[i] = opt[i];
  for (i = 0; i < CRT_P_COUNT; ++i) s->prm[i] = prm[i];
  for (i = 0; i < CRT_STAT_COUNT; ++i) s->stat[i] = 0;
  for (i = 0; i < NQ; ++i) s->q[i] = q0[i];
  s->summary[CRT_SUMMARY_MIN_HEIGHT] = HUGE_VAL;
  s->summary[CRT_SUMMARY_MIN_NORMAL] = HUGE_VAL;
  s->summary[CRT_SUMMARY_T_MIN_HEIGHT] = t0;
  s->summary[CRT_SUMMARY_MAX_FRICTION_RATIO] = 0.0;
  s->lw.valid = 0;
  s->t = t0;
  s->phase = CRT_FLIGHT;
  s->status = CRT_OK;
  s->bad_option = -1;
  s->bad_parameter = -1;
  s->plane = MODEL_HAS_PLANE && s->opt[CRT_OPT_PLANE] != 0.0;
  s->err_old = 1e-4;
  crt_changed(s);
  s->g_valid = 0;
  s->last_impact_t = t0;
  s->last_event_t = -HUGE_VAL;
  s->last_flight = 0.0;
  s->next_output = t0;
  s->t_first = t0;
  s->out_k = 0.0;
  s->out_pending = 0;
  s->out_until = t0;
  if (s->ctl) crt_control_start(s, t0);    /* the loop's clock, noise, pushes; the law */
  if (s->law.kind != CRT_LAW_PROGRAM && s->law.kind != CRT_LAW_TABLE) {
    s->status = CRT_BAD_LAW;
    return s->status;
  }
  s->bad_option = crt_option_fault(s->opt);
  if (s->bad_option >= 0) { s->status = CRT_BAD_OPTIONS; return s->status; }
  s->bad_parameter = crt_parameter_fault(s->prm);
  if (s->bad_parameter >= 0) { s->status = CRT_BAD_PARAMETERS; return s->status; }
#if MODEL_FRICTION
  s->fr.spin.on = s->prm[CRT_P_spin_friction] > 0.0;
  s->fr.roll.on = s->prm[CRT_P_rolling_resistance] > 0.0;
  s->fr.couples = s->fr.spin.on || s->fr.roll.on;
  s->fr.spin.held = s->fr.roll.held = 0;
#endif
  if (!crt_finite(s->q)) { s->status = CRT_NONFINITE; return s->status; }
  crt_rhs(s, s->t, s->q, s->f);
  if (!crt_finite(s->f)) { s->status = CRT_NONFINITE; return s->status; }
  s->f_valid = 1;
  if ((int)s->opt[CRT_OPT_METHOD] == CRT_RK4) s->h = s->opt[CRT_OPT_RK4_STEP];
  else if (s->opt[CRT_OPT_H0] > 0.0) s->h = s->opt[CRT_OPT_H0];
#if MODEL_LIE
  else if (crt_lie_active(s)) s->h = crt_lie_initial_step(s, crt_order(s));
#endif
  else s->h = crt_initial_step(s);
  return s->status;
}

/* After crt_init returned CRT_BAD_OPTIONS: the index (CRT_OPT_*) of the first option
   that breaks its rule (crt_option_name gives its name); otherwise -1. */
int crt_bad_option(const crt_session *s) { return s->bad_option; }

/* After crt_init returned CRT_BAD_PARAMETERS: the index (CRT_P_*) of the first parameter
   that is not finite (crt_parameter_name gives its name); otherwise -1. */
int crt_bad_parameter(const crt_session *s) { return s->bad_parameter; }

/* CRT_FLIGHT or CRT_CONTACT (S held on the plane) */
int crt_phase(const crt_session *s) { return s->phase; }

/* the time the session has reached */
double crt_time(const crt_session *s) { return s->t; }

/* the state at crt_time: q[NQ] */
void crt_state(const crt_session *s, double *q)
{
  int i;
  for (i = 0; i < NQ; ++i) q[i] = s->q[i];
}

/* the run's counters: out[CRT_STAT_COUNT] (enum crt_stat) */
void crt_stats(const crt_session *s, long *out)
{
  int i;
  for (i = 0; i < CRT_STAT_COUNT; ++i) out[i] = s->stat[i];
}

/* what the run kept: out[CRT_SUMMARY_COUNT] (enum crt_summary_value) */
void crt_summary(const crt_session *s, double *out)
{
  int i;
  for (i = 0; i < CRT_SUMMARY_COUNT; ++i) out[i] = s->summary[i];
}

/* the model's right-hand side at (t, q) in the current phase (for tests and benchmarks) */
void crt_eval_rhs(crt_session *s, double t, const double *q, double *dq)
{
  crt_rhs(s, t, q, dq);
}

/* persistent contact at (t, q): dq/dt with S held on the plane, the reaction N and the
   normal acceleration of S without it, a_free (models with a plane; else N = a_free = 0) */
void crt_eval_contact(crt_session *s, double t, const double *q, double *dq, double *N,
                      double *a_free)
{
#if MODEL_HAS_PLANE
  model_contact(s->prm, crt_u(s, t), q, dq, N, a_free);
#else
  int i;
  for (i = 0; i < NQ; ++i) dq[i] = 0.0;
  (void)t; (void)q;
  *N = 0.0;
  *a_free = 0.0;
  (void)s;
#endif
}

/* the height h of S above the plane and its rate v_n at (t, q): what the event search
   follows (models with a plane; else h = v_n = 0) */
void crt_eval_gap(crt_session *s, double t, const double *q, double *h, double *v_n)
{
#if MODEL_HAS_PLANE
  model_gap(s->prm, crt_u(s, t), q, h, v_n);
#else
  (void)s; (void)t; (void)q;
  *h = 0.0;
  *v_n = 0.0;
#endif
}

/* persistent contact along n rows (t[k], q[k*NQ..]): dq/dt into dq[k*NQ..], N[k], a_free[k] */
void crt_eval_contact_rows(crt_session *s, int n, const double *t, const double *q, double *dq,
                           double *N, double *a_free)
{
  int k;
  for (k = 0; k < n; ++k)
    crt_eval_contact(s, t[k], q + (long)k * NQ, dq + (long)k * NQ, N + k, a_free + k);
}

/* the flight right-hand side along n rows (t[k], q[k*NQ..]) into dq[k*NQ..] */
void crt_eval_rhs_rows(crt_session *s, int n, const double *t, const double *q, double *dq)
{
  int k;
  for (k = 0; k < n; ++k) model_rhs(s->prm, crt_u(s, t[k]), q + (long)k * NQ, dq + (long)k * NQ);
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
  if (s->stat[CRT_STAT_STEPS] == 0 && s->t_first == s->t && s->out_k == 0.0) {
    crt_emit(o, s->t, s->q, CRT_ROW_STEP);
    s->out_k = 1.0;
    s->next_output = out_dt > 0.0 ? s->t_first + out_dt : s->t;
  }
  if (s->ctl && !s->ctl->started) {        /* the loop's first call, at t0 */
    const int stop = crt_control_call(s, CRT_CALL_START, 0);
    s->ctl->started = 1;
    if (stop) { s->status = stop; return; }
  }
  if (s->out_pending && !crt_flush_outputs(s, o, s->out_until, s->out_until >= t_end)) {
    return;
  }
  while (s->t < t_end) {
    double h, h_wanted, knot, err, t1, stop = HUGE_VAL;
    if (o->n + CRT_MIN_ROWS > o->cap || o->ev_n + CRT_MIN_EVENTS > o->ev_cap) break;
    if (s->ctl && s->ctl->log_n + CRT_CTL_MAX_KNOTS > s->ctl->log_cap) break;
    if ((double)s->stat[CRT_STAT_STEPS] >= s->opt[CRT_OPT_MAX_STEPS]) { s->status = CRT_MAX_STEPS; break; }
#if MODEL_HAS_PLANE
    if (s->plane && s->phase == CRT_CONTACT) {
#if MODEL_FRICTION
      /* friction hook 9: a transition due at the start of a step */
      if (!(crt_rough_event_value(s, s->t, s->q) > 0.0)) {
        crt_rough_transition(s, o, s->t);
        if (crt_events_exhausted(s)) break;
        continue;
      }
#else
      /* the reaction already non-positive at the start of a step: lift off now */
      double N, a_free;
      crt_contact_state(s, s->t, s->q, &N, &a_free);
      if (!(N > 0.0)) {
        crt_lift_off(s, o, s->t, N);
        if (crt_events_exhausted(s)) break;
        if (s->ctl) {
          const int halt = crt_control_call(s, CRT_CALL_EVENT, CRT_EV_LIFTOFF);
          if (halt) { s->status = halt; break; }
        }
        continue;
      }
#endif
    }
    if (s->plane && s->phase == CRT_FLIGHT) {
      double g0 = s->g_start, d0 = s->d_start;
      if (!s->g_valid) {
        crt_gap(s, s->t, s->q, &g0, &d0);
        s->g_start = g0; s->d_start = d0; s->g_valid = 1;
      }
      if (g0 <= 0.0 && d0 < 0.0 && s->t != s->last_event_t) {
        /* S on (or, after round-off, just below) the plane and moving down: collide now
           (once: not again at the time of the event that put it there) */
        double q_now[NQ];
        long before[3];
        int i;
        crt_control_counters(s, before);
        for (i = 0; i < NQ; ++i) q_now[i] = s->q[i];
        crt_collide(s, o, s->t, q_now);
        crt_emit(o, s->t, s->q, CRT_ROW_AFTER_EVENT);
        crt_changed(s);
        s->g_valid = 0;
        if (crt_events_exhausted(s)) break;
        if (s->ctl) {
          const int halt = crt_control_after_event(s, before);
          if (halt) { s->status = halt; break; }
        }
        continue;
      }
    }
#endif
    if (!s->f_valid && !crt_lie_active(s)) { crt_rhs(s, s->t, s->q, s->f); s->f_valid = 1; }
    h = crt_min(crt_min(s->h, s->opt[CRT_OPT_HMAX]), crt_step_limit(s));
    h_wanted = h;
    knot = crt_law_next_knot(&s->law, s->t);     /* steps end on a table's knots */
    if (s->t + h > knot) h = knot - s->t;
    if (s->ctl) {                                /* and on the loop's samples and pushes */
      stop = crt_control_next_stop(s);
      if (stop <= s->t) {                        /* due now (a push at an event's time) */
        const int halt = crt_control_at_stop(s, o);
        if (halt) { s->status = halt; break; }
        continue;
      }
      /* a knot a rounding error before the stop is the stop: no step of 1e-16 s */
      if (s->t + h >= stop || stop - (s->t + h) < h_min) h = stop - s->t;
    }
    if (s->t + h > t_end) h = t_end - s->t;
    if (h < h_min && s->t + h < t_end) { s->status = CRT_STEP_UNDERFLOW; break; }
    err = crt_step(s, s->t, s->q, s->f, h, y1, f1, 1);
    if (!crt_finite(y1) || !crt_finite(f1)) {
      if (h > h_min) { s->h = 0.25 * h; ++s->stat[CRT_STAT_REJECTED]; continue; }
      s->status = CRT_NONFINITE; break;
    }
    if (adaptive && err > 1.0) {
      const double fac = crt_max(0.2, 0.9 * pow(err, -1.0 / order));
      s->h = h * fac;
      ++s->stat[CRT_STAT_REJECTED];
      if (s->h < h_min) { s->status = CRT_STEP_UNDERFLOW; break; }
      continue;
    }
    t1 = s->t + h;
#if MODEL_HAS_PLANE
    if (s->plane) {
      double ta = 0.0, tb = 0.0, ga = 0.0, gb = 0.0;
      const int found = crt_search(s, t1, y1, model_rate(s->prm, crt_u(s, t1), y1),
                                   &ta, &ga, &tb, &gb);
      if (found == CRT_STEP_EVENT) {
        enum crt_handled handled;
        long before[3];
        crt_control_counters(s, before);
        handled = crt_handle_event(s, o, ta, ga, tb, gb);
        if (handled == CRT_HANDLED_BUFFER_FULL) { s->g_valid = 0; break; }
        if (handled == CRT_HANDLED_STOP) break;
        if (s->ctl) {
          const int halt = crt_control_after_event(s, before);
          if (halt) { s->status = halt; break; }
        }
        continue;
      }
      if (found == CRT_STEP_RETRY) {
        s->g_valid = 0;
        ++s->stat[CRT_STAT_REJECTED];
        if (0.25 * h < h_min) { s->status = CRT_PENETRATION; break; }
        s->h = 0.25 * h;
        continue;
      }
      if (s->phase == CRT_FLIGHT) crt_track_height(s, t1, s->g_start);
    }
#endif
    /* accepted step without event */
    ++s->stat[CRT_STAT_STEPS];
    if (h == stop - s->t) t1 = stop;             /* exactly at the loop's stop */
    {
      int i;
      s->t = t1;
      for (i = 0; i < NQ; ++i) { s->q[i] = y1[i]; s->f[i] = f1[i]; }
    }
    s->f_valid = 1;
#if MODEL_LIE
    if (crt_lie_active(s)) crt_lie_accept(s);   /* on SO(3) already: no projection */
    else
#endif
    if (s->opt[CRT_OPT_ORTHONORMAL] != 0.0) {
      model_normalize(s->q);
      crt_changed(s);
      s->g_valid = 0;
    }
#if MODEL_HAS_PLANE
    if (s->phase == CRT_CONTACT) {
      if (model_surface_may_jump(s->prm) && crt_surface_jumped(s, s->t, s->q)) {
        s->status = CRT_SURFACE_JUMP;
        break;
      }
      crt_project(s, s->t, s->q, 1);
#if MODEL_FRICTION
      crt_rough_after_step(s);            /* friction hook 10 */
#else
      {
        double N, a_free;
        crt_contact_state(s, s->t, s->q, &N, &a_free);
        if (N < s->summary[CRT_SUMMARY_MIN_NORMAL]) s->summary[CRT_SUMMARY_MIN_NORMAL] = N;
      }
#endif
      crt_changed(s);
      s->g_valid = 0;
#if MODEL_FRICTION
      if (s->status < 0) break;           /* friction hook 11: painleve while sliding */
#endif
    }
#endif
    if (out_dt <= 0.0) crt_emit(o, s->t, s->q, CRT_ROW_STEP);
    else if (!crt_flush_outputs(s, o, s->t, s->t >= t_end)) {
      /* the rest on the next call */
    }
    if (s->ctl && s->t >= stop) {                /* a sample, a push: the loop acts */
      const int halt = crt_control_at_stop(s, o);
      if (halt) { s->status = halt; break; }
    }
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
    if (s->out_pending) break;
  }
  if (s->ctl && s->status != CRT_PAUSED) crt_control_log_law(s->ctl, s->t);
  if (s->status == CRT_PAUSED && s->t >= t_end && !s->out_pending) {
    s->status = CRT_DONE;
    if (s->ctl) crt_control_log_law(s->ctl, s->t);
    /* the output_dt grid need not land on t_end: the final state is a row too */
    if (out_dt > 0.0 && (o->n == 0 || o->t[o->n - 1] < s->t))
      crt_emit(o, s->t, s->q, CRT_ROW_STEP);
  }
}

/* Advance the run to t_end (> crt_time, or nothing happens and the run is done), or until
   an output buffer is full.  Writes rows t_out[cap], q_out[cap * NQ], kind_out[cap]
   (enum crt_row_kind): the initial state (on the first call), the state at every accepted
   step (or every opt[CRT_OPT_OUTPUT_DT] from the dense output, and at t_end), and before
   and after every event; *n_out of them.  Writes events ev_out[ev_cap * CRT_EVENT_COLUMNS]
   (t, kind (enum crt_event_kind), value, v_n-, v_n+, t_accumulation); *n_ev of them.
   cap >= CRT_MIN_ROWS and ev_cap >= CRT_MIN_EVENTS, else CRT_BAD_ARGUMENT and nothing is
   done.  Returns CRT_PAUSED when a buffer is full (read the rows, call again: the run
   resumes where it paused), CRT_DONE at t_end, or the code that stopped the run
   (CRT_MAX_EVENTS, or an error: the manual at the top of this file); after a stop or an
   error, and after crt_init failed, it returns that code again and writes nothing. */
int crt_advance(crt_session *s, double t_end, double *t_out, double *q_out, int *kind_out,
                int cap, int *n_out, double *ev_out, int ev_cap, int *n_ev)
{
  crt_out o;
  *n_out = 0; *n_ev = 0;
  if (cap < CRT_MIN_ROWS || ev_cap < CRT_MIN_EVENTS) return CRT_BAD_ARGUMENT;
  if (s->status != CRT_OK && s->status != CRT_PAUSED) return s->status;
  s->status = CRT_PAUSED;                  /* running: a stop or an error overwrites it */
  o.t = t_out; o.q = q_out; o.kind = kind_out; o.cap = cap; o.n = 0;
  o.ev = ev_out; o.ev_cap = ev_cap; o.ev_n = 0;
  crt_integrate(s, t_end, &o);
  *n_out = o.n;
  *n_ev = o.ev_n;
  return s->status;
}

/* crt_init, then crt_advance to t_end, then crt_stats and crt_summary: a whole run in one
   call (what a binding pays per call is per crossing).  The arguments are those of the
   three.  *init_status is crt_init's result; when it is not CRT_OK nothing ran, and that
   code is returned (stats and summary are not written).  Otherwise returns crt_advance's
   code: CRT_PAUSED when a buffer filled (call crt_advance again, then crt_stats and
   crt_summary), CRT_BAD_ARGUMENT for too small buffers (nothing ran yet: call
   crt_advance with larger ones). */
int crt_run(crt_session *s, const double *opt, const double *prm, double t0, const double *q0,
            double t_end, double *t_out, double *q_out, int *kind_out, int cap, int *n_out,
            double *ev_out, int ev_cap, int *n_ev, long *stats, double *summary,
            int *init_status)
{
  int status = crt_init(s, opt, prm, t0, q0);
  *init_status = status;
  *n_out = 0; *n_ev = 0;
  if (status != CRT_OK) return status;
  status = crt_advance(s, t_end, t_out, q_out, kind_out, cap, n_out, ev_out, ev_cap, n_ev);
  crt_stats(s, stats);
  crt_summary(s, summary);
  return status;
}

/* n runs of the session's law, one after another, each keeping only what a parameter
   study reads: its status, counters, summary, final time and state, and the time of its
   first contact (NaN if none) -- one crossing into C for many runs.  Row i of opt
   (CRT_OPT_COUNT), prm (CRT_P_COUNT) and q0 (NQ), and t0[i], t_end[i], are run i's; the
   row and event buffers (t_buf[cap], q_buf[cap * NQ], kind_buf[cap], ev_buf[ev_cap *
   CRT_EVENT_COLUMNS]) are scratch; the smaller they are, the more often each run pauses
   and resumes inside.  init_status[i] is crt_init's result (when not CRT_OK, run i did
   not start and its status is that code).  status[i] is the code that ended run i:
   CRT_DONE, CRT_MAX_EVENTS or an error, never CRT_PAUSED; CRT_BAD_ARGUMENT when cap <
   CRT_MIN_ROWS or ev_cap < CRT_MIN_EVENTS (then no run advances).  Outputs: status[n],
   stats[n * CRT_STAT_COUNT], summary[n * CRT_SUMMARY_COUNT], last[n * (1 + NQ)] (t, then
   q), first_contact[n]. */
void crt_run_many(crt_session *s, int n, const double *opt, const double *prm,
                  const double *t0, const double *q0, const double *t_end, double *t_buf,
                  double *q_buf, int *kind_buf, int cap, double *ev_buf, int ev_cap,
                  int *init_status, int *status, long *stats, double *summary, double *last,
                  double *first_contact)
{
  int i, j, e, n_rows, n_ev, st;
  for (i = 0; i < n; ++i) {
    double *row = last + (long)i * (1 + NQ);
    first_contact[i] = NAN;
    row[0] = t0[i];
    for (j = 0; j < NQ; ++j) row[1 + j] = q0[(long)i * NQ + j];
    st = crt_init(s, opt + (long)i * CRT_OPT_COUNT, prm + (long)i * CRT_P_COUNT, t0[i],
                  q0 + (long)i * NQ);
    init_status[i] = st;
    if (st == CRT_OK) {
      do {
        st = crt_advance(s, t_end[i], t_buf, q_buf, kind_buf, cap, &n_rows, ev_buf, ev_cap,
                         &n_ev);
        for (e = 0; e < n_ev; ++e)
          if (first_contact[i] != first_contact[i]
              && (int)ev_buf[(long)e * CRT_EVENT_COLUMNS + 1] == CRT_EV_CONTACT)
            first_contact[i] = ev_buf[(long)e * CRT_EVENT_COLUMNS];
        if (n_rows > 0) {
          row[0] = t_buf[n_rows - 1];
          for (j = 0; j < NQ; ++j) row[1 + j] = q_buf[(long)(n_rows - 1) * NQ + j];
        }
      } while (st == CRT_PAUSED);
    }
    status[i] = st;
    crt_stats(s, stats + (long)i * CRT_STAT_COUNT);
    crt_summary(s, summary + (long)i * CRT_SUMMARY_COUNT);
  }
}

#endif /* CRT_CORE_H */
