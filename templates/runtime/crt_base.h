/*
 * crt_base.h: the loop of the base model (crt_integrate for MODEL_BASE, in crt_loop.h's
 * place): a body on its face that sticks and slips, with exact events (issue 33).
 *
 * Hand-written C: this file is templates/runtime/crt_base.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * Three modes (s->bs.mode):
 *  - rest: the body is at rest at t; sticking holds if the gauge gamma of the wrench the
 *    rest needs (crt_face_gauge, mu_s) is below 1 (or at 1 and not rising); else the slip
 *    starts against the gauge's maximiser, along the stable direction of the slip's flow:
 *    where the flow turns off that direction, along its slow manifold to a twist of 1e-6
 *    v_scale (crt_base_onset_far: the stiff phase of a slip from rest, skipped); else (a
 *    slip along a line, or that start not exact or over an event) by its Taylor series
 *    (twist = G0 d + G1 d^2/2 until it reaches 1e2 eps);
 *  - stick: the state is constant; the event functions 1 - gamma, N, the centre of
 *    pressure's edge margin and (linear pressure) its kern margin are sampled every
 *    opt[CRT_OPT_HMAX]/8 (gamma by the gauge's bounds where they put it below 1 - 1e-3)
 *    and a sign change is located by the Illinois method
 *    (break-away: the slip starts; N: status lift_off; the edge: status tipping; the kern:
 *    status face_lifting);
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
 *    on z, the first step of a slip along a line the last such slip's; the events (t_end,
 *    the stop, N, the edge, the kern) located inside a step on DOP853's dense output
 *    (Illinois on the step's fraction), the state at an event the dense output's there.
 * A run never goes on past lift-off, tipping or the face lifting: it stops there with that
 * status and an event at its time.  The closed loop (crt_set_control) is refused
 * (CRT_BAD_CONTROL).
 */
#ifndef CRT_BASE_H
#define CRT_BASE_H

#include "crt_control.h"
#include "crt_base_steps.h"       /* crt_base_a, crt_base_e5, crt_base_e3: DOP853 */

#define CRT_BASE_NZ (NQ + 1)      /* the slip's state in s: (t, q) */

enum crt_base_mode { CRT_BASE_REST = 0, CRT_BASE_STICK = 1, CRT_BASE_SLIP = 2 };
enum crt_base_event { CRT_BASE_NONE = -1, CRT_BASE_END = 0, CRT_BASE_STOP = 1,
                      CRT_BASE_LIFT = 2, CRT_BASE_TIP = 3, CRT_BASE_KERN = 4 };
#define CRT_BASE_NG 5             /* the slip's event functions */
#define CRT_BASE_NG_STICK 4       /* the stick's: 1 - gamma, N, the edge, the kern */

/* the moments in the face frame at t (summed once per evaluation of the law; the body's
   own when the face frame is the body's) */
static const double *crt_base_u(crt_session *s, double t)
{
  const double *u = crt_u(s, t);
  if (s->bs.body.identity) return u;
  if (s->bs.stamp != s->stat[CRT_STAT_LAW_EVALUATIONS]) {
    crt_base_face_moments(&s->bs.body, u, s->bs.uf);
    s->bs.stamp = s->stat[CRT_STAT_LAW_EVALUATIONS];
  }
  return s->bs.uf;
}

/* dq/dt in slip (crt_eval_rhs, crt_init) */
static void crt_rhs(crt_session *s, double t, const double *q, double *dq)
{
  double N, cp[2];
  ++s->stat[CRT_STAT_RHS_EVALUATIONS];
  crt_base_rates(&s->bs.body, crt_base_u(s, t), q, 0, dq, &N, cp);
}

static void crt_base_line_start(crt_session *s);

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

/* ---- the slip ---------------------------------------------------------------------------- */
/* The slip's scaled twist in the face frame, xi = (v_x, v_y, ell w), at q */
static void crt_base_xi(const crt_base_body *b, const double *q, double *xi)
{
  double sn, cs;
  crt_sincos(q[2], &sn, &cs);
  xi[0] = cs * q[3] + sn * q[4];
  xi[1] = -sn * q[3] + cs * q[4];
  xi[2] = b->ell * q[5];
}

/* The signed speed xi.d at q along the unit direction d (face frame), with sin and cos of
   psi and O's velocity in the face frame (v_x, v_y) */
static double crt_base_speed(const crt_base_body *b, const double *q, const double *d,
                             double *sn, double *cs, double *vx, double *vy)
{
  crt_sincos(q[2], sn, cs);
  *vx = *cs * q[3] + *sn * q[4];
  *vy = -*sn * q[3] + *cs * q[4];
  return *vx * d[0] + *vy * d[1] + b->ell * q[5] * d[2];
}

/* Along the line d at (q, dq): the signed speed xi.d, and how far the flow of xi turns off
   the line, squared, |xi' - (xi'.d) d|^2 / |xi'|^2 (0 when at most 1e-24, xi' = 0 among
   them: the only test is against (1e-12)^2), xi' = (a_f + w (v_y, -v_x), ell w'),
   a_f O's acceleration in the face frame (the frame turns with psi) */
static double crt_base_line_flow(const crt_base_body *b, const double *q, const double *dq,
                                 const double *d, double *speed)
{
  double sn, cs, vx, vy, G[3], along, lat = 0.0, nG = 0.0;
  int i;
  *speed = crt_base_speed(b, q, d, &sn, &cs, &vx, &vy);
  G[0] = cs * dq[3] + sn * dq[4] + q[5] * vy;
  G[1] = -sn * dq[3] + cs * dq[4] - q[5] * vx;
  G[2] = b->ell * dq[5];
  along = G[0] * d[0] + G[1] * d[1] + G[2] * d[2];
  for (i = 0; i < 3; ++i) {
    const double r = G[i] - along * d[i];
    lat += r * r;
    nG += G[i] * G[i];
  }
  return lat > 1e-24 * nG ? lat / nG : 0.0;     /* (a turn below 1e-12: 0, no division) */
}

