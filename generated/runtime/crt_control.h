/*
 * crt_control.h: the loop closed around a run -- a controller that reads the state at
 * every sample and after every event and sets the point's law from then on; impulsive
 * pushes at given times; noise on what the controller reads.  Built on crt_session.h (and
 * the model's model_push); the loop (crt_loop.h) calls it at its stops and after events.
 *
 * Hand-written C: this file is templates/runtime/crt_control.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * ---- Use -----------------------------------------------------------------------------
 * The caller owns a crt_control (crt_control_sizeof() bytes, aligned for a double), fills
 * it with crt_control_setup and hands it to a session with crt_set_control after the law
 * is set (crt_set_law_* takes the loop away: an open-loop law) and before crt_init, which
 * starts the loop (its clock, its noise generator, its pushes) and gives the session the
 * law set before (the law the controller's first call continues).  The session then
 *   - calls the controller once at the start (CRT_CALL_START), at every sample t0 + k
 *     period (CRT_CALL_SAMPLE; period 0: none) and after every impact, entry into
 *     contact and lift-off (CRT_CALL_EVENT, the event's kind in crt_call.event); a step
 *     ends exactly at each sample, so the state the controller reads is the integrator's
 *     own state (plus the noise), not its dense output, and the method restarts there;
 *   - applies each push at its time: the impulse P (fixed axes) at a point of the body
 *     (body axes, from O) by the derived impulse map (model_push: the general, rough
 *     and moments models; others refuse pushes), recorded as a CRT_EV_PUSH event (value
 *     |P|); the controller is not told;
 *   - writes the realised law into the caller's log, rows of CRT_LOG_COLUMNS: the piece's
 *     knot, the start and end of the time it was in use, and its coefficients of x, y, z
 *     (c0 s^3 + c1 s^2 + c2 s + c3, s = t - knot; 4 per coordinate).  When fewer than
 *     CRT_CTL_MAX_KNOTS rows are free, crt_advance returns CRT_PAUSED: read
 *     crt_control_log_count() rows, call crt_control_log_taken, call crt_advance again.
 *     The law before the first change (the one set with crt_set_law_*) is not logged.
 *
 * ---- The controller -------------------------------------------------------------------
 *   int fn(void *ctx, const crt_call *call, int max_knots, int *n_knots, double *knots,
 *          double *coef)
 * reads call (the time, why it is called, the measured state in the model's layout, the
 * law's x, y, z and their first two derivatives at that time) and either returns 0 (the
 * law goes on) or writes a new law from call->t on and returns 1: n_knots knots
 * (2 <= n_knots <= max_knots = CRT_CTL_MAX_KNOTS), knots[0] = call->t < knots[1] < ...,
 * and coef[(n_knots - 1) * 12], the cubic of x, y, z on each interval as in
 * crt_set_law_table.  Beyond the last knot the last cubic goes on.  x and x' go on
 * continuously (the impact map reads x'; x'' may jump): the new law's value and rate at
 * call->t must equal call->u's to 1e-12 relative, else the run stops with
 * CRT_BAD_CONTROL and crt_control_fault says why (as it does for a session whose law is
 * of several bodies, crt_set_law_bodies, when the controller drives none of them: pushes
 * act on it, and call->u holds its first point's nine numbers, zeros where it has none).
 * A controller of several bodies drives up to three of their outputs
 * (crt_control_channels: a point's x, y, z, or up to three rotors' psi): call->u holds
 * theirs, and its law's columns replace them, the other outputs going on.  A
 * negative return stops the run with CRT_STOPPED.  ctx is the controller's own memory
 * (its state, its solver's workspace): the runtime passes it through and never reads it.
 * Nothing is allocated.
 */
#ifndef CRT_CONTROL_H
#define CRT_CONTROL_H

#include "crt_session.h"
#include "crt_call.h"          /* crt_call, crt_controller_fn: the ABI of a controller */

