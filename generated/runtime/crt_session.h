/*
 * crt_session.h: the bottom of the runtime -- the session record every stage reads and
 * writes (the caller's memory: crt_sizeof() bytes), the output buffers, and the helpers
 * all stages share: crt_u (what the model's functions read at t: the point law, or the
 * bodies' moments), crt_changed (what was computed from the state is stale), crt_emit and
 * crt_event (an output row, an event row).
 *
 * Hand-written C: this file is templates/runtime/crt_session.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * The runtime is a stack of headers, each including only those below it: none calls a
 * function of one above it (the loop reaches the stages through their hooks, named
 * below).  From the top (each line: the header, what it holds, what it includes):
 *   crt_core.h        the public API and the manual          crt_loop.h (crt_rough_api.h),
 *                                                            or crt_base.h (MODEL_BASE)
 *   crt_base.h        the base model's loop (a body on its   crt_control.h,
 *                     face: stick, slip, their events)       crt_base_steps.h
 *   crt_rough_api.h   the friction models' own functions     crt_rhs.h
 *   crt_loop.h        the loop of crt_advance                crt_events.h, crt_control.h
 *   crt_control.h     the closed loop: calls, pushes, noise  crt_session.h, crt_call.h
 *   crt_events.h      event location and application;        crt_step.h
 *                     hooks crt_events_* (no-ops without the plane)
 *   crt_step.h        the steppers' dispatcher, dense output crt_integrators.h, crt_lie.h
 *   crt_lie.h         the Lie-group methods                  crt_integrators.h
 *   crt_integrators.h RK4, DOPRI5, DOP853                    crt_rhs.h
 *   crt_rhs.h         the right-hand side in either phase    crt_contact.h
 *   crt_contact.h     the contact's variant, chosen once: hooks crt_contact_*
 *                       MODEL_FRICTION:  crt_rough.h        crt_dk.h, crt_rough_modes.h
 *                                        crt_rough_modes.h  crt_plane.h
 *                       MODEL_HAS_PLANE: crt_smooth.h       crt_plane.h
 *                       neither:         (no-ops)           crt_session.h
 *   crt_plane.h       the gap, projection, lift-off          crt_session.h
 *   crt_dk.h          Darboux-Keller's impact, standalone    crt_math.h, crt_abi.h
 *   crt_session.h     this file                              crt_law.h, crt_friction_state.h,
 *                                                            crt_bodies.h (MODEL_MOMENTS),
 *                                                            crt_base_model.h (MODEL_BASE)
 *   crt_bodies.h      the bodies' law summed into moments    crt_law.h, crt_abi.h
 *   crt_base_model.h  the base model's physics (MODEL_BASE)  crt_face.h, crt_abi.h
 *   crt_face.h        friction over a flat face, the gauge   crt_face_rules.h
 *   crt_law.h         the laws of the internal bodies        crt_math.h, crt_abi.h
 *   crt_math.h        max, min, sin and cos                  crt_constants.h
 * and the rendered crt_abi.h, crt_constants.h, crt_rk_steps.h, crt_lie_steps.h,
 * crt_dk_steps.h.  The model's file (model_<kind>.c) defines the model's functions, then
 * includes crt_core.h.
 */
#ifndef CRT_SESSION_H
#define CRT_SESSION_H

#include "crt_abi.h"
#include "crt_law.h"                      /* crt_law, crt_law_work, crt_law_eval */

#define CRT_MAX_STAGES 16
#define CRT_MAX_DENSE 7

#if MODEL_FRICTION
#include "crt_friction_state.h"           /* the type of s->fr: the rough contact's memory */
#endif
#if MODEL_MOMENTS
#include "crt_bodies.h"                   /* crt_moments, crt_bodies_sum: u of the bodies */
#endif
#if MODEL_BASE
#include "crt_base_model.h"               /* crt_base_body: a body on its face */