/* A slip from q starts along one line: its direction xi/|xi| (face frame) */
static void crt_base_line_start(crt_session *s)
{
  double xi[3], n;
  int i;
  crt_base_xi(&s->bs.body, s->q, xi);
  s->bs.fsal = 0;                          /* (the last step's rate: another direction's) */
  n = sqrt(xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]);
  s->bs.line = n > 0.0;
  for (i = 0; i < 3; ++i) s->bs.dir[i] = n > 0.0 ? xi[i] / n : 0.0;
}

/* The slip's rate at z = (t, q), with N, cp and rho.  Along a line (s->bs.line): in t,
   dz/dt = (1, dq/dt) with the friction of the held direction dir (the slip's own while
   xi stays on its line, and smooth through xi = 0), rho the signed speed xi.dir, and
   s->bs.lateral the largest turn of the flow off the line (squared).  Else in s, dz/ds =
   rho (1, dq/dt) with the slip's own friction, rho = |xi|. */
static void crt_base_zrhs(crt_session *s, const double *z, double *dz, double *N, double *cp,
                          double *rho)
{
  double dq[NQ];
  int i;
  ++s->stat[CRT_STAT_RHS_EVALUATIONS];
  if (s->bs.line) {
    double lat;
    crt_base_rates(&s->bs.body, crt_base_u(s, z[0]), z + 1, s->bs.dir, dq, N, cp);
    lat = crt_base_line_flow(&s->bs.body, z + 1, dq, s->bs.dir, rho);
    if (lat > s->bs.lateral) s->bs.lateral = lat;       /* (squared) */
    dz[0] = 1.0;
    for (i = 0; i < NQ; ++i) dz[1 + i] = dq[i];
    return;
  }
  crt_base_rates(&s->bs.body, crt_base_u(s, z[0]), z + 1, 0, dq, N, cp);
  *rho = crt_base_rho(&s->bs.body, z + 1);
  dz[0] = *rho;
  for (i = 0; i < NQ; ++i) dz[1 + i] = *rho * dq[i];
}

/* one DOP853 step of h (in s, or in t along a line) from z0 (f0 its rate): z1, f1 and N,
   cp, rho at z1, the stages in k; returns the error norm (Hairer's: the 5th-order
   estimate, tempered by the 3rd-order one) */
static double crt_base_step(crt_session *s, const double *z0, const double *f0, double h,
                            double (*k)[CRT_BASE_NZ], double *z1, double *f1, double *N,
                            double *cp, double *rho)
{
  double tmp[CRT_BASE_NZ], err3 = 0.0, err5 = 0.0, denom;
  int i, j, st;
  for (i = 0; i < CRT_BASE_NZ; ++i) k[0][i] = f0[i];
  for (st = 1; st < 13; ++st) {            /* the stage 12 is at z1 (FSAL) */
    for (i = 0; i < CRT_BASE_NZ; ++i) {
      double acc = 0.0;
      for (j = 0; j < st; ++j) acc += crt_base_a[st][j] * k[j][i];
      tmp[i] = z0[i] + h * acc;
    }
    crt_base_zrhs(s, tmp, k[st], N, cp, rho);
  }
  for (i = 0; i < CRT_BASE_NZ; ++i) {
    double e3 = 0.0, e5 = 0.0, sc;
    z1[i] = tmp[i];
    f1[i] = k[12][i];
    for (j = 0; j < 13; ++j) {
      e3 += crt_base_e3[j] * k[j][i];
      e5 += crt_base_e5[j] * k[j][i];
    }
    sc = s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * crt_max(fabs(z0[i]), fabs(z1[i]));
    err3 += (e3 / sc) * (e3 / sc);
    err5 += (e5 / sc) * (e5 / sc);
  }
  denom = err5 + 0.01 * err3;            /* (a stage's overflow: NaN, a rejection) */
  if (!(denom - denom == 0.0)) return HUGE_VAL;
  return denom > 0.0 ? fabs(h) * err5 / sqrt(denom * CRT_BASE_NZ) : 0.0;
}

/* DOP853's dense output of the step of h from z0 to z1 (its 13 stages in k): the three
   extra stages, then F (7 rows), z(x) = z0 + x (F0 + (1 - x) (F1 + x (F2 + ...))) */
static void crt_base_dense(crt_session *s, const double *z0, const double *z1, double h,
                           double (*k)[CRT_BASE_NZ], double (*F)[CRT_BASE_NZ])
{
  double tmp[CRT_BASE_NZ], N, cp[2], rho;
  int i, j, st, r;
  for (st = 13; st < 16; ++st) {
    for (i = 0; i < CRT_BASE_NZ; ++i) {
      double acc = 0.0;
      for (j = 0; j < st; ++j) acc += crt_base_a[st][j] * k[j][i];
      tmp[i] = z0[i] + h * acc;
    }
    crt_base_zrhs(s, tmp, k[st], &N, cp, &rho);
  }
  for (i = 0; i < CRT_BASE_NZ; ++i) {
    const double dz = z1[i] - z0[i];
    F[0][i] = dz;
    F[1][i] = h * k[0][i] - dz;
    F[2][i] = 2.0 * dz - h * (k[0][i] + k[12][i]);
    for (r = 0; r < 4; ++r) {
      double acc = 0.0;
      for (j = 0; j < 16; ++j) acc += crt_base_d[r][j] * k[j][i];
      F[3 + r][i] = h * acc;
    }
  }
}