struct crt_control {
  /* set by crt_control_setup */
  crt_controller_fn fn;
  void *ctx;
  double period;                         /* samples every period from t0 (0: none) */
  double noise[4];                       /* std: omega, attitude (rad), com, com_velocity */
  unsigned long long seed;
  const double *pushes;                  /* rows of CRT_PUSH_COLUMNS, by time */
  int n_pushes;
  double *log;                           /* rows of CRT_LOG_COLUMNS */
  int log_cap;
  /* the law set before crt_set_control: the run starts on it */
  crt_law base;
  /* the loop's state, set by crt_init */
  int started;
  int log_n;
  int next_push;
  double t_start, k_sample, next_sample;
  int fault;                             /* enum crt_control_fault of CRT_BAD_CONTROL */
  unsigned long long rng[4];             /* xoshiro256** */
  int spare_valid;
  double spare;                          /* Box-Muller's second deviate */
  int controlled;                        /* the law is the controller's (a buffer) */
  int active;                            /* the buffer the law reads */
  double since;                          /* when the current law was set */
  int n_knots[2];
  double knots[2][CRT_CTL_MAX_KNOTS];
  double coef[2][(CRT_CTL_MAX_KNOTS - 1) * 12];
  double q_meas[NQ];
  /* a law of several bodies (crt_control_channels): the outputs (x, y, z of each point,
     then psi of each rotor, crt_law.h's order) the controller's columns x, y, z drive */
  int n_channels;
  int channels[3];
};

/* ---- noise: xoshiro256** seeded by splitmix64, Gaussian deviates by Box-Muller -------- */
static unsigned long long crt_rotl(unsigned long long x, int k)
{
  return (x << k) | (x >> (64 - k));
}

