/*
 * crt_rough_modes.h: Coulomb friction at S in persistent contact -- the two modes of the
 * slip (sliding, sticking), the couples of spin friction and rolling resistance (the
 * contact then solved as a wrench), and what the runtime reads of them in contact: the
 * right-hand side (crt_rough_rhs) and the event function (crt_rough_event_value).
 * The friction models only (MODEL_FRICTION, the `rough` model); crt_rough.h builds the
 * contact's events and impacts on it.
 *
 * Hand-written C: this file is templates/runtime/crt_rough_modes.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * ---- The modes (derive/friction.py; the functions from derive/friction_models.py) ------
 * The reaction at S is R = N e_Z + R_t with |R_t| <= mu_f N (mu_f = prm[CRT_P_friction]).
 * In contact (s->phase == CRT_CONTACT) S is held on the plane (h = 0, v_n = 0 after every
 * step, as in smooth contact) in one of two modes (s->fr.mode):
 *   sliding:  R = N (e_Z - mu_f dir), N from dv_n/dt = 0 (model_sliding); dir is the slip's
 *             direction, continued through zero along the reference s->fr.dir within a
 *             step, so that "the slip reaches 0" (v_t . dir = 0) is a sign change the event
 *             search finds; k_f = W_ZZ - mu_f (W_tn, dir) > 0 is checked at the end of each
 *             step (else status painleve);
 *   sticking: v_S = 0 held by R from dv_S/dt = 0 (model_sticking: a solve with W); after
 *             every step the slip's round-off is removed by an impulse at S
 *             (crt_rough_stop_slip).
 * With spin friction or rolling resistance on (s->fr.couples) the reaction is a wrench
 * (R, T) at S and each couple's channel is held or turning as the slip is (the section
 * "spin friction and rolling resistance" below).
 */
#ifndef CRT_ROUGH_MODES_H
#define CRT_ROUGH_MODES_H

#include "crt_plane.h"

/* ---- the session: scales, event rows ----------------------------------------------------- */
static double crt_rough_force_scale(const crt_session *s)
{
  const double g = s->prm[CRT_P_g];
  return (s->prm[CRT_P_M] + s->prm[CRT_P_m]) * (g > 0.0 ? g : 1.0);
}

/* the tolerance of an impact's slip stage */
static double crt_rough_dk_rtol(const crt_session *s)
{
  return crt_max(crt_min(s->opt[CRT_OPT_RTOL], 1e-10), 1e-14);
}

/* the slip's scale, its round-off, its resolution and the speed below which the friction
   keeps its reference (crt_follow_dir) at (t, q): band = (v_scale, v_eps, v_arm, v_freeze) */
static void crt_rough_band(crt_session *s, double t, const double *q, double *band)
{
  const double L = s->opt[CRT_OPT_LENGTH_SCALE], g = s->prm[CRT_P_g];
  const double *vc = q + Q_COM_VELOCITY;
  const double v = sqrt(vc[0] * vc[0] + vc[1] * vc[1] + vc[2] * vc[2])
                   + model_rate(s->prm, crt_u(s, t), q) * L + sqrt((g > 0.0 ? g : 1.0) * L);
  band[0] = v > 0.0 ? v : 1.0;
  band[1] = 1e3 * CRT_EPS * band[0];
  band[2] = crt_max(10.0 * (s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * band[0]), band[1]);
  band[3] = crt_max(sqrt(s->opt[CRT_OPT_RTOL]) * band[0], band[2]);
}

/* the slip's scales, set entering a contact mode (crt_rough_band of the state) */
static void crt_rough_scales(crt_session *s, double t)
{
  const double L = s->opt[CRT_OPT_LENGTH_SCALE];
  double band[4];
  crt_rough_band(s, t, s->q, band);
  s->fr.v_scale = band[0];
  s->fr.v_eps = band[1];
  s->fr.v_arm = band[2];
  s->fr.v_freeze = band[3];
  /* the couples' channels: the same over the length scale */
  s->fr.spin.w_scale = s->fr.roll.w_scale = s->fr.v_scale / L;
  s->fr.spin.w_eps = s->fr.roll.w_eps = s->fr.v_eps / L;
  s->fr.spin.w_arm = s->fr.roll.w_arm = s->fr.v_arm / L;
  s->fr.spin.w_freeze = s->fr.roll.w_freeze = s->fr.v_freeze / L;
}