/* z at the fraction x of the step from the dense output */
static void crt_base_interp(const double *z0, double (*F)[CRT_BASE_NZ], double x, double *z)
{
  const double y = 1.0 - x;
  int i;
  for (i = 0; i < CRT_BASE_NZ; ++i)
    z[i] = z0[i] + x * (F[0][i] + y * (F[1][i] + x * (F[2][i] + y * (F[3][i]
           + x * (F[4][i] + y * (F[5][i] + x * F[6][i]))))));
}

/* N below which cp = (the moment)/N is not known (the moment's round-off over N: 1e-9 of
   the weight leaves cp known to about 1e-7 of the face) */
static double crt_base_n_res(const crt_base_body *b)
{
  return 1e-9 * (b->pf[0] + b->pf[1]) * b->pf[5];
}

/* A margin of cp (the edge's, the kern's) as an event function: itself while N is above
   crt_base_n_res, minus the face's size below.  Past N = 0, cp jumps to the other side and
   comes back into the face as |N| grows, so a step that ends past the lift-off would find
   the margin positive at both ends and miss a tip before the lift-off (the moment the face
   must give need not vanish with N: a point moving sideways in a body spinning at w needs
   about 2 mu w z rho'_h, mu the reduced mass); near N = 0 cp is round-off.  A root located
   where N is that small is the lift-off's (cp in the face up to N = 0): crt_base_tie. */
static double crt_base_margin(const crt_base_body *b, double N, double margin)
{
  return N > crt_base_n_res(b) ? margin : -b->face.a;
}

/* 1 if the tip's or the kern's root located where N is N is the lift-off's (see
   crt_base_margin) */
static int crt_base_tie(const crt_base_body *b, double N)
{
  return !(N > crt_base_n_res(b));
}

/* the slip's event functions at a state: t_end - t, the stop (rho - eps in s; along a line
   the signed speed rho), N, the edge margin, the kern margin (linear pressure; 1 under
   uniform pressure: no event) */
static void crt_base_slip_g(const crt_session *s, double t_end, const double *z, double N,
                            const double *cp, double rho, double *g)
{
  g[CRT_BASE_END] = t_end - z[0];
  g[CRT_BASE_STOP] = s->bs.line ? rho : rho - s->bs.eps;
  g[CRT_BASE_LIFT] = N;
  g[CRT_BASE_TIP] = crt_base_margin(&s->bs.body, N, crt_face_edge_margin(&s->bs.body.face,
                                                                              cp[0], cp[1]));
  g[CRT_BASE_KERN] = s->bs.body.linear
      ? crt_base_margin(&s->bs.body, N, crt_face_kern_margin(&s->bs.body.face, cp[0], cp[1]))
      : 1.0;
}

/* The slip's event function k at the state z: the end and the stop from z alone (t; the
   signed speed along a line, |xi| in s: what crt_base_zrhs gives as rho), the others
   (N, the margins of cp) through the slip's rate (dz: its room) */
static double crt_base_slip_g_at(crt_session *s, double t_end, const double *z, int k,
                                 double *dz, double *g)
{
  double N, cp[2], rho;
  if (k == CRT_BASE_END) return t_end - z[0];
  if (k == CRT_BASE_STOP) {
    double sn, cs, vx, vy;
    return s->bs.line ? crt_base_speed(&s->bs.body, z + 1, s->bs.dir, &sn, &cs, &vx, &vy)
                      : crt_base_rho(&s->bs.body, z + 1) - s->bs.eps;
  }
  crt_base_zrhs(s, z, dz, &N, cp, &rho);
  crt_base_slip_g(s, t_end, z, N, cp, rho, g);
  return g[k];
}

/* ---- the rest ------------------------------------------------------------------------------ */
/* the stick's event functions at t (the state is constant): 1 - gamma, N, the edge
   margin, the kern margin (linear pressure, whose slope the gauge reads; else 1).  Where
   the gauge's bounds (crt_face_gauge_bounds) put gamma below 1 - 1e-3, 1 - their upper
   bound (the sign is all a sample needs, and a root is located only where gamma is near
   1: computed there); else the gauge itself, its maximiser in xi.  Under linear pressure
   the upper bound is scaled by the pressure's mean over its least on the face (none where
   the least is 0: the gauge computed). */
static void crt_base_stick_g(crt_session *s, double t, double *g, double *xi)
{
  double W[3], N, cp[2], k[2], lo, hi;
  int part;
  crt_base_rest(&s->bs.body, crt_base_u(s, t), W, &N, cp);
  ++s->stat[CRT_STAT_EVENT_FUNCTION_EVALUATIONS];
  crt_base_slope(&s->bs.body, crt_max(N, 0.0), cp, k);
  crt_face_gauge_bounds(&s->bs.body.face, crt_max(N, 0.0), k, s->bs.body.mu_s, W, &lo, &hi,
                        &part);
  if (hi <= 1.0 - 1e-3) g[0] = 1.0 - hi;
  else g[0] = 1.0 - crt_face_gauge(&s->bs.body.face, crt_max(N, 0.0), k, s->bs.body.mu_s, W,
                                   xi, &s->stat[CRT_STAT_EVENT_FUNCTION_EVALUATIONS]);
  g[1] = N;
  g[2] = crt_base_margin(&s->bs.body, N, crt_face_edge_margin(&s->bs.body.face, cp[0],
                                                                   cp[1]));
  g[3] = s->bs.body.linear
      ? crt_base_margin(&s->bs.body, N, crt_face_kern_margin(&s->bs.body.face, cp[0], cp[1]))
      : 1.0;
}