static void crt_rng_seed(crt_control *c, unsigned long long seed)
{
  int i;
  for (i = 0; i < 4; ++i) {
    unsigned long long z = (seed += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    c->rng[i] = z ^ (z >> 31);
  }
  c->spare_valid = 0;
}

/* uniform in (0, 1): the top 53 bits of xoshiro256**, never 0 */
static double crt_rng_uniform(crt_control *c)
{
  unsigned long long *s = c->rng;
  const unsigned long long result = crt_rotl(s[1] * 5, 7) * 9, t = s[1] << 17;
  s[2] ^= s[0];
  s[3] ^= s[1];
  s[1] ^= s[2];
  s[0] ^= s[3];
  s[2] ^= t;
  s[3] = crt_rotl(s[3], 45);
  return ((double)(result >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

static double crt_rng_normal(crt_control *c)
{
  double r, a;
  if (c->spare_valid) {
    c->spare_valid = 0;
    return c->spare;
  }
  r = sqrt(-2.0 * log(crt_rng_uniform(c)));
  a = 6.283185307179586 * crt_rng_uniform(c);
  c->spare = r * sin(a);
  c->spare_valid = 1;
  return r * cos(a);
}

/* What the controller reads: the state with noise of the given standard deviations on
   the attitude (A -> A exp(d^), d of that deviation per body axis; the vertical model's n
   as the third row of such an A), omega, the position and the velocity of C.  Every call
   draws the same twelve deviates whatever the deviations, so a run's noise is its seed's. */
static void crt_control_measure(crt_control *c, const double *q, double *qm)
{
  double d[3], R[9], th, a, b;
  int i, j, k;
  for (i = 0; i < NQ; ++i) qm[i] = q[i];
  for (i = 0; i < 3; ++i) d[i] = c->noise[1] * crt_rng_normal(c);
  th = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  /* Rodrigues: exp(d^) = 1 + a d^ + b d^ d^, a = sin(th)/th, b = (1 - cos(th))/th^2 */
  a = th > 1e-4 ? sin(th) / th : 1.0 - th * th / 6.0;
  b = th > 1e-4 ? (1.0 - cos(th)) / (th * th) : 0.5 - th * th / 24.0;
  R[0] = 1.0 - b * (d[1] * d[1] + d[2] * d[2]);
  R[4] = 1.0 - b * (d[0] * d[0] + d[2] * d[2]);
  R[8] = 1.0 - b * (d[0] * d[0] + d[1] * d[1]);
  R[1] = -a * d[2] + b * d[0] * d[1];
  R[3] = a * d[2] + b * d[0] * d[1];
  R[2] = a * d[1] + b * d[0] * d[2];
  R[6] = -a * d[1] + b * d[0] * d[2];
  R[5] = -a * d[0] + b * d[1] * d[2];
  R[7] = a * d[0] + b * d[1] * d[2];
  (void)j; (void)k; (void)R;
#if defined(Q_A)
  for (i = 0; i < 3; ++i)
    for (j = 0; j < 3; ++j) {
      double acc = 0.0;
      for (k = 0; k < 3; ++k) acc += q[Q_A + 3 * i + k] * R[3 * k + j];
      qm[Q_A + 3 * i + j] = acc;
    }
#elif defined(Q_N)
  for (j = 0; j < 3; ++j) {
    double acc = 0.0;
    for (k = 0; k < 3; ++k) acc += q[Q_N + k] * R[3 * k + j];
    qm[Q_N + j] = acc;
  }
#endif
  for (i = 0; i < 3; ++i) {
    const double w = c->noise[0] * crt_rng_normal(c);
    const double r = c->noise[2] * crt_rng_normal(c);
    const double v = c->noise[3] * crt_rng_normal(c);
    (void)w; (void)r; (void)v;
#if defined(Q_OMEGA)
    qm[Q_OMEGA + i] += w;
#endif
#if defined(Q_COM)
    qm[Q_COM + i] += r;
    qm[Q_COM_VELOCITY + i] += v;
#elif defined(Q_Z)
    if (i == 2) {
      qm[Q_Z] += r;
      qm[Q_ZD] += v;
    }
#endif
  }
}

/* ---- the law ------------------------------------------------------------------------- */
/* The pieces of the controller's law in use over [c->since, t] into the log. */
static void crt_control_log_law(crt_control *c, double t)
{
  const int b = c->active, n = c->n_knots[b];
  int i, k;
  if (!c->controlled || !(t > c->since)) return;
  for (i = 0; i < n - 1; ++i) {
    const double lo = crt_max(c->since, c->knots[b][i]);
    const double hi = i == n - 2 ? t : crt_min(t, c->knots[b][i + 1]);
    double *row;
    if (!(hi > lo) || c->log_n >= c->log_cap) continue;
    row = c->log + (long)CRT_LOG_COLUMNS * c->log_n++;
    row[0] = c->knots[b][i];
    row[1] = lo;
    row[2] = hi;
    for (k = 0; k < 12; ++k) row[3 + k] = c->coef[b][12 * i + k];
  }
  c->since = t;
}

/* The controller's new law (in the buffer not in use) checked and made the session's:
   0, or CRT_BAD_CONTROL with c->fault saying why. */
static int crt_control_install(crt_session *s, double t, const double *u, int n)
{
  crt_control *c = s->ctl;
  const int b = 1 - c->active;
  const double *knots = c->knots[b], *coef = c->coef[b];
  int i;
  if (c->base.kind == CRT_LAW_BODIES && c->n_channels == 0) {
    c->fault = CRT_FAULT_BODIES;
    return CRT_BAD_CONTROL;
  }
  if (n < 2 || n > CRT_CTL_MAX_KNOTS) { c->fault = CRT_FAULT_KNOT_COUNT; return CRT_BAD_CONTROL; }
  if (knots[0] != t) { c->fault = CRT_FAULT_FIRST_KNOT; return CRT_BAD_CONTROL; }
  for (i = 1; i < n; ++i)
    if (!(knots[i] > knots[i - 1]) || !(knots[i] - knots[i] == 0.0)) {
      c->fault = CRT_FAULT_KNOT_ORDER;
      return CRT_BAD_CONTROL;
    }
  for (i = 0; i < (n - 1) * 12; ++i)
    if (!(coef[i] - coef[i] == 0.0)) { c->fault = CRT_FAULT_NONFINITE; return CRT_BAD_CONTROL; }
  for (i = 0; i < 3; ++i) {
    /* the first cubic at s = 0: value c3, rate c2 */
    const double x = coef[4 * i + 3], v = coef[4 * i + 2];
    if (fabs(x - u[i]) > 1e-12 * (1.0 + fabs(u[i]) + s->opt[CRT_OPT_LENGTH_SCALE])) {
      c->fault = CRT_FAULT_POSITION_JUMP;
      return CRT_BAD_CONTROL;
    }
    if (fabs(v - u[3 + i]) > 1e-12 * (1.0 + fabs(u[3 + i]))) {
      c->fault = CRT_FAULT_VELOCITY_JUMP;
      return CRT_BAD_CONTROL;
    }
  }
  crt_control_log_law(c, t);
  c->active = b;
  c->n_knots[b] = n;
  c->controlled = 1;
  c->since = t;
  if (c->base.kind == CRT_LAW_BODIES) {   /* the bodies' law, the driven outputs its */
    s->law = c->base;
    s->law.ctl_n_knots = n;
    s->law.ctl_knots = c->knots[b];
    s->law.ctl_coef = c->coef[b];
    for (i = 0; i < 3; ++i) s->law.ctl_out[i] = i < c->n_channels ? c->channels[i] : -1;
  } else {
    s->law.kind = CRT_LAW_TABLE;
    s->law.n_knots = n;
    s->law.knots = c->knots[b];
    s->law.coef = c->coef[b];
    s->law.periodic = 0;
    s->law.extend = 1;
  }
  crt_law_prepare(&s->law, &s->lw);
  s->lw.valid = 0;
  ++s->stat[CRT_STAT_LAW_CHANGES];
  return 0;
}

/* Call the controller at s->t (reason, event); its law installed.  Returns 0 to go on,
   else the status that stops the run (CRT_STOPPED, CRT_BAD_CONTROL). */
static int crt_control_call(crt_session *s, int reason, int event)
{
  crt_control *c = s->ctl;
  crt_call call;
  double u[9];
  int i, n = 0, r;
  const double *ul = crt_law_u(s, s->t);
  const int width = crt_law_u_width(&s->law);  /* a law of several bodies: its first nine */
  if (c->n_channels > 0) {                     /* or the outputs the controller drives */
    const int np = s->law.n_points;
    for (i = 0; i < 9; ++i) u[i] = 0.0;
    for (i = 0; i < c->n_channels; ++i) {
      const int o = c->channels[i];
      const int at = o < 3 * np ? 9 * (o / 3) + o % 3 : 9 * np + 3 * (o - 3 * np);
      const int step = o < 3 * np ? 3 : 1;
      if (o < 0) continue;
      u[i] = ul[at];
      u[3 + i] = ul[at + step];
      u[6 + i] = ul[at + 2 * step];
    }
  } else {
    for (i = 0; i < 9; ++i) u[i] = i < width ? ul[i] : 0.0;
  }
  crt_control_measure(c, s->q, c->q_meas);
  call.t = s->t;
  call.reason = reason;
  call.event = event;
  call.nq = NQ;
  call.q = c->q_meas;
  call.u = u;
  call.k = s->stat[CRT_STAT_CONTROLLER_CALLS]++;
  r = c->fn(c->ctx, &call, CRT_CTL_MAX_KNOTS, &n, c->knots[1 - c->active],
            c->coef[1 - c->active]);
  if (r < 0) return CRT_STOPPED;
  if (r == 0) return 0;
  r = crt_control_install(s, s->t, u, n);
  if (r) return r;
  /* the method restarts on the new law */
  crt_changed(s);
  s->g_valid = 0;
  s->err_old = 1e-4;
  return 0;
}

/* ---- the loop's clock ------------------------------------------------------------------ */
/* crt_init's part: the loop starts at t0 on the law set before */
static void crt_control_start(crt_session *s, double t0)
{
  crt_control *c = s->ctl;
  c->started = 0;
  c->log_n = 0;
  c->next_push = 0;
  while (c->next_push < c->n_pushes
         && c->pushes[(long)CRT_PUSH_COLUMNS * c->next_push] < t0) ++c->next_push;
  c->t_start = t0;
  c->k_sample = 1.0;
  c->next_sample = c->period > 0.0 ? t0 + c->period : HUGE_VAL;
  c->fault = 0;
  crt_rng_seed(c, c->seed);
  c->controlled = 0;
  c->active = 0;
  c->since = t0;
  s->law = c->base;
  crt_law_prepare(&s->law, &s->lw);
  s->lw.valid = 0;
}

/* the next time a step must end at: a sample or a push (HUGE_VAL: none) */
static double crt_control_next_stop(const crt_session *s)
{
  const crt_control *c = s->ctl;
  double t = c->next_sample;
  if (c->next_push < c->n_pushes)
    t = crt_min(t, c->pushes[(long)CRT_PUSH_COLUMNS * c->next_push]);
  return t;
}

#if MODEL_PUSH
static void crt_control_push(crt_session *s, crt_out *o, const double *row)
{
  double q_plus[NQ], P = sqrt(row[1] * row[1] + row[2] * row[2] + row[3] * row[3]);
  int i;
  crt_emit(o, s->t, s->q, CRT_ROW_BEFORE_EVENT);
  model_push(s->prm, crt_u(s, s->t), s->q, row + 4, row + 1, q_plus);
  for (i = 0; i < NQ; ++i) s->q[i] = q_plus[i];
#if MODEL_HAS_PLANE
  s->phase = CRT_FLIGHT;                   /* an impulse in contact: the gap decides next */
#endif
  crt_emit(o, s->t, s->q, CRT_ROW_AFTER_EVENT);
  crt_event(o, s->t, CRT_EV_PUSH, P, 0.0, 0.0, 0.0);
  ++s->stat[CRT_STAT_PUSHES];
  s->last_event_t = -HUGE_VAL;             /* a collision may follow at this very time */
  crt_changed(s);
  s->g_valid = 0;
  s->err_old = 1e-4;
}
#endif

/* A step ended at a stop of the loop: the pushes due, then the sample.  ``due``: the time
   up to which a stop is now (s->t and the loop's least step: a sample k period after the
   start can round to an ulp past a push the user put at the same time; left for later,
   it asked a step of 1e-16 s and stopped the run, step_underflow).  Returns 0 to go on,
   else the status that stops the run. */
static int crt_control_at_stop(crt_session *s, crt_out *o, double due)
{
  crt_control *c = s->ctl;
  while (c->next_push < c->n_pushes
         && c->pushes[(long)CRT_PUSH_COLUMNS * c->next_push] <= due) {
#if MODEL_PUSH
    crt_control_push(s, o, c->pushes + (long)CRT_PUSH_COLUMNS * c->next_push);
#else
    (void)o;
#endif
    ++c->next_push;
  }
  if (c->next_sample <= due) {
    c->k_sample += 1.0;
    c->next_sample = c->t_start + c->k_sample * c->period;   /* no accumulation */
    return crt_control_call(s, CRT_CALL_SAMPLE, 0);
  }
  return 0;
}

/* After an event handled at s->t (counters before it in before[]): the controller is
   called after an impact (or the entry into contact it led to) and a lift-off. */
static int crt_control_after_event(crt_session *s, const long *before)
{
  int kind = 0;
  if (s->stat[CRT_STAT_CONTACTS] > before[0]) kind = CRT_EV_CONTACT;
  else if (s->stat[CRT_STAT_IMPACTS] > before[1]) kind = CRT_EV_IMPACT;
  else if (s->stat[CRT_STAT_LIFT_OFFS] > before[2]) kind = CRT_EV_LIFT_OFF;
  if (!kind) return 0;
  return crt_control_call(s, CRT_CALL_EVENT, kind);
}

static void crt_control_counters(const crt_session *s, long *before)
{
  before[0] = s->stat[CRT_STAT_CONTACTS];
  before[1] = s->stat[CRT_STAT_IMPACTS];
  before[2] = s->stat[CRT_STAT_LIFT_OFFS];
}

/* ---- the public API of the loop -------------------------------------------------------- */
int crt_control_sizeof(void) { return (int)sizeof(crt_control); }

/* Fill a crt_control: the controller fn (called with ctx), the sample period (0: events
   only), the noise's standard deviations noise[4] (omega, attitude in rad, com,
   com_velocity; NULL: none) and its seed, the pushes (n_pushes rows of CRT_PUSH_COLUMNS:
   time, P_X, P_Y, P_Z, at_x, at_y, at_z, by increasing time; kept by pointer) and the log
   (log_cap rows of CRT_LOG_COLUMNS, at least 2 CRT_CTL_MAX_KNOTS).  Returns CRT_OK or
   CRT_BAD_ARGUMENT. */
int crt_control_setup(crt_control *c, crt_controller_fn fn, void *ctx, double period,
                      const double *noise, double seed, const double *pushes, int n_pushes,
                      double *log, int log_cap)
{
  int i;
  c->fn = fn;
  c->ctx = ctx;
  c->period = period;
  for (i = 0; i < 4; ++i) c->noise[i] = noise ? noise[i] : 0.0;
  c->seed = (unsigned long long)(seed >= 0.0 && seed < 1.8e19 ? seed : 0.0);
  c->pushes = pushes;
  c->n_pushes = n_pushes;
  c->log = log;
  c->log_cap = log_cap;
  c->log_n = 0;
  c->started = 0;
  c->controlled = 0;
  c->n_channels = 0;
  if (!fn || !(period >= 0.0) || period - period != 0.0 || n_pushes < 0
      || (n_pushes > 0 && !pushes) || !log || log_cap < 2 * CRT_CTL_MAX_KNOTS)
    return CRT_BAD_ARGUMENT;
  for (i = 0; i < 4; ++i)
    if (!(c->noise[i] >= 0.0) || c->noise[i] - c->noise[i] != 0.0) return CRT_BAD_ARGUMENT;
  for (i = 0; i < n_pushes; ++i) {
    const double *row = pushes + (long)CRT_PUSH_COLUMNS * i;
    int k;
    for (k = 0; k < CRT_PUSH_COLUMNS; ++k)
      if (row[k] - row[k] != 0.0) return CRT_BAD_ARGUMENT;
    if (i > 0 && row[0] < row[-CRT_PUSH_COLUMNS]) return CRT_BAD_ARGUMENT;
  }
  if (n_pushes > 0 && !MODEL_PUSH) return CRT_BAD_ARGUMENT;
  return CRT_OK;
}

/* A law of several bodies (crt_set_law_bodies): the controller's columns x, y, z drive
   outputs outputs[0..n-1] of it (x, y, z of point j are 3 j, 3 j + 1, 3 j + 2; psi of
   rotor r is 3 n_points + r; -1: the column drives none), n at most 3: call->u holds
   their values and two derivatives as a point's (x at u[c], x' at u[3 + c], x'' at
   u[6 + c]), and a law the controller sets replaces them, the other outputs going on.
   After crt_control_setup, before crt_set_control (which checks them against the law).
   CRT_OK or CRT_BAD_ARGUMENT. */
int crt_control_channels(crt_control *c, int n, const int *outputs)
{
  int i;
  if (n < 0 || n > 3 || (n > 0 && !outputs)) return CRT_BAD_ARGUMENT;
  for (i = 0; i < n; ++i)
    if (outputs[i] < -1) return CRT_BAD_ARGUMENT;
  c->n_channels = n;
  for (i = 0; i < 3; ++i) c->channels[i] = i < n ? outputs[i] : -1;
  return CRT_OK;
}

/* Close the loop of a session (after its law is set; c == NULL opens it again).  The
   session gets back the law set before the loop it had (a run leaves it reading the
   controller's buffers): call crt_set_control(s, NULL) before the crt_control's memory
   goes, if the session is to run again. */
int crt_set_control(crt_session *s, crt_control *c)
{
  if (s->ctl && s->ctl->controlled) {
    s->law = s->ctl->base;
    crt_law_prepare(&s->law, &s->lw);
    s->lw.valid = 0;
  }
  s->ctl = c;
  if (c) {
    /* a law of several bodies (the moments models) runs under a loop of pushes; a
       controller's law is refused on it (CRT_FAULT_BODIES) */
    if (s->law.kind != CRT_LAW_PROGRAM && s->law.kind != CRT_LAW_TABLE
        && !(MODEL_MOMENTS && s->law.kind == CRT_LAW_BODIES))
      return CRT_BAD_LAW;
    if (c->n_channels > 0) {             /* channels: outputs of a law of bodies */
      int i;
      if (s->law.kind != CRT_LAW_BODIES) return CRT_BAD_LAW;
      for (i = 0; i < c->n_channels; ++i)
        if (c->channels[i] >= 3 * s->law.n_points + s->law.n_rotors) return CRT_BAD_LAW;
    }
    c->base = s->law;
  }
  return CRT_OK;
}

int crt_control_log_count(const crt_control *c) { return c->log_n; }

void crt_control_log_taken(crt_control *c) { c->log_n = 0; }

int crt_control_fault(const crt_control *c) { return c->fault; }

#endif /* CRT_CONTROL_H */