/* an event row with the friction columns (abi.EVENT_COLUMNS) */
static void crt_rough_event(const crt_session *s, crt_out *o, double t, int kind, double value,
                            double a, double b, double t_accumulation, int mode,
                            const crt_dk_result *dk)
{
  double *row;
  int i;
  if (o->ev_n >= o->ev_cap) return;
  row = o->ev + (long)CRT_EVENT_COLUMNS * o->ev_n;
  for (i = 0; i < CRT_EVENT_COLUMNS; ++i) row[i] = 0.0;
  row[0] = t; row[1] = (double)kind; row[2] = value; row[3] = a; row[4] = b;
  row[5] = t_accumulation; row[6] = (double)mode;
  if (dk != 0) {
    row[7] = dk->P[0]; row[8] = dk->P[1];
    row[9] = dk->v_minus[0]; row[10] = dk->v_minus[1];
    row[11] = dk->v[0]; row[12] = dk->v[1];
    row[13] = dk->work_n; row[14] = dk->work_t;
    row[15] = (double)dk->stage;
  }
  if (mode != CRT_MODE_FLIGHT)
    row[16] = (double)((s->fr.spin.on && s->fr.spin.held) + 2 * (s->fr.roll.on && s->fr.roll.held));
  ++o->ev_n;
}

/* ---- contact: the two modes ---------------------------------------------------------------- */
/* sliding: the direction opposite the friction.  Armed (the slip resolved): the slip's,
   v_t/|v_t|, continued through zero along the reference s->fr.dir (so that the stop of the
   slip is a sign change of v_t . dir); restarting from rest: the reference itself, fixed,
   until the slip is resolved along it (v_t/|v_t| of a slip at round-off would turn the
   friction at random and chatter).  Below v_freeze = sqrt(rtol) times the slip's scale the
   reference too, which follows the slip at the end of every step: the slip's direction
   damps a deviation at the rate |a_t|/|v_t|, which no explicit step survives as the slip
   passes 0; a step there lags the friction's direction by its own turn of the slip. */
static void crt_follow_dir(int armed, double v_freeze, const double *ref, int dim,
                           const double *v, double *dir)
{
  const double rho = dim == 2 ? sqrt(v[0] * v[0] + v[1] * v[1]) : fabs(v[0]);
  if (armed && rho > v_freeze) {
    const double sg = v[0] * ref[0] + (dim == 2 ? v[1] * ref[1] : 0.0) < 0.0 ? -1.0 : 1.0;
    dir[0] = sg * v[0] / rho; dir[1] = dim == 2 ? sg * v[1] / rho : 0.0;
  } else {
    dir[0] = ref[0]; dir[1] = ref[1];
  }
}

static void crt_rough_dir(const crt_session *s, const double *v, double *dir)
{
  crt_follow_dir(s->fr.armed, s->fr.v_freeze, s->fr.dir, 2, v, dir);
}

/* sliding: the slip along the reference over its scale, zero where the slip stops (armed)
   or where a slip restarting from rest turns back against the reference (v_t . dir =
   -v_eps: the friction no longer opposes it); a couple's channel the same in its units */
static double crt_follow_value(int armed, double v_eps, double v_scale, const double *ref,
                               int dim, const double *v)
{
  return (v[0] * ref[0] + (dim == 2 ? v[1] * ref[1] : 0.0) + (armed ? 0.0 : v_eps)) / v_scale;
}

static double crt_rough_slip_value(const crt_session *s, const double *v)
{
  return crt_follow_value(s->fr.armed, s->fr.v_eps, s->fr.v_scale, s->fr.dir, 2, v);
}