/* the scaled twist's rate at rest at (t, q) with the friction of the unit direction d */
static void crt_base_flow(crt_session *s, double t, const double *q, const double *d,
                          double *G)
{
  double dq[NQ], N, cp[2], sn, cs;
  crt_base_rates(&s->bs.body, crt_base_u(s, t), q, d, dq, &N, cp);
  ++s->stat[CRT_STAT_RHS_EVALUATIONS];
  crt_sincos(q[2], &sn, &cs);
  G[0] = cs * dq[3] + sn * dq[4];
  G[1] = -sn * dq[3] + cs * dq[4];
  G[2] = s->bs.body.ell * dq[5];
}

/* The flow's part across d in the plane across d (basis e1, e2) */
static void crt_base_across(crt_session *s, double t, const double *q, const double *d,
                            const double *e1, const double *e2, double *p, double *G)
{
  crt_base_flow(s, t, q, d, G);
  p[0] = G[0] * e1[0] + G[1] * e1[1] + G[2] * e1[2];
  p[1] = G[0] * e2[0] + G[1] * e2[1] + G[2] * e2[2];
}

/* The stable direction of the slip's flow at rest at (t, q), from d (in place): where the
   scaled twist's rate G with the friction of d is along d, by Newton's method on G's part
   across d (its 2 x 2 Jacobian by differences of 1e-7 rad), to 1e-12 of mu g (a
   fixed-point iteration diverges there: the part across d varies with d at the rate of
   the friction, mu g, while G is only the small excess of the wrench over the limit
   surface); returns G.d (G in G) */
static double crt_base_stable_dir(crt_session *s, double t, const double *q, double *d,
                                  double *G)
{
  const double scale = 1e-12 * s->bs.body.mu * s->bs.body.pf[5], eta = 1e-7;
  double e1[3], e2[3], p[2], pk[2][2], J[2][2], Gk[3], dk[3], det, x0, x1, n;
  int i, it, k;
  for (it = 0; it < 20; ++it) {
    /* e1, e2: across d (e1 from the axis least along d) */
    const int m = fabs(d[0]) <= fabs(d[1]) && fabs(d[0]) <= fabs(d[2]) ? 0
                  : (fabs(d[1]) <= fabs(d[2]) ? 1 : 2);
    for (i = 0; i < 3; ++i) e1[i] = (i == m) - d[m] * d[i];
    n = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (i = 0; i < 3; ++i) e1[i] /= n;
    e2[0] = d[1] * e1[2] - d[2] * e1[1];
    e2[1] = d[2] * e1[0] - d[0] * e1[2];
    e2[2] = d[0] * e1[1] - d[1] * e1[0];
    crt_base_across(s, t, q, d, e1, e2, p, G);
    if (sqrt(p[0] * p[0] + p[1] * p[1]) <= scale) break;
    for (k = 0; k < 2; ++k) {
      const double *e = k ? e2 : e1;
      for (i = 0; i < 3; ++i) dk[i] = d[i] + eta * e[i];
      crt_base_across(s, t, q, dk, e1, e2, pk[k], Gk);
      J[0][k] = (pk[k][0] - p[0]) / eta;
      J[1][k] = (pk[k][1] - p[1]) / eta;
    }
    det = J[0][0] * J[1][1] - J[0][1] * J[1][0];
    if (!(fabs(det) > 0.0)) break;
    x0 = -(J[1][1] * p[0] - J[0][1] * p[1]) / det;
    x1 = -(-J[1][0] * p[0] + J[0][0] * p[1]) / det;
    n = sqrt(x0 * x0 + x1 * x1);
    if (n > 0.5) { x0 *= 0.5 / n; x1 *= 0.5 / n; }       /* (at most half a radian) */
    for (i = 0; i < 3; ++i) d[i] += x0 * e1[i] + x1 * e2[i];
    n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (i = 0; i < 3; ++i) d[i] /= n;
  }
  if (it == 20) crt_base_flow(s, t, q, d, G);
  return G[0] * d[0] + G[1] * d[1] + G[2] * d[2];
}

/* The start along the slow manifold (crt_base_onset_far) at t0 + u from rest at q0: r(u)
   = int_0^u a* by the 3-point Gauss-Legendre rule (its nodes' directions in dn, rates in
   an, warm from d0), the distance moved int_0^u (u - v) a* d* by the same nodes; q the
   state there with the twist r d (d: the direction at t0 + u, warm from dn[2]; NULL: the
   twist along dn[2]).  Returns r, or 0 where a rate is not positive (no such start). */