/* the base model's memory (crt_base.h): the body, its mode, the last gauge's maximiser */
typedef struct {
  crt_base_body body;
  int mode;                               /* rest, stick or slip (crt_base.h) */
  long stamp;                             /* uf: the moments in the face frame of this */
  double uf[MODEL_MOMENTS_COUNT];         /* evaluation of the law (-1: none) */
  double xi[3];                           /* the gauge's last maximiser (a warm start) */
  double g[4];                            /* the stick's event functions at t */
  double tp, gp[4];                       /* and at the previous sample (the stick's rate) */
  int has_p;                              /* 1: tp, gp hold a sample */
  double eps;                             /* the slip ends at rho = eps */
  double hs;                              /* the slip's step in s or t (0: to be chosen) */
  int line;                               /* 1: a slip along one line in t (crt_base.h) */
  double dir[3];                          /* its unit scaled twist, face frame */
  double lateral;                         /* the largest lateral flow of its step */
  double ht;                              /* the last step along a line (0: none yet) */
  int fsal;                               /* 1: the last step's end z, its rate, N, cp */
  double fz[NQ + 1], ff[NQ + 1], fN, fcp[2], frho;   /* and rho (the next step's start) */
  int full;                               /* 1: no room for a step's output_dt rows */
  double t_end;                           /* this crt_integrate's end (the slip's start) */
  int tr_try;                             /* 1: a slip along a line that does not turn:
                                             its exact translation to be tried */
  int turned;                             /* 1: the translation's flow left its line */
  double tr_t0, tr_X[2], tr_P[2], tr_S[2];   /* the translation's start: t, O, momentum,
                                                the moment s (fixed axes), */
  double tr_sz[2], tr_e[2], tr_sc[2];     /* s_z, s_z' there, its friction's direction
                                             (fixed axes), sin and cos of its yaw */
} crt_base_memory;
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
  double next_output;                     /* out_origin + out_k output_dt, no accumulation */
  double out_origin;                      /* t0 + opt[CRT_OPT_OUTPUT_PHASE]: the grid's */
  double out_k;
  int rows_started;                       /* the initial row written (crt_advance's first) */
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
  crt_friction fr;                        /* the rough contact: its mode (crt_rough.h) */
#endif
#if MODEL_MOMENTS
  crt_moments mo;                         /* the bodies' moments at lw.t (crt_bodies.h) */
#endif
#if MODEL_BASE
  crt_base_memory bs;                     /* the base model's (crt_base.h) */
#endif
} crt_session;

/* ---- output buffers ---------------------------------------------------------------------- */
typedef struct {
  double *t;
  double *q;
  int *kind;
  int cap, n;
  double *ev;                              /* rows of CRT_EVENT_COLUMNS */
  int ev_cap, ev_n;
} crt_out;

/* ---- small helpers ---------------------------------------------------------------------- */
static int crt_finite(const double *y)
{
  int i;
  for (i = 0; i < NQ; ++i) {
    if (!(y[i] - y[i] == 0.0)) return 0;  /* NaN or infinity */
  }
  return 1;
}

/* the state changed other than by a step (an event, a projection): what was computed
   from it is stale */
static void crt_changed(crt_session *s)
{
  s->f_valid = 0;
#if MODEL_LIE
  s->lie.valid = 0;
#endif
}

/* the law's own u at t (one point's nine numbers, or every body's: crt_law.h); the last
   evaluation is reused */
static const double *crt_law_u(crt_session *s, double t)
{
  return crt_law_eval(&s->law, &s->lw, t, &s->stat[CRT_STAT_LAW_EVALUATIONS]);
}

/* what the model's functions read at t: the point law (crt_law_u), or, MODEL_MOMENTS, the
   bodies' moments, summed once per evaluation of their law (crt_bodies.h) */
static const double *crt_u(crt_session *s, double t)
{
#if MODEL_MOMENTS
  const double *b = crt_law_u(s, t);
  if (s->mo.stamp != s->stat[CRT_STAT_LAW_EVALUATIONS]) {
    crt_bodies_sum(&s->law, s->prm, b, s->mo.u);
    s->mo.stamp = s->stat[CRT_STAT_LAW_EVALUATIONS];
  }
  return s->mo.u;
#else
  return crt_law_u(s, t);
#endif
}

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

#if MODEL_HAS_PLANE || MODEL_BASE         /* (events happen only on the plane) */
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
#endif

/* What an event due at the start of a step led to (crt_contact_due, crt_events_due): none
   (take the step), or one applied after which the controller of a closed loop is told of
   the impact, entry into contact or lift-off it was, or not. */
enum crt_due { CRT_DUE_NONE = 0, CRT_DUE_TELL = 1, CRT_DUE_SILENT = 2 };

/* the run has had its events: opt[CRT_OPT_MAX_EVENTS] of them (then status
   CRT_MAX_EVENTS), or an event was refused (status < 0) or stopped it (a flat landing) */
static int crt_events_exhausted(crt_session *s)
{
  const double n = (double)(s->stat[CRT_STAT_IMPACTS] + s->stat[CRT_STAT_CONTACTS]
                            + s->stat[CRT_STAT_LIFT_OFFS] + s->stat[CRT_STAT_GRAZES]
                            + s->stat[CRT_STAT_STICKS] + s->stat[CRT_STAT_SLIPS]
                            + s->stat[CRT_STAT_REVERSALS] + s->stat[CRT_STAT_COUPLE_STOPS]
                            + s->stat[CRT_STAT_COUPLE_STARTS]);
  if (s->status < 0) return 1;            /* an event refused (friction: painleve, ...) */
  if (s->status == CRT_FLAT_LANDING) return 1;
  if (n >= s->opt[CRT_OPT_MAX_EVENTS]) {
    s->status = CRT_MAX_EVENTS;
    return 1;
  }
  return 0;
}

#endif /* CRT_SESSION_H */