/* without couples, a slip restarting from rest (not armed): zero where it reaches
   v_freeze (its direction resolved to sqrt(rtol)), where it is armed along itself
   (crt_rough_transition), in whatever direction it took: the friction then follows the
   slip.  A slip that grows along the reference is armed at the end of its step, as
   before (crt_rough_after_step); one that grows across it, or ends its step against it
   (the sticking reaction turning as it leaves the cone: the slip's acceleration is 0 at
   the onset), was held along the reference to the step's end and never armed, and its
   event (v_t . dir = -v_eps) took a resolved slip for one that stopped and removed it.
   (Armed at twice v_arm, as with couples, a slip's direction is the integrator's error
   as much as the slip's: it turns back, and a slip that starts slowly chatters.) */
static double crt_rough_arm_value(const crt_session *s, const double *v)
{
  return (s->fr.v_freeze - sqrt(v[0] * v[0] + v[1] * v[1])) / s->fr.v_scale;
}

/* ---- spin friction and rolling resistance: the contact as a wrench ---------------------- */
/* With either on (s->fr.couples), the contact's reaction is a wrench w = (R, T) at S (fixed
   axes); u = (v_S, Omega), Omega = A omega, changes as du/dt = a_free + G w
   (model_contact_wrench, derive/friction.py: contact_wrench).  The couple's channels:
   spin (c = 0) is Omega_Z with |T_Z| <= mu_s N, roll (c = 1) is (Omega_X, Omega_Y) with
   |(T_X, T_Y)| <= mu_r N; each is held (its Omega 0, its couple an unknown) or turning
   (its couple -mu_c N along its direction, mu_c its mu_s or mu_r; followed as the slip's is:
   crt_follow_dir). */
typedef struct {
  double w[6];                /* (R, T) at S, fixed axes */
  double u[6];                /* (v_S, Omega) */
  double a[6];                /* du/dt = a_free + G w (crt_wrench_rates_of_u) */
  double N, k, g_zz;          /* N, its coefficient in dv_n/dt (k > 0 needed) and G_ZZ */
} crt_wrench;

static crt_channel *crt_couple(crt_session *s, int c)
{
  return c ? &s->fr.roll : &s->fr.spin;
}

static int crt_couple_first(int c) { return c ? 3 : 5; }
static int crt_couple_dim(int c) { return c ? 2 : 1; }

static double crt_couple_bound(const crt_session *s, int c)
{
  return s->prm[c ? CRT_P_rolling_resistance : CRT_P_spin_friction];
}

static double crt_norm_of(int dim, const double *v)
{
  return dim == 2 ? sqrt(v[0] * v[0] + v[1] * v[1]) : fabs(v[0]);
}

/* The reference of a slip or a channel (ref, dim 2 or 1) moved to its velocity v and
   armed: armed, where v is above eps; not yet, where v is resolved (above arm) along the
   reference.  Returns 1 if it moved. */
static int crt_follow_arm(int *armed, double *ref, int dim, const double *v, double eps,
                          double arm)
{
  const double rho = crt_norm_of(dim, v);
  if (*armed ? rho > eps
             : rho > arm && v[0] * ref[0] + (dim == 2 ? v[1] * ref[1] : 0.0) > 0.0) {
    ref[0] = v[0] / rho; ref[1] = dim == 2 ? v[1] / rho : 0.0;
    *armed = 1;
    return 1;
  }
  return 0;
}

/* The wrench in the mode `mode` of the slip (sliding along dir, or along crt_rough_dir's
   where dir is 0; sticking) and the channels' modes at (t, q), and dq/dt under it (where
   dq is not 0: the events and the mode decisions need the wrench alone).  The
   unknowns are the held components and N, the equations their rates and dv_n/dt, all 0:
   Gaussian elimination in that order (the held block is a principal block of G, positive
   definite: no pivoting), whose last pivot is N's coefficient k. */
typedef struct {
  double G[6][6], a[6];       /* du/dt = a + G w */
  double u[6];                /* (v_S, Omega) */
  double w0[3], Yw[18];       /* omega' = w0 + Yw w (Yw column by column) */
} crt_wrench_terms;