static const double crt_base_gx[3] = {0.1127016653792583, 0.5, 0.8872983346207417};
static const double crt_base_gw[3] = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};
static double crt_base_far_at(crt_session *s, double t0, const double *q0, const double *d0,
                              double u, double (*dn)[3], double *an, double *d, double *q)
{
  const double ell = s->bs.body.ell;
  double r = 0.0, moved[3] = {0.0, 0.0, 0.0}, G[3], xi[3], sn, cs;
  int i, j;
  for (j = 0; j < 3; ++j) {
    for (i = 0; i < 3; ++i) dn[j][i] = j ? dn[j - 1][i] : d0[i];
    an[j] = crt_base_stable_dir(s, t0 + crt_base_gx[j] * u, q0, dn[j], G);
    if (!(an[j] > 0.0)) return 0.0;
    r += crt_base_gw[j] * an[j] * u;
    for (i = 0; i < 3; ++i)
      moved[i] += crt_base_gw[j] * u * (1.0 - crt_base_gx[j]) * u * an[j] * dn[j][i];
  }
  if (d) {
    for (i = 0; i < 3; ++i) d[i] = dn[2][i];
    if (!(crt_base_stable_dir(s, t0 + u, q0, d, G) > 0.0)) return 0.0;
  }
  for (i = 0; i < 3; ++i) xi[i] = r * (d ? d[i] : dn[2][i]);
  crt_sincos(q0[2], &sn, &cs);
  for (i = 0; i < NQ; ++i) q[i] = q0[i];
  q[0] += cs * moved[0] - sn * moved[1];
  q[1] += sn * moved[0] + cs * moved[1];
  q[2] += moved[2] / ell;
  crt_sincos(q[2], &sn, &cs);
  q[3] = cs * xi[0] - sn * xi[1];
  q[4] = sn * xi[0] + cs * xi[1];
  q[5] = xi[2] / ell;
  return r;
}

/* The slip from rest at t* = s->t carried to the seed R = CRT_BASE_FAR of v_scale along
   its slow manifold: while |xi| is small the direction relaxes onto the flow's stable
   direction d*(t) at a rate ~ mu g / |xi| (stiff: an explicit step there covers ~4.5 |xi|
   of time, ~2,000 steps from the seed 1e2 eps), so xi = r d*(t) + O(r^2), with r(tau) =
   int_0^tau a*(u) du and a*(u) = G(t* + u, d*(t* + u)).d*(t* + u) the along rate at rest
   (an O(r) lag of the direction behind d* decays at that stiff rate and moves r by O(r^2)
   only).  tau solves r(tau) = R by Newton's method (from the quadratic a0 tau + a1 tau^2
   / 2 = R; crt_base_far_at).  Taken only where it is exact to the tolerance and steps
   over no event: the 2-point Gauss rule's r within atol + rtol R of the 3-point's; N, the
   edge and kern margins positive at the nodes and the end; t* + tau before this call's
   end; the output_dt rows inside (from crt_base_far_at) fitting the buffer.  Else 0 (the
   caller's start at the small seed). */
#define CRT_BASE_FAR 1e-6
static long crt_base_rows_before(const crt_session *s, double until, long cap);
static int crt_base_rows_fit(crt_session *s, const crt_out *o, long n, double *shrink);
static int crt_base_onset_far(crt_session *s, crt_out *o, const double *d0, double a0,
                              double a1)
{
  const double R = CRT_BASE_FAR * s->bs.body.v_scale, t0 = s->t;
  const double tol = s->opt[CRT_OPT_ATOL] + s->opt[CRT_OPT_RTOL] * R;
  double tau = 0.0, d[3], dn[3][3], an[3], G[3], dq[NQ], N, cp[2], r = 0.0, r2, q1[NQ];
  double q0[NQ], shrink;
  int i, j, it;
  const double disc = a0 * a0 + 2.0 * a1 * R;
  if (!(disc >= 0.0) || !(a0 + sqrt(disc) > 0.0)) return 0;
  tau = 2.0 * R / (a0 + sqrt(disc));
  for (i = 0; i < NQ; ++i) q0[i] = s->q[i];
  for (it = 0; it < 12; ++it) {
    double dt;
    if (!(tau > 0.0) || !(t0 + tau < s->bs.t_end)) return 0;
    r = crt_base_far_at(s, t0, q0, d0, tau, dn, an, d, q1);
    if (!(r > 0.0)) return 0;
    crt_base_flow(s, t0 + tau, q0, d, G);
    dt = (R - r) / (G[0] * d[0] + G[1] * d[1] + G[2] * d[2]);
    tau += dt;
    if (fabs(dt) <= 1e-9 * tau) break;    /* (r within ~1e-9 R: below atol) */
  }
  if (it == 12 || !(t0 + tau < s->bs.t_end)) return 0;
  r = crt_base_far_at(s, t0, q0, d0, tau, dn, an, d, q1);
  if (!(r > 0.0)) return 0;
  /* the truncation: the 2-point Gauss rule against the 3-point */
  {
    const double x2[2] = {0.2113248654051871, 0.7886751345948129};
    r2 = 0.0;
    for (j = 0; j < 2; ++j) {
      double dd[3];
      for (i = 0; i < 3; ++i) dd[i] = dn[j][i];
      r2 += 0.5 * crt_base_stable_dir(s, t0 + x2[j] * tau, q0, dd, G) * tau;
    }
    if (!(fabs(r2 - r) <= tol)) return 0;
  }
  /* no event inside: N and the margins at the nodes and at the end (rest's balance with
     the friction of d*: the slip's at r -> 0) */
  for (j = 0; j <= 3; ++j) {
    crt_base_rates(&s->bs.body, crt_base_u(s, t0 + (j < 3 ? crt_base_gx[j] : 1.0) * tau), q0,
                   j < 3 ? dn[j] : d, dq, &N, cp);
    ++s->stat[CRT_STAT_RHS_EVALUATIONS];
    if (!(N > 0.0) || !(crt_face_edge_margin(&s->bs.body.face, cp[0], cp[1]) > 0.0)) return 0;
    if (s->bs.body.linear && !(crt_face_kern_margin(&s->bs.body.face, cp[0], cp[1]) > 0.0))
      return 0;
  }
  /* the output_dt rows inside, from the same series (a run's steps do not depend on its
     grid: derive/runtime/motion.py reruns a run on a finer one) */
  if (!crt_base_rows_fit(s, o, crt_base_rows_before(s, t0 + tau, o->cap), &shrink)) {
    s->bs.full = 0;
    return 0;
  }
  while (s->opt[CRT_OPT_OUTPUT_DT] > 0.0 && s->next_output <= t0 + tau) {
    if (s->next_output < t0 + tau) {
      double qr[NQ], dr[3][3], ar[3];
      const double u = s->next_output - t0;
      if (u > 0.0) crt_base_far_at(s, t0, q0, d0, u, dr, ar, 0, qr);
      crt_emit(o, s->next_output, u > 0.0 ? qr : q0, CRT_ROW_STEP);
    }
    s->out_k += 1.0;
    s->next_output = s->t_first + s->out_k * s->opt[CRT_OPT_OUTPUT_DT];
  }
  for (i = 0; i < NQ; ++i) s->q[i] = q1[i];
  s->t = t0 + tau;
  return 1;
}

