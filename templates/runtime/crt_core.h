/*
 * crt_core.h: the event-driven runtime's public API, on top of its stack of headers (the
 * list: crt_session.h).  Included at the end of each model's file (model_<kind>.c: with
 * the headers it includes, the runtime's one translation unit).
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
 *                                              which the moments models run)
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
 *   CRT_LIFT_OFF         5  crt_advance, the base model (a body on its face, crt_base.h):
 *                           the normal force N under the face reached 0; the run stops
 *                           there, with an event lift_off at its time
 *   CRT_TIPPING          6  crt_advance, the base model: the centre of pressure reached the
 *                           face's edge (the body tips); the run stops there, with an
 *                           event tipping at its time
 *   CRT_FACE_LIFTING     7  crt_advance, the base model with linear pressure: the centre
 *                           of pressure left the face's kern (the pressure would turn
 *                           negative at an edge); the run stops there, with an event
 *                           face_lifting at its time
 *   CRT_FLAT_LANDING     8  crt_advance, a box or a cylinder in flight: a touch coming
 *                           down with the face nearest the plane flat, every corner (the
 *                           rim) within the height resolution (a multi-point impact no
 *                           model makes; derive/docs/bodies.md); the run stops at the
 *                           touch's row before_event, with an event flat_landing (no
 *                           impact applied)
 *   CRT_MAX_STEPS       -1  crt_advance: opt[CRT_OPT_MAX_STEPS] steps before t_end (an
 *                           error, as CVODE's CV_TOO_MUCH_WORK)
 *   CRT_STEP_UNDERFLOW  -2  crt_advance: the step fell below 1e-14 of the time scale
 *   CRT_NONFINITE       -3  the state or the right-hand side is NaN or infinite (crt_init:
 *                           at t0; crt_advance: even after steps cut down to the minimum)
 *   CRT_PENETRATION     -4  crt_advance: S below the plane by more than h_pen and no
 *                           shorter step avoids it (the contact guarantees below)
 *   CRT_PAINLEVE        -5  crt_advance, friction models: sliding friction leaves no
 *                           consistent normal reaction (dv_n/dp <= 0 in an impact, or
 *                           k_f <= 0 while sliding: crt_dk.h, crt_rough.h)
 *   CRT_RESTITUTION_REFUSED -6  crt_advance, friction models: restitution_model newton at
 *                           an impact where it is not energy-consistent
 *   CRT_SURFACE_JUMP    -7  crt_advance: in contact, the lowest point S jumped (a
 *                           surface that is not strictly convex, as a capsule whose axis
 *                           passes the horizontal), or another point across the body
 *                           reached the plane with it (a cylinder lying on its side): the
 *                           one-point contact cannot hold it
 *   CRT_BAD_ARGUMENT   -20  crt_advance, crt_run, crt_run_many: cap < CRT_MIN_ROWS or
 *                           ev_cap < CRT_MIN_EVENTS.  Nothing is done, nothing written:
 *                           the session is as it was (call again with larger buffers)
 *   CRT_BAD_OPTIONS    -21  crt_init: an option breaks its rule (crt_abi.h);
 *                           crt_bad_option(s) gives its index CRT_OPT_*
 *   CRT_BAD_PARAMETERS -22  crt_init: a parameter is not finite, or shape is no
 *                           CRT_SHAPE_*; crt_bad_parameter(s) gives its index CRT_P_*
 *   CRT_BAD_LAW        -23  crt_set_law_*: the law is malformed (the session then has no
 *                           law); crt_init: no law is set, or a law of several bodies in a
 *                           model of one point (any but moments and moments_rough)
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
 *   model_rate(p, u, q)                      |omega|: how fast S moves over the body
 *   model_surface_may_jump(p)                1 for a surface not strictly convex
 *   model_surface_second(p, q, reach)        height above S of the next lowest point
 *                                            across the body (HUGE_VAL: none)
 * and, when MODEL_FRICTION (Coulomb friction at S; crt_rough_modes.h, crt_rough.h):
 *   model_delassus, model_contact_velocity, model_apply_impulse, model_sliding,
 *   model_sticking, model_contact_wrench, model_wrench_rates, and the emitted
 *   impulse_slip_direction_rate, impulse_stick_rate, impulse_resliding (crt_dk.h);
 * and, when MODEL_PUSH (the closed loop's pushes, crt_control.h): model_push;
 * and, when MODEL_MOMENTS (the moments models: any number of points and rotors), the
 * emitted point_moments and rotor_moments and MODEL_MOMENTS_COUNT, MODEL_MOMENTS_SPIN
 * (crt_bodies.h), and, with MODEL_LIE, MODEL_LIE_STAGE, MODEL_LIE_POINT and
 * MODEL_FIXED_KINETIC_MOMENT name the family's momentum-form functions.
 * p: the parameters (crt_parameter), u: what crt_u gives at t -- the point law
 * (crt_law.h), or the moments models' sum of their bodies' moments (crt_bodies.h).
 * The contact's variant (smooth, rough, none) is chosen once, in crt_contact.h, by
 * MODEL_FRICTION and MODEL_HAS_PLANE; the loop reaches it through named hooks.
 *
 * Contact guarantees (issue 11; tests/test_contact_properties.py checks them over random
 * scenes):
 *  - in flight every accepted step ends with the height h of S >= -h_pen, where
 *    h_pen = max(1e-10 L, 64 eps (|Z_C| + L)) (L = opt[CRT_OPT_LENGTH_SCALE], the
 *    largest |CS|); a step that would end lower is retried shorter, and if no step can
 *    avoid it the run stops with CRT_PENETRATION, never CRT_DONE;
 *  - S approaching the plane faster than round-off is an impact; heights below
 *    h_res = 10 (atol + rtol (|Z_C| + L)) are not resolved by the integrator (RK4,
 *    which keeps no tolerance: 10 (64 eps (|Z_C| + L)), round-off; crt_kept_rtol);
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

#if MODEL_BASE
#include "crt_base.h"                     /* the base model's loop: stick and slip */
#else
#include "crt_loop.h"
#endif