/* the state's side of the wrench equations at (t, q) (model_contact_wrench) */
static void crt_wrench_terms_at(crt_session *s, double t, const double *q,
                                crt_wrench_terms *m)
{
  double g[21];
  double (*G)[6] = m->G;
  model_contact_wrench(s->prm, crt_u(s, t), q, g, m->a, m->u, m->w0, m->Yw);
  /* G from its upper triangle, row by row (written out: the loops cost 4x the stores) */
  G[0][0] = g[0];  G[0][1] = G[1][0] = g[1];  G[0][2] = G[2][0] = g[2];
  G[0][3] = G[3][0] = g[3];  G[0][4] = G[4][0] = g[4];  G[0][5] = G[5][0] = g[5];
  G[1][1] = g[6];  G[1][2] = G[2][1] = g[7];  G[1][3] = G[3][1] = g[8];
  G[1][4] = G[4][1] = g[9];  G[1][5] = G[5][1] = g[10];
  G[2][2] = g[11]; G[2][3] = G[3][2] = g[12]; G[2][4] = G[4][2] = g[13];
  G[2][5] = G[5][2] = g[14];
  G[3][3] = g[15]; G[3][4] = G[4][3] = g[16]; G[3][5] = G[5][3] = g[17];
  G[4][4] = g[18]; G[4][5] = G[5][4] = g[19];
  G[5][5] = g[20];
}

/* the modes' side: the unknowns for the terms m (crt_rough_wrench without the rates) */
static void crt_wrench_solve(crt_session *s, const crt_wrench_terms *m, int mode,
                             const double *dir, crt_wrench *o)
{
  const double mu_f = s->prm[CRT_P_friction];
  double b[6] = {0.0, 0.0, 1.0, 0.0, 0.0, 0.0}, K[7][7], r[7], x[7];
  int idx[7], n = 0, i, j, k, c;
  for (i = 0; i < 6; ++i) o->u[i] = m->u[i];
  if (mode == CRT_MODE_STICKING) { idx[n++] = 0; idx[n++] = 1; }
  else {
    double d[2];
    if (dir != 0) { d[0] = dir[0]; d[1] = dir[1]; } else crt_rough_dir(s, o->u, d);
    b[0] = -mu_f * d[0]; b[1] = -mu_f * d[1];
  }
  for (c = 0; c < 2; ++c) {
    const crt_channel *ch = crt_couple(s, c);
    const int first = crt_couple_first(c), dim = crt_couple_dim(c);
    if (!ch->on) continue;
    if (ch->held) {
      for (i = 0; i < dim; ++i) idx[n++] = first + i;
    } else {
      double d[2];
      crt_follow_dir(ch->armed, ch->w_freeze, ch->dir, dim, o->u + first, d);
      for (i = 0; i < dim; ++i) b[first + i] = -crt_couple_bound(s, c) * d[i];
    }
  }
  idx[n] = 2;
  for (i = 0; i <= n; ++i) {
    const int ri = idx[i];
    double gb = 0.0;
    for (j = 0; j < n; ++j) K[i][j] = m->G[ri][idx[j]];
    for (k = 0; k < 6; ++k) gb += m->G[ri][k] * b[k];
    K[i][n] = gb;
    r[i] = -m->a[ri];
  }
  for (k = 0; k < n; ++k)
    for (i = k + 1; i <= n; ++i) {
      const double f = K[i][k] / K[k][k];      /* (K[i][k] itself is not read again) */
      for (j = k + 1; j <= n; ++j) K[i][j] -= f * K[k][j];
      r[i] -= f * r[k];
    }
  for (i = n; i >= 0; --i) {
    double acc = r[i];
    for (j = i + 1; j <= n; ++j) acc -= K[i][j] * x[j];
    x[i] = acc / K[i][i];
  }
  o->k = K[n][n];
  o->g_zz = m->G[2][2];
  o->N = x[n];
  for (i = 0; i < 6; ++i) o->w[i] = x[n] * b[i];
  for (i = 0; i < n; ++i) o->w[idx[i]] += x[i];
}

