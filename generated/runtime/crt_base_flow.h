/*
 * crt_base_flow.h: the base model's flow (a body on its face, issue 33), below its loop in
 * crt_base.h: the moments at t and the planar right-hand side, the slip's twist and its
 * flow in t along a line or in arc time, its DOP853 step (the tableau of crt_base_steps.h)
 * and dense output, the event functions of the slip and of the rest, the slip's start from
 * rest (its stable direction, the Taylor start and the start along the slow manifold), the
 * Illinois root and the rows every output_dt.  crt_base.h's header comment says how the
 * modes use them.
 *
 * Hand-written C: this file is templates/runtime/crt_base_flow.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_BASE_FLOW_H
#define CRT_BASE_FLOW_H

#include "crt_control.h"
#include "crt_base_steps.h"       /* crt_base_a, crt_base_e5, crt_base_e3: DOP853 */

#define CRT_BASE_NZ (NQ + 1)      /* the slip's state in s: (t, q) */

enum crt_base_mode { CRT_BASE_REST = 0, CRT_BASE_STICK = 1, CRT_BASE_SLIP = 2,
                     CRT_BASE_TRANSLATION = 3 };
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
   psi (sc: given; NULL: computed) and O's velocity in the face frame (v_x, v_y) */
static double crt_base_speed(const crt_base_body *b, const double *q, const double *d,
                             const double *sc, double *sn, double *cs, double *vx, double *vy)
{
  if (sc) { *sn = sc[0]; *cs = sc[1]; }
  else crt_sincos(q[2], sn, cs);
  *vx = *cs * q[3] + *sn * q[4];
  *vy = -*sn * q[3] + *cs * q[4];
  return *vx * d[0] + *vy * d[1] + b->ell * q[5] * d[2];
}

/* Along the line d at (q, dq): the signed speed xi.d, and how far the flow of xi turns off
   the line, squared, |xi' - (xi'.d) d|^2 / |xi'|^2 (0 when at most 1e-24, xi' = 0 among
   them: the only test is against (1e-12)^2), xi' = (a_f + w (v_y, -v_x), ell w'),
   a_f O's acceleration in the face frame (the frame turns with psi); sc: sin and cos of
   psi where known (the translation's, held), else NULL */