/* A slip from rest at s->t against the gauge's maximiser: the stable direction of the
   slip's flow from -xi*, then the start along the slow manifold to a seed of 1e-6 v_scale
   (crt_base_onset_far) where the flow turns off d and that start is exact and steps over
   no event, else the Taylor start
   to 1e2 eps.  0 when no slip starts (the flow points back: the body stays). */
static int crt_base_onset(crt_session *s, crt_out *o)
{
  const double ell = s->bs.body.ell, h = 1e-7 * s->bs.body.t_scale, seed = 1e2 * s->bs.eps;
  double d[3], G[3], Gp[3], Gm[3], a, bb, disc, delta, xi[3], moved[3], sn, cs, across;
  double along, *q = s->q;
  int i;
  for (i = 0; i < 3; ++i) d[i] = -s->bs.xi[i];
  crt_base_stable_dir(s, s->t, q, d, G);
  if (!(G[0] * d[0] + G[1] * d[1] + G[2] * d[2] > 0.0)) {
    for (i = 0; i < 3; ++i) d[i] = -s->bs.xi[i];
    crt_base_flow(s, s->t, q, d, G);
  }
  crt_base_flow(s, s->t + h, q, d, Gp);
  crt_base_flow(s, s->t - h, q, d, Gm);
  a = G[0] * d[0] + G[1] * d[1] + G[2] * d[2];
  bb = 0.0;
  for (i = 0; i < 3; ++i) bb += (Gp[i] - Gm[i]) / (2.0 * h) * d[i];
  disc = a * a + 2.0 * bb * seed;
  if (disc < 0.0 || a + sqrt(crt_max(disc, 0.0)) <= 0.0) return 0;
  /* along a line (the flow at t* +- h along d, as crt_base_line_flow tests it): the slip
     runs in t from the small seed, not stiff; else the start along the slow manifold */
  across = along = 0.0;
  for (i = 0; i < 3; ++i) {
    const double gp = Gp[i] - (Gp[0] * d[0] + Gp[1] * d[1] + Gp[2] * d[2]) * d[i];
    const double gm = Gm[i] - (Gm[0] * d[0] + Gm[1] * d[1] + Gm[2] * d[2]) * d[i];
    across += gp * gp + gm * gm;
    along += Gp[i] * Gp[i] + Gm[i] * Gm[i];
  }
  if (across <= 1e-24 * along || !crt_base_onset_far(s, o, d, a, bb)) {
    delta = 2.0 * seed / (a + sqrt(disc));
    for (i = 0; i < 3; ++i) {
      const double G1 = (Gp[i] - Gm[i]) / (2.0 * h);
      xi[i] = G[i] * delta + G1 * delta * delta / 2.0;
      moved[i] = G[i] * delta * delta / 2.0 + G1 * delta * delta * delta / 6.0;
    }
    crt_sincos(q[2], &sn, &cs);
    q[0] += cs * moved[0] - sn * moved[1];
    q[1] += sn * moved[0] + cs * moved[1];
    q[2] += moved[2] / ell;
    crt_sincos(q[2], &sn, &cs);
    q[3] = cs * xi[0] - sn * xi[1];
    q[4] = sn * xi[0] + cs * xi[1];
    q[5] = xi[2] / ell;
    s->t += delta;
  }
  crt_changed(s);
  s->bs.mode = CRT_BASE_SLIP;
  s->bs.hs = 0.0;
  crt_base_line_start(s);
  return 1;
}

/* stop the run at t with a status and its event */
static void crt_base_end(crt_session *s, crt_out *o, int status, int event, double value)
{
  crt_emit(o, s->t, s->q, CRT_ROW_BEFORE_EVENT);
  crt_event(o, s->t, event, value, 0.0, 0.0, 0.0);
  if (event == CRT_EV_LIFTOFF) ++s->stat[CRT_STAT_LIFTOFFS];
  s->status = status;
}

/* At rest at s->t (after a stop of the slip when after_stop, else at the start): stick,
   or slip off (a slip, or a reversal after a stop), or stop (lift-off, tipping, the face
   lifting). */