/* du/dt = a + G w of a solved wrench (the onset's scan reads it) */
static void crt_wrench_rates_of_u(const crt_wrench_terms *m, crt_wrench *o)
{
  int i, j;
  for (i = 0; i < 6; ++i) {
    double acc = m->a[i];
    for (j = 0; j < 6; ++j) acc += m->G[i][j] * o->w[j];
    o->a[i] = acc;
  }
}

static void crt_rough_wrench(crt_session *s, double t, const double *q, int mode,
                             const double *dir, double *dq, crt_wrench *o)
{
  crt_wrench_terms m;
  crt_wrench_terms_at(s, t, q, &m);
  crt_wrench_solve(s, &m, mode, dir, o);
  if (dq != 0) {          /* omega' = w0 + Yw w, then the rates */
    double wd[3];
    int i, j;
    for (i = 0; i < 3; ++i) {
      double acc = m.w0[i];
      for (j = 0; j < 6; ++j) acc += m.Yw[3 * j + i] * o->w[j];
      wd[i] = acc;
    }
    model_wrench_rates(s->prm, q, wd, o->w, dq);
  }
}

/* the least of the channels' event values: a held one's (mu_c N - |T_c|)/(mu_c F), a turning
   one's crt_follow_value (HUGE_VAL without couples); *which: the channel that gives it */
static double crt_couples_value(crt_session *s, const crt_wrench *w, int *which)
{
  const double F = crt_rough_force_scale(s);
  double g = HUGE_VAL;
  int c;
  for (c = 0; c < 2; ++c) {
    const crt_channel *ch = crt_couple(s, c);
    const int first = crt_couple_first(c), dim = crt_couple_dim(c);
    double gc;
    if (!ch->on) continue;
    if (ch->held) {
      const double mu_c = crt_couple_bound(s, c);
      gc = (mu_c * w->w[2] - crt_norm_of(dim, w->w + first)) / (mu_c * F);
    } else {
      gc = crt_follow_value(ch->armed, ch->w_eps, ch->w_scale, ch->dir, dim, w->u + first);
      if (!ch->armed)          /* resolved: arm it (crt_couples_arm) */
        gc = crt_min(gc, (2.0 * ch->w_arm - crt_norm_of(dim, w->u + first)) / ch->w_scale);
    }
    if (gc < g) { g = gc; *which = c; }
  }
  return g;
}

/* the slip's event value with couples: as crt_rough_event_value's without them */
static double crt_wrench_slip_value(crt_session *s, const crt_wrench *w)
{
  const double F = crt_rough_force_scale(s);
  double g;
  if (s->fr.mode == CRT_MODE_STICKING)
    return (s->prm[CRT_P_friction] * w->w[2] - sqrt(w->w[0] * w->w[0] + w->w[1] * w->w[1]))
           / F;
  g = crt_min(w->N / F, crt_rough_slip_value(s, w->u));
  if (!s->fr.armed)            /* resolved: arm it (crt_couples_arm) */
    g = crt_min(g, (2.0 * s->fr.v_arm - crt_norm_of(2, w->u)) / s->fr.v_scale);
  return g;
}

/* With couples a slip or a channel restarting from rest is armed where it is resolved
   (twice v_arm; an event of the event function), not at the end of the step: the
   friction and the couples then follow their velocities from there on (a step frozen
   along the reference while the slip turns would jump at its end, and a held couple
   with it).  Returns 1 if one was armed. */
static int crt_couples_arm(crt_session *s, const crt_wrench *w)
{
  int c, armed = 0;
  if (s->fr.mode == CRT_MODE_SLIDING && !s->fr.armed)
    armed |= crt_follow_arm(&s->fr.armed, s->fr.dir, 2, w->u, s->fr.v_eps, s->fr.v_arm);
  for (c = 0; c < 2; ++c) {
    crt_channel *ch = crt_couple(s, c);
    if (ch->on && !ch->held && !ch->armed)
      armed |= crt_follow_arm(&ch->armed, ch->dir, crt_couple_dim(c),
                              w->u + crt_couple_first(c), ch->w_eps, ch->w_arm);
  }
  return armed;
}