/* ---- public API (its manual: the comment at the top of this file and those below) ---- */

/* the size of a session in bytes: the caller gives the memory (aligned for a double) */
int crt_sizeof(void) { return (int)sizeof(crt_session); }

/* the number of states of the model, and their names (crt_state_name, model_<kind>.c) */
int crt_nq(void) { return NQ; }

/* 1 when the model has the plane (impacts, contact), else 0 */
int crt_has_plane(void) { return MODEL_HAS_PLANE; }

/* 1 when the model has Coulomb friction at S (crt_rough.h, crt_rough_api.h), else 0 */
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
   its u (crt_law_width numbers, crt_law.h); the moments models run it (their
   parameters n_points, n_rotors, m_j, a_r_*, I_r describe its bodies: crt_bodies.h), the
   others refuse it in crt_init (CRT_BAD_LAW): they read one point's u. */
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
  v = crt_law_u(s, t);
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
    const double *v = crt_law_u(s, t[k]);
    for (i = 0; i < width; ++i) u[(long)width * k + i] = v[i];
  }
}

/* the numbers the model's functions read in place of the law (crt_u): 9 for the models
   of one point (the law's u), MODEL_MOMENTS_COUNT for the moments models (the moments of
   the bodies, crt_bodies.h) */
int crt_u_width(void)
{
#if MODEL_MOMENTS
  return MODEL_MOMENTS_COUNT;
#else
  return 9;
#endif
}

/* what the model's functions read at n times, after crt_init: u[crt_u_width() k + i] (the
   moments models: the moments their bodies' law gives, summed as in a run) */
void crt_eval_u_rows(crt_session *s, int n, const double *t, double *u)
{
  const int width = crt_u_width();
  int k, i;
  for (k = 0; k < n; ++k) {
    const double *v = crt_u(s, t[k]);
    for (i = 0; i < width; ++i) u[(long)width * k + i] = v[i];
  }
}

/* 1 when the model runs the law set: one point's (every model), or several bodies'
   (the moments models) */
static int crt_law_runs(const crt_law *L)
{
  if (L->kind == CRT_LAW_PROGRAM || L->kind == CRT_LAW_TABLE) return 1;
  return MODEL_MOMENTS && L->kind == CRT_LAW_BODIES;
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
  if (!(opt[CRT_OPT_OUTPUT_PHASE] >= 0.0)) return CRT_OPT_OUTPUT_PHASE;
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
                          it is crt_set_law_bodies' and the model reads one point (all
                          but the moments models);
     CRT_BAD_OPTIONS      an option breaks its rule: crt_bad_option(s) is its index;
     CRT_BAD_PARAMETERS   a parameter is not finite, or shape is no CRT_SHAPE_*, or (the
                          moments models) the bodies' parameters do not describe the
                          law's bodies (crt_bodies_fault): crt_bad_parameter(s) is its
                          index;
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
  s->out_origin = t0 + opt[CRT_OPT_OUTPUT_PHASE];
  s->out_k = 0.0;
  s->rows_started = 0;
  s->out_pending = 0;
  s->out_until = t0;
  if (s->ctl) crt_control_start(s, t0);    /* the loop's clock, noise, pushes; the law */
  if (!crt_law_runs(&s->law)) {
    s->status = CRT_BAD_LAW;
    return s->status;
  }
  s->bad_option = crt_option_fault(s->opt);
  if (s->bad_option >= 0) { s->status = CRT_BAD_OPTIONS; return s->status; }
  s->bad_parameter = crt_parameter_fault(s->prm);
#if MODEL_MOMENTS
  s->mo.stamp = -1;                        /* no sum of this run's law yet (crt_u) */
  if (s->bad_parameter < 0) s->bad_parameter = crt_bodies_fault(&s->law, s->prm);
#endif
  if (s->bad_parameter >= 0) { s->status = CRT_BAD_PARAMETERS; return s->status; }
  crt_contact_start(s);                    /* the contact's memory (the rough's: couples) */
  if (!crt_finite(s->q)) { s->status = CRT_NONFINITE; return s->status; }
  crt_rhs(s, s->t, s->q, s->f);
  if (!crt_finite(s->f)) { s->status = CRT_NONFINITE; return s->status; }
  s->f_valid = 1;
  if ((int)s->opt[CRT_OPT_METHOD] == CRT_RK4) s->h = s->opt[CRT_OPT_RK4_STEP];
  else if (s->opt[CRT_OPT_H0] > 0.0) s->h = s->opt[CRT_OPT_H0];
  else s->h = crt_first_step(s);
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

/* the scales below which the event search calls a height and a normal speed round-off at
   (t, q): out[0] the height resolution (crt_height_resolution: the integrator's own error in
   Z_C, or round-off), out[1] the speed noise (crt_speed_noise: S touching, not hitting);
   the scales crt_collide judges a touch and a flat landing by, which the driver's
   hand-over records and its judge checks (models with a plane; else 0, 0) */
void crt_eval_noise(crt_session *s, double t, const double *q, double *out)
{
#if MODEL_HAS_PLANE
  out[0] = crt_height_resolution(s, q);
  out[1] = crt_speed_noise(s, t, q);
#else
  (void)s; (void)t; (void)q;
  out[0] = 0.0;
  out[1] = 0.0;
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

#if MODEL_FRICTION
#include "crt_rough_api.h"                /* the friction models' own functions */
#endif

#endif /* CRT_CORE_H */