static void crt_base_settle(crt_session *s, crt_out *o, int after_stop)
{
  double g[CRT_BASE_NG_STICK], later[CRT_BASE_NG_STICK], xi[3];
  int i, stick;
  crt_base_stick_g(s, s->t, g, s->bs.xi);
  if (g[1] <= 0.0) { crt_base_end(s, o, CRT_LIFT_OFF, CRT_EV_LIFTOFF, g[1]); return; }
  if (crt_base_tie(&s->bs.body, g[1])) {}  /* (cp unknown: N's root is the stick's) */
  else if (g[2] <= 0.0) { crt_base_end(s, o, CRT_TIPPING, CRT_EV_TIPPING, g[2]); return; }
  else if (g[3] <= 0.0) {
    crt_base_end(s, o, CRT_FACE_LIFTING, CRT_EV_FACE_LIFTING, g[3]);
    return;
  }
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
  if (after_stop) {
    crt_event(o, s->t, CRT_EV_STICK, 1.0 - g[0], 0.0, 0.0, 0.0);
    ++s->stat[CRT_STAT_STICKS];
  }
  s->bs.mode = CRT_BASE_STICK;
  s->bs.has_p = 0;
  for (i = 0; i < CRT_BASE_NG_STICK; ++i) s->bs.g[i] = g[i];
}

/* Illinois' root of one of the functions from [x0: g0 > 0] to [x1: g1 <= 0]; eval(k, x)
   gives that function at x */
#define CRT_BASE_ILLINOIS(x0, g0, x1, g1, root, tol, EVAL)                              \
  do {                                                                                 \
    double xa_ = (x0), ga_ = (g0), xb_ = (x1), gb_ = (g1);                             \
    int side_ = 0, it_;                                                                \
    for (it_ = 0; it_ < 100 && xb_ - xa_ > (tol); ++it_) {                             \
      double xm_ = (xa_ * gb_ - xb_ * ga_) / (gb_ - ga_), gm_;                         \
      if (!(xm_ > xa_ && xm_ < xb_)) xm_ = 0.5 * (xa_ + xb_);                          \
      gm_ = EVAL(xm_);                                                                 \
      if (gm_ > 0.0) { xa_ = xm_; ga_ = gm_; if (side_ == 1) gb_ *= 0.5; side_ = 1; }  \
      else { xb_ = xm_; gb_ = gm_; if (side_ == -1) ga_ *= 0.5; side_ = -1; }          \
    }                                                                                  \
    (root) = xb_;                                                                      \
  } while (0)

/* ---- rows every output_dt ---------------------------------------------------------------- */
/* The grid rows out_origin + k output_dt (k >= out_k) before until: how many (up to cap + 1) */
static long crt_base_rows_before(const crt_session *s, double until, long cap)
{
  const double out_dt = s->opt[CRT_OPT_OUTPUT_DT];
  double k = s->out_k;
  long n = 0;
  if (!(out_dt > 0.0)) return 0;
  while (s->out_origin + k * out_dt < until && n <= cap) { ++n; k += 1.0; }
  return n;
}

/* Room for n grid rows and a step's own rows (CRT_MIN_ROWS); else, with the buffer empty,
   0 and the step too long for any buffer (*shrink: the share of it that fits), or 0 and
   *shrink = 1: the step is taken again, the same, once the caller has emptied the buffer
   (s->bs.full ends this call) */
static int crt_base_rows_fit(crt_session *s, const crt_out *o, long n, double *shrink)
{
  const long room = (long)o->cap - (long)o->n - CRT_MIN_ROWS;
  *shrink = 1.0;
  if (n <= room) return 1;
  if (o->n == 0) *shrink = crt_max((double)room, 1.0) / (double)n;
  else s->bs.full = 1;
  return 0;
}

/* The grid rows before until: from the step's dense output (z0, F: t at the row's fraction
   x found by Illinois on t(x), monotone in a step), or the constant state s->q (F = 0); a
   grid time at or before the step's start (a stop's last linear part, a slip's Taylor
   start, 1e-9 s at most) reads its start.  A grid time at until is the step's own row. */
static void crt_base_rows(crt_session *s, crt_out *o, double until, const double *z0,
                          double (*F)[CRT_BASE_NZ])
{
  const double out_dt = s->opt[CRT_OPT_OUTPUT_DT];
  double z[CRT_BASE_NZ];
  if (!(out_dt > 0.0)) return;
  while (s->next_output < until) {
    const double at = s->next_output;
    if (!F) {
      crt_emit(o, at, s->q, CRT_ROW_STEP);
    } else {
      double x = 0.0;
      crt_base_interp(z0, F, 1.0, z);
      if (at > z0[0] && at < z[0]) {
#define CRT_BASE_T_EVAL(x_) (crt_base_interp(z0, F, (x_), z), at - z[0])
        CRT_BASE_ILLINOIS(0.0, at - z0[0], 1.0, at - z[0], x, 1e-15, CRT_BASE_T_EVAL);
#undef CRT_BASE_T_EVAL
      } else if (at >= z[0]) {
        x = 1.0;
      }
      crt_base_interp(z0, F, x, z);
      crt_emit(o, at, z + 1, CRT_ROW_STEP);
    }
    s->out_k += 1.0;
    s->next_output = s->out_origin + s->out_k * out_dt;
  }
  if (s->next_output == until) {
    s->out_k += 1.0;
    s->next_output = s->out_origin + s->out_k * out_dt;
  }
}

/* One sample of the stick: its events located in [t, t + h].  The stick's functions
   (1 - gamma, N, the margins) depend on t alone, and a short excursion of one below 0 (a
   break of a few ms, gamma just past 1 near its maximum) must not fall between two
   samples.  Two rules, from the samples themselves:
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
   A sample is at most opt[CRT_OPT_HMAX]/8 long. */