/* Omega = A omega of the state q */
static void crt_omega_fixed(const double *q, double *Om)
{
  int i, j;
  for (i = 0; i < 3; ++i) {
    double acc = 0.0;
    for (j = 0; j < 3; ++j) acc += q[Q_A + 3 * i + j] * q[Q_OMEGA + j];
    Om[i] = acc;
  }
}

/* channel c's angular velocity set to 0 in q (the components of Omega along the fixed axes
   of the channel removed from omega: the rows of A are those axes in body axes) */
static void crt_couple_stop(double *q, int c)
{
  const int first = crt_couple_first(c) - 3, dim = crt_couple_dim(c);
  double Om[3];
  int i, j;
  crt_omega_fixed(q, Om);
  for (i = first; i < first + dim; ++i)
    for (j = 0; j < 3; ++j) q[Q_OMEGA + j] -= Om[i] * q[Q_A + 3 * i + j];
}

/* The velocity of S (slip and v_n) removed by the impulse P = -W^-1 v_S at S (W the
   Delassus matrix, symmetric positive definite; solved by its adjugate): the reaction's
   own way of holding S, so the energy changes by P . (v_S- + v_S+)/2 = -v_S W^-1 v_S / 2
   (second order in the removed slip: round-off, or the slip a stop leaves across the
   friction's reference) plus the drives' impulsive work (the bodies' rates do not jump),
   which the energy balance books as drive work at events.  V_C alone shifted by -v_S,
   as the runtime did, had changed the energy by -(m+M) V_C . v_S, first order (6.6e-8 J
   at the stick of README's two.toml). */
static void crt_rough_stop_slip(crt_session *s, double t, double *q)
{
  const double *u = crt_u(s, t);
  double w[6], v[3], c[6], P[3], q_plus[NQ], det;
  int i;
  model_delassus(s->prm, u, q, w, v);     /* w: W_XX, W_XY, W_XZ, W_YY, W_YZ, W_ZZ */
  if (s->fr.couples) {
    /* a held couple's channel: an impulse at S would turn it (the wrench's impulse, G
       restricted to the held channels, is not written); V_C alone, as before */
    q[Q_COM_VELOCITY] -= v[0];
    q[Q_COM_VELOCITY + 1] -= v[1];
    return;
  }
  c[0] = w[3] * w[5] - w[4] * w[4]; c[1] = w[2] * w[4] - w[1] * w[5];
  c[2] = w[1] * w[4] - w[2] * w[3]; c[3] = w[0] * w[5] - w[2] * w[2];
  c[4] = w[1] * w[2] - w[0] * w[4]; c[5] = w[0] * w[3] - w[1] * w[1];
  det = w[0] * c[0] + w[1] * c[1] + w[2] * c[2];
  if (!(det > 0.0)) return;               /* not reached: W is positive definite */
  P[0] = -(c[0] * v[0] + c[1] * v[1] + c[2] * v[2]) / det;
  P[1] = -(c[1] * v[0] + c[3] * v[1] + c[4] * v[2]) / det;
  P[2] = -(c[2] * v[0] + c[4] * v[1] + c[5] * v[2]) / det;
  model_apply_impulse(s->prm, u, q, P, q_plus);
  for (i = 0; i < NQ; ++i) q[i] = q_plus[i];
}

/* entering a contact mode with couples: each channel turning along its angular velocity
   where that is resolved (armed), else held with it set to 0 */
static void crt_couples_enter(crt_session *s)
{
  int c;
  for (c = 0; c < 2; ++c) {
    crt_channel *ch = crt_couple(s, c);
    const int first = crt_couple_first(c) - 3, dim = crt_couple_dim(c);
    double Om[3], rho;
    if (!ch->on) continue;
    crt_omega_fixed(s->q, Om);
    rho = crt_norm_of(dim, Om + first);
    if (rho > ch->w_arm) {
      ch->held = 0; ch->armed = 1;
      ch->dir[0] = Om[first] / rho; ch->dir[1] = dim == 2 ? Om[first + 1] / rho : 0.0;
    } else {
      ch->held = 1;
      crt_couple_stop(s->q, c);
    }
  }
}