static double crt_base_line_flow(const crt_base_body *b, const double *q, const double *dq,
                                 const double *d, const double *sc, double *speed)
{
  double sn, cs, vx, vy, G[3], along, lat = 0.0, nG = 0.0;
  int i;
  *speed = crt_base_speed(b, q, d, sc, &sn, &cs, &vx, &vy);
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
  s->bs.tr_try = s->bs.line && fabs(s->bs.dir[2]) <= 1e-12;  /* (crt_base_tr_start) */
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
    lat = crt_base_line_flow(&s->bs.body, z + 1, dq, s->bs.dir, 0, rho);
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

/* a stage's state z0 + h sum_j a[st][j] k[j] (j < st): each component's sum in the order
   of j, the same operations as a sum per component (the crawler's run compared: the
   same bit for bit), with the components side by side in the inner loop, which the
   compiler vectorises (that run 3 to 4 % faster) */
static void crt_base_stage(const double *z0, double h, double (*k)[CRT_BASE_NZ], int st,
                           double *tmp)
{
  double acc[CRT_BASE_NZ];
  int i, j;
  for (i = 0; i < CRT_BASE_NZ; ++i) acc[i] = 0.0;
  for (j = 0; j < st; ++j) {
    const double a = crt_base_a[st][j];
    for (i = 0; i < CRT_BASE_NZ; ++i) acc[i] += a * k[j][i];
  }
  for (i = 0; i < CRT_BASE_NZ; ++i) tmp[i] = z0[i] + h * acc[i];
}

/* one DOP853 step of h (in s, or in t along a line) from z0 (f0 its rate): z1, f1 and N,
   cp, rho at z1, the stages in k; returns the error norm (Hairer's: the 5th-order
   estimate, tempered by the 3rd-order one), each component of z against atol + rtol
   max(|z0|, |z1|, its least scale): O's position at least the face's size ell, its
   velocity at least v_scale (zscale).  Where O stands is the origin's choice, not the
   body's: held to its own coordinates, a body near the origin was held to atol alone,
   1e-12 m, where the flight's Lie steps hold the attitude to atol + rtol radians
   (crt_lie.h; derive bench base's crawler: 4209 evaluations of the rates, 3249 at the
   body's scale).  t, psi and psi' keep atol + rtol max(|z0|, |z1|). */
static double crt_base_step(crt_session *s, const double *z0, const double *f0, double h,
                            double (*k)[CRT_BASE_NZ], double *z1, double *f1, double *N,
                            double *cp, double *rho)
{
  const double *zscale = s->bs.body.zscale;
  double tmp[CRT_BASE_NZ], err3 = 0.0, err5 = 0.0, denom;
  int i, j, st;
  for (i = 0; i < CRT_BASE_NZ; ++i) k[0][i] = f0[i];
  for (st = 1; st < 13; ++st) {            /* the stage 12 is at z1 (FSAL) */
    crt_base_stage(z0, h, k, st, tmp);
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
    sc = s->opt[CRT_OPT_ATOL]
         + s->opt[CRT_OPT_RTOL] * crt_max(crt_max(fabs(z0[i]), fabs(z1[i])), zscale[i]);
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
    crt_base_stage(z0, h, k, st, tmp);
    crt_base_zrhs(s, tmp, k[st], &N, cp, &rho);
  }
  for (i = 0; i < CRT_BASE_NZ; ++i) {
    const double dz = z1[i] - z0[i];
    F[0][i] = dz;
    F[1][i] = h * k[0][i] - dz;
    F[2][i] = 2.0 * dz - h * (k[0][i] + k[12][i]);
  }
  for (r = 0; r < 4; ++r) {
    double acc[CRT_BASE_NZ];
    for (i = 0; i < CRT_BASE_NZ; ++i) acc[i] = 0.0;
    for (j = 0; j < 16; ++j)
      for (i = 0; i < CRT_BASE_NZ; ++i) acc[i] += crt_base_d[r][j] * k[j][i];
    for (i = 0; i < CRT_BASE_NZ; ++i) F[3 + r][i] = h * acc[i];
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
    return s->bs.line ? crt_base_speed(&s->bs.body, z + 1, s->bs.dir, 0, &sn, &cs, &vx, &vy)
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


/* q moved by a displacement of the scaled pose, face frame at q's yaw (moved: O's x, y and
   ell times the turn), its velocities set to the scaled twist xi (face frame at the new
   yaw): the slip's start from rest ends by this, in series or along its slow manifold */
static void crt_base_move(double *q, const double *moved, const double *xi, double ell)
{
  double sn, cs;
  crt_sincos(q[2], &sn, &cs);
  q[0] += cs * moved[0] - sn * moved[1];
  q[1] += sn * moved[0] + cs * moved[1];
  q[2] += moved[2] / ell;
  crt_sincos(q[2], &sn, &cs);
  q[3] = cs * xi[0] - sn * xi[1];
  q[4] = sn * xi[0] + cs * xi[1];
  q[5] = xi[2] / ell;
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
  double r = 0.0, moved[3] = {0.0, 0.0, 0.0}, G[3], xi[3];
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
  for (i = 0; i < NQ; ++i) q[i] = q0[i];
  crt_base_move(q, moved, xi, ell);
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
    s->next_output = s->out_origin + s->out_k * s->opt[CRT_OPT_OUTPUT_DT];
  }
  for (i = 0; i < NQ; ++i) s->q[i] = q1[i];
  s->t = t0 + tau;
  return 1;
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

/* N at t0 + x of the rest's balance with the friction of d (N depends on t alone) */
static double crt_base_onset_n(crt_session *s, double t0, const double *d, double x)
{
  double dq[NQ], N, cp[2];
  crt_base_rates(&s->bs.body, crt_base_u(s, t0 + x), s->q, d, dq, &N, cp);
  ++s->stat[CRT_STAT_EVENT_FUNCTION_EVALUATIONS];
  return N;
}

/* The Taylor start's span delta, cut at N's root where N reaches 0 inside it: a break-away
   as N falls to 0 (mu N meets a small friction just before the lift-off) would step over
   the lift-off, found at the next step's start, delta ~ 2e-6 s late (N there -2e-3 of
   the weight); cut, the next step starts at N <= 0 at its root, the lift-off's time */
static double crt_base_onset_span(crt_session *s, const double *d, double delta)
{
  const double t0 = s->t, n1 = crt_base_onset_n(s, t0, d, delta);
  const double tol = 1e-15 * crt_max(1.0, fabs(t0)) + 1e-15 * s->bs.body.t_scale;
  double n0, root;
  if (n1 > 0.0) return delta;
  n0 = crt_base_onset_n(s, t0, d, 0.0);
  if (!(n0 > 0.0)) return 0.0;
#define CRT_BASE_ONSET_EVAL(x) crt_base_onset_n(s, t0, d, (x))
  CRT_BASE_ILLINOIS(0.0, n0, delta, n1, root, tol, CRT_BASE_ONSET_EVAL);
#undef CRT_BASE_ONSET_EVAL
  return root;
}

/* A slip from rest at s->t against the gauge's maximiser: the stable direction of the
   slip's flow from -xi*, then the start along the slow manifold to a seed of 1e-6 v_scale
   (crt_base_onset_far) where the flow turns off d and that start is exact and steps over
   no event, else the Taylor start
   to 1e2 eps.  0 when no slip starts (the flow points back: the body stays). */
static int crt_base_onset(crt_session *s, crt_out *o)
{
  const double ell = s->bs.body.ell, h = 1e-7 * s->bs.body.t_scale, seed = 1e2 * s->bs.eps;
  double d[3], G[3], Gp[3], Gm[3], a, bb, disc, delta, xi[3], moved[3], across;
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
    delta = crt_base_onset_span(s, d, 2.0 * seed / (a + sqrt(disc)));
    for (i = 0; i < 3; ++i) {
      const double G1 = (Gp[i] - Gm[i]) / (2.0 * h);
      xi[i] = G[i] * delta + G1 * delta * delta / 2.0;
      moved[i] = G[i] * delta * delta / 2.0 + G1 * delta * delta * delta / 6.0;
    }
    crt_base_move(q, moved, xi, ell);
    s->t += delta;
  }
  crt_changed(s);
  s->bs.mode = CRT_BASE_SLIP;
  s->bs.hs = 0.0;
  crt_base_line_start(s);
  return 1;
}

/* ---- the translation ------------------------------------------------------------------ */
/* A slip along a line that does not turn (psi' = 0 and no yaw or lateral rate: the line's
   test, crt_base_line_flow, at every sample) is a quadrature of the law.  The horizontal
   momentum P = (M + m) V_O + R(psi) s'_h (fixed axes; the body does not turn) changes by
   the friction alone, -mu N e (every point of the face slides along e), and N = (M + m) g
   + s_z'', so from the start t0
     P(t) = P0 - mu e [(M + m) g (t - t0) + s_z'(t) - s_z'(t0)],
     X_O(t) = X_O(t0) + (P0 (t - t0) - mu e [(M + m) g (t - t0)^2/2 + s_z(t) - s_z(t0)
              - s_z'(t0) (t - t0)] - R (s_h(t) - s_h(t0))) / (M + m),
   V_O = (P - R s'_h)/(M + m): the state at any t from the law's values there, no steps.
   The stop (V_O.e = 0), N and the margins of cp are functions of t alone, sampled and
   located as the stick's (crt_base_sample_step). */

/* the translation's state q at t, u the moments (face frame) there */
static void crt_base_tr_q(const crt_session *s, double t, const double *u, double *q)
{
  const crt_base_body *b = &s->bs.body;
  const double Mt = b->pf[0] + b->pf[1], tau = t - s->bs.tr_t0, sn = s->bs.tr_sc[0];
  const double cs = s->bs.tr_sc[1], mu = b->mu;
  const double IN = Mt * b->pf[5] * tau + u[5] - s->bs.tr_sz[1];
  const double JN = Mt * b->pf[5] * 0.5 * tau * tau + u[2] - s->bs.tr_sz[0]
                    - s->bs.tr_sz[1] * tau;
  const double S[2] = {cs * u[0] - sn * u[1], sn * u[0] + cs * u[1]};
  const double Sd[2] = {cs * u[3] - sn * u[4], sn * u[3] + cs * u[4]};
  int i;
  for (i = 0; i < 2; ++i) {
    q[i] = s->bs.tr_X[i] + (s->bs.tr_P[i] * tau - mu * JN * s->bs.tr_e[i]
                           - (S[i] - s->bs.tr_S[i])) / Mt;
    q[3 + i] = (s->bs.tr_P[i] - mu * IN * s->bs.tr_e[i] - Sd[i]) / Mt;
  }
  q[2] = s->q[2];                          /* (the yaw held: s->q's is the start's) */
  q[5] = 0.0;
}

/* the translation's event functions at t (the stick's order): the signed speed V_O.e, N,
   the edge margin, the kern margin (linear pressure; else 1); its state in q.  The rates
   there (the friction of the line held) test the line: a turn or a lateral rate sets
   s->bs.turned */
static void crt_base_tr_g(crt_session *s, double t, double *g, double *q)
{
  const crt_base_body *b = &s->bs.body;
  const double *u = crt_base_u(s, t);
  double dq[NQ], N, cp[2];
  crt_base_tr_q(s, t, u, q);
  crt_base_rates(b, u, q, s->bs.dir, dq, &N, cp);
  ++s->stat[CRT_STAT_RHS_EVALUATIONS];
  if (crt_base_line_flow(b, q, dq, s->bs.dir, s->bs.tr_sc, &g[0]) > 0.0)
    s->bs.turned = 1;
  g[1] = N;
  g[2] = crt_base_margin(b, N, crt_face_edge_margin(&b->face, cp[0], cp[1]));
  g[3] = b->linear ? crt_base_margin(b, N, crt_face_kern_margin(&b->face, cp[0], cp[1]))
                   : 1.0;
}

/* The translation from the slip at s->t along its line (s->bs.tr_try: its turn, ell psi',
   at most 1e-12 of its speed, the line's own test of a turn: held at 0); the slip's
   DOP853 steps where its flow turns there, or where N or a margin is not positive there
   (the slip's step stops the run at its start: a reversal's own cp off the face tips at
   once) */
static void crt_base_tr_start(crt_session *s)
{
  const crt_base_body *b = &s->bs.body;
  const double *u = crt_base_u(s, s->t), Mt = b->pf[0] + b->pf[1];
  const double d[3] = {s->bs.dir[0], s->bs.dir[1], s->bs.dir[2]}, w = s->q[5];
  const double n = sqrt(d[0] * d[0] + d[1] * d[1]);
  double sn, cs, q[NQ];
  int k;
  s->bs.tr_try = 0;
  s->bs.dir[0] = d[0] / n;
  s->bs.dir[1] = d[1] / n;
  s->bs.dir[2] = s->q[5] = 0.0;
  crt_sincos(s->q[2], &sn, &cs);
  s->bs.tr_sc[0] = sn;
  s->bs.tr_sc[1] = cs;
  s->bs.tr_t0 = s->t;
  s->bs.tr_X[0] = s->q[0];
  s->bs.tr_X[1] = s->q[1];
  s->bs.tr_P[0] = Mt * s->q[3] + cs * u[3] - sn * u[4];
  s->bs.tr_P[1] = Mt * s->q[4] + sn * u[3] + cs * u[4];
  s->bs.tr_S[0] = cs * u[0] - sn * u[1];
  s->bs.tr_S[1] = sn * u[0] + cs * u[1];
  s->bs.tr_sz[0] = u[2];
  s->bs.tr_sz[1] = u[5];
  s->bs.tr_e[0] = cs * s->bs.dir[0] - sn * s->bs.dir[1];
  s->bs.tr_e[1] = sn * s->bs.dir[0] + cs * s->bs.dir[1];
  s->bs.turned = 0;
  crt_base_tr_g(s, s->t, s->bs.g, q);
  for (k = 0; k < CRT_BASE_NG_STICK && s->bs.g[k] > 0.0; ++k) {}
  if (k == CRT_BASE_NG_STICK && !s->bs.turned) {
    s->bs.mode = CRT_BASE_TRANSLATION;
    s->bs.has_p = 0;
    return;
  }
  for (k = 0; k < 3; ++k) s->bs.dir[k] = d[k];   /* (the slip's steps as they were) */
  s->q[5] = w;
}

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

/* Room for n grid rows and a step's own rows (CRT_MIN_ROWS; an empty buffer holds one grid
   row at least, with a step's own few: a buffer of CRT_MIN_ROWS rows, room 0, had retried
   the same step with a grid row in it forever); else, with the buffer empty, 0 and the
   step too long for any buffer (*shrink: the share of it that fits), or 0 and *shrink = 1:
   the step is taken again, the same, once the caller has emptied the buffer (s->bs.full
   ends this call) */
static int crt_base_rows_fit(crt_session *s, const crt_out *o, long n, double *shrink)
{
  const long left = (long)o->cap - (long)o->n - CRT_MIN_ROWS;
  const long room = o->n == 0 && left < 1 ? 1 : left;
  *shrink = 1.0;
  if (n <= room) return 1;
  if (o->n == 0) *shrink = (double)room / (double)n;
  else s->bs.full = 1;
  return 0;
}

/* The grid rows before until: from the step's dense output (z0, F: t at the row's fraction
   x found by Illinois on t(x), monotone in a step), the translation's state there, or the
   constant state s->q (F = 0); a
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
    if (!F && s->bs.mode == CRT_BASE_TRANSLATION) {
      double qr[NQ];
      crt_base_tr_q(s, at, crt_base_u(s, at), qr);
      crt_emit(o, at, qr, CRT_ROW_STEP);
    } else if (!F) {
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

#endif /* CRT_BASE_FLOW_H */