static void crt_base_stick_step(crt_session *s, crt_out *o, double t_end)
{
  const double hmax = s->opt[CRT_OPT_HMAX] / 8.0;
  double h = crt_min(hmax, t_end - s->t), t1, tol, shrink;
  double g1[CRT_BASE_NG_STICK], xi[3], first = HUGE_VAL, g[CRT_BASE_NG_STICK];
  int k, which = -1, i;
  for (i = 0; i < 3; ++i) xi[i] = s->bs.xi[i];
  if (!s->bs.has_p) {                      /* the previous sample: 1/100 of one earlier */
    s->bs.tp = s->t - 1e-2 * hmax;
    crt_base_stick_g(s, s->bs.tp, s->bs.gp, xi);
    s->bs.has_p = 1;
  }
  for (k = 0; k < CRT_BASE_NG_STICK; ++k) {
    const double r = (s->bs.gp[k] - s->bs.g[k]) / (s->t - s->bs.tp);
    if (s->bs.g[k] > 0.0 && r > 0.0) h = crt_min(h, crt_max(2.0 * s->bs.g[k] / r, 1e-6 * hmax));
  }
  if (!crt_base_rows_fit(s, o, crt_base_rows_before(s, s->t + h, o->cap), &shrink)) {
    if (shrink == 1.0) return;             /* (taken again, the same, with room) */
    h *= shrink;                           /* (no buffer holds its rows: a shorter sample) */
  }
  t1 = s->t + h;
  tol = 1e-15 * crt_max(1.0, fabs(t1)) + 1e-15 * s->bs.body.t_scale;
  crt_base_stick_g(s, t1, g1, xi);
  for (k = 0; k < CRT_BASE_NG_STICK; ++k) {
    double end = t1, gend = g1[k], root;
    if (!(s->bs.g[k] > 0.0)) continue;
    if (gend > 0.0) {                      /* a minimum inside the step: g there */
      const double d1 = (s->bs.g[k] - s->bs.gp[k]) / (s->t - s->bs.tp);
      const double d2 = (g1[k] - s->bs.g[k]) / h, a = (d2 - d1) / (t1 - s->bs.tp);
      const double tv = a > 0.0 ? 0.5 * (s->t + t1) - d2 / (2.0 * a) : s->t;
      if (tv > s->t && tv < t1) {
        double gv[CRT_BASE_NG_STICK], xv[3];
        for (i = 0; i < 3; ++i) xv[i] = xi[i];
        crt_base_stick_g(s, tv, gv, xv);
        end = tv;
        gend = gv[k];
      }
    }
    if (gend <= 0.0) {
#define CRT_BASE_STICK_EVAL(x) (crt_base_stick_g(s, (x), g, xi), g[k])
      CRT_BASE_ILLINOIS(s->t, s->bs.g[k], end, gend, root, tol, CRT_BASE_STICK_EVAL);
#undef CRT_BASE_STICK_EVAL
      if (k == 2 || k == 3) {              /* N there: a tip or the lift-off */
        double gr[CRT_BASE_NG_STICK], xr[3];
        for (i = 0; i < 3; ++i) xr[i] = xi[i];
        crt_base_stick_g(s, root, gr, xr);
        if (crt_base_tie(&s->bs.body, gr[1])) continue;  /* (N's root: located, or later) */
      }
      if (root < first) { first = root; which = k; }
    }
  }
  crt_base_rows(s, o, which < 0 ? t1 : first, 0, 0);
  ++s->stat[CRT_STAT_STEPS];
  if (which < 0) {
    s->bs.tp = s->t;
    for (i = 0; i < CRT_BASE_NG_STICK; ++i) s->bs.gp[i] = s->bs.g[i];
    s->t = t1;
    for (i = 0; i < CRT_BASE_NG_STICK; ++i) s->bs.g[i] = g1[i];
    for (i = 0; i < 3; ++i) s->bs.xi[i] = xi[i];
    crt_emit(o, s->t, s->q, CRT_ROW_STEP);
    return;
  }
  s->t = first;
  crt_base_stick_g(s, s->t, g, s->bs.xi);  /* the maximiser at the event */
  if (which == 1) { crt_base_end(s, o, CRT_LIFT_OFF, CRT_EV_LIFTOFF, g[1]); return; }
  if (which == 2) { crt_base_end(s, o, CRT_TIPPING, CRT_EV_TIPPING, g[2]); return; }
  if (which == 3) { crt_base_end(s, o, CRT_FACE_LIFTING, CRT_EV_FACE_LIFTING, g[3]); return; }
  crt_emit(o, s->t, s->q, CRT_ROW_BEFORE_EVENT);
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
  double g1[CRT_BASE_NG], gt[CRT_BASE_NG], N, cp[2], rho, err, hs, span, first = HUGE_VAL;
  int k_, which = -1, i, dense = 0, same;
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
  if (g0[CRT_BASE_LIFT] <= 0.0) { crt_base_end(s, o, CRT_LIFT_OFF, CRT_EV_LIFTOFF, N); return; }
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
  hs = s->bs.hs;
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
    span = z1[0] - z0[0];
    if (err <= 1.0 && crt_finite(z1 + 1) && span - span == 0.0 && span <= s->opt[CRT_OPT_HMAX])
      break;
    ++s->stat[CRT_STAT_REJECTED];
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
    crt_emit(o, s->t, s->q, CRT_ROW_STEP);
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
    crt_base_end(s, o, CRT_LIFT_OFF, CRT_EV_LIFTOFF, N);
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
    (void)crt_law_next_knot;               /* (a table's cubic pieces join with s'' continuous) */
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
    else if (s->bs.mode == CRT_BASE_STICK) crt_base_stick_step(s, o, t_end);
    else crt_base_slip_step(s, o, t_end);
    if (!crt_finite(s->q)) s->status = CRT_NONFINITE;
  }
  if (s->status == CRT_PAUSED && s->t >= t_end) s->status = CRT_DONE;
}

#endif /* CRT_BASE_H */