/* a held channel whose couple is outside its bound turns from rest against it */
static void crt_couples_release(crt_session *s, const crt_wrench *w)
{
  int c;
  for (c = 0; c < 2; ++c) {
    crt_channel *ch = crt_couple(s, c);
    const int first = crt_couple_first(c), dim = crt_couple_dim(c);
    const double Tn = crt_norm_of(dim, w->w + first);
    if (!ch->on || !ch->held || !(Tn > crt_couple_bound(s, c) * w->N)) continue;
    ch->held = 0; ch->armed = 0;
    ch->dir[0] = -w->w[first] / Tn; ch->dir[1] = dim == 2 ? -w->w[first + 1] / Tn : 0.0;
  }
}

/* sliding at (t, q): dq/dt, N and the velocity of S */
static void crt_rough_sliding(crt_session *s, double t, const double *q, double *dq, double *N,
                              double *v)
{
  const double *u = crt_u(s, t);
  double dir[2], v_t[2], a_t[2];
  if (s->fr.couples) {
    crt_wrench w;
    crt_rough_wrench(s, t, q, CRT_MODE_SLIDING, 0, dq, &w);
    *N = w.N;
    v[0] = w.u[0]; v[1] = w.u[1]; v[2] = w.u[2];
    return;
  }
  model_contact_velocity(s->prm, u, q, v);
  crt_rough_dir(s, v, dir);
  model_sliding(s->prm, u, q, s->prm[CRT_P_friction], dir, dq, N, v_t, a_t);
}

/* sticking at (t, q): dq/dt and the reaction R */
static void crt_rough_sticking(crt_session *s, double t, const double *q, double *dq,
                               double *R)
{
  if (s->fr.couples) {
    crt_wrench w;
    crt_rough_wrench(s, t, q, CRT_MODE_STICKING, 0, dq, &w);
    R[0] = w.w[0]; R[1] = w.w[1]; R[2] = w.w[2];
    return;
  }
  model_sticking(s->prm, crt_u(s, t), q, dq, R);
}

/* the right-hand side in contact (crt_contact_rhs) */
static void crt_rough_rhs(crt_session *s, double t, const double *q, double *dq)
{
  if (s->fr.mode == CRT_MODE_STICKING) {
    double R[3];
    crt_rough_sticking(s, t, q, dq, R);
  } else {
    double N, v[3];
    crt_rough_sliding(s, t, q, dq, &N, v);
  }
}

/* The event function in contact (crt_contact_event_value): sticking, (mu_f R_Z - |R_t|)/F, zero
   where R leaves the cone (or R_Z reaches 0 with it); sliding, the least of N/F, of
   crt_rough_slip_value and, restarting from rest, of crt_rough_arm_value: zero at
   lift-off, where the slip reaches 0 or where it reaches v_freeze.  F = (m+M) g. */
static double crt_rough_event_value(crt_session *s, double t, const double *y)
{
  double dq[NQ];
  const double F = crt_rough_force_scale(s);
  ++s->stat[CRT_STAT_EVENT_FUNCTION_EVALUATIONS];
  if (s->fr.couples) {
    /* with couples, also the channels' values (crt_couples_value) */
    crt_wrench w;
    double g;
    int which = 0;
    crt_rough_wrench(s, t, y, s->fr.mode, 0, 0, &w);
    g = crt_wrench_slip_value(s, &w);
    return crt_min(g, crt_couples_value(s, &w, &which));
  }
  if (s->fr.mode == CRT_MODE_STICKING) {
    double R[3];
    model_sticking(s->prm, crt_u(s, t), y, dq, R);
    return (s->prm[CRT_P_friction] * R[2] - sqrt(R[0] * R[0] + R[1] * R[1])) / F;
  } else {
    double N, v[3], g;
    crt_rough_sliding(s, t, y, dq, &N, v);
    g = crt_min(N / F, crt_rough_slip_value(s, v));
    if (!s->fr.armed) g = crt_min(g, crt_rough_arm_value(s, v));
    return g;
  }
}

#endif /* CRT_ROUGH_MODES_H */
