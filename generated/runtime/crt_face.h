/*
 * crt_face.h: Coulomb friction over a flat face on the plane, sliding and spinning coupled
 * (Contensou) -- the base model's friction law (issue 33).  Needs only <math.h> and the
 * rules of crt_face_rules.h: a friction law as a header, like crt_rough*.h's.
 *
 * Hand-written C: this file is templates/runtime/crt_face.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * The face, in the face frame (derive/face.py: body axes turned so that the third is the
 * upward vertical): the rectangle |x - c_x| <= a, |y - c_y| <= b or the disc |r - c| <= R,
 * positions from O's vertical.  A face point r slips at u(r) = v + w e_z x r (the twist
 * (v_x, v_y, w): O's velocity and the yaw rate), and friction there is -mu p(r) u/|u|,
 * with the pressure p affine, p = P_c + k.(r - c) (uniform: k = 0, P_c = N/A; linear: k
 * from the centre of pressure, crt_face_slope, and positive while the centre is in the
 * face's kern, crt_face_kern_margin).
 *
 * crt_face_wrench gives the friction's force (F_x, F_y) and torque T_z about O's vertical
 * summed over the face, and the power it takes, D = mu int p |u| dA (a norm of the twist,
 * whose gradient is minus the wrench).  With w != 0 the slip turns about the instant
 * centre r0 = e_z x v/w and the integrals are taken about r0 (radially in closed form):
 *   - a rectangle edge by edge in closed form (asinh and square roots), exact to
 *     round-off;
 *   - a disc by fixed rules in the angle about r0: the trapezoid rule with 4n angles when
 *     r0 is inside, n-point Gauss-Legendre in phi with sin(theta - theta_c) = (R/delta)
 *     sin(phi) when it is outside (n = CRT_FACE_ANGLE_N);
 *   - r0 beyond CRT_FACE_FAR face sizes from the centroid: the product Gauss rule over
 *     the face (the slip field is analytic there; the triangles about r0 would cancel);
 *   - |w| size <= 1e-12 |v|: a translation, F = -mu N v/|v| at the pressure's centroid.
 * derive/face.py computes the same integrals (centre_wrench); tests/test_crt_face.py
 * holds this header to it, and both to adaptive quadrature (derive/base_reference.py).
 *
 * crt_face_gauge gives the gauge of the limit surface at a wrench W, gamma = max over
 * twists xi of W.xi / D(xi) (at most 1: static friction can supply W), and the unit
 * scaled twist xi* = (v_x, v_y, size w) that attains it, as 1 / min D over the plane
 * W.xi = 1 (a convex problem in two coordinates) by BFGS, warm-started from the last
 * maximiser -- or in closed form under uniform pressure when W is a force through the
 * centroid or a torque alone (to round-off).  crt_face_gauge_bounds brackets it from
 * those two parts (a caller needing only to know that gamma < 1 may stop at them), under
 * linear pressure too (the upper bound scaled by the pressure's mean over its least).
 */
#ifndef CRT_FACE_H
#define CRT_FACE_H

#include <math.h>

#include "crt_face_rules.h"     /* the rules' nodes, CRT_FACE_FAR */

enum crt_face_kind { CRT_FACE_RECTANGLE = 0, CRT_FACE_DISC = 1 };

typedef struct {
  int kind;                     /* enum crt_face_kind */
  double a, b;                  /* half sizes (a rectangle), or the radius R in a (a disc) */
  double cx, cy;                /* the face's centroid from O's vertical (face frame) */
  double size;                  /* the half-diagonal or the radius: scales w in a twist */
  double area;
  double Ix, Iy;                /* int x^2 dA, int y^2 dA about the centroid */
  double rbar;                  /* the mean distance from the centroid, int |r - c| dA / A */
} crt_face;

static void crt_face_set(crt_face *f, int kind, double a, double b, double cx, double cy)
{
  const double pi = 3.14159265358979323846;
  f->kind = kind;
  f->a = a;
  f->b = kind == CRT_FACE_DISC ? a : b;
  f->cx = cx;
  f->cy = cy;
  if (kind == CRT_FACE_RECTANGLE) {
    f->size = sqrt(a * a + b * b);
    f->area = 4.0 * a * b;
    f->Ix = 4.0 * a * a * a * b / 3.0;
    f->Iy = 4.0 * a * b * b * b / 3.0;
    /* a quarter's int |r| dA = (2 a b d + a^3 ln((b + d)/a) + b^3 ln((a + d)/b))/6 */
    f->rbar = (2.0 * a * b * f->size + a * a * a * log((b + f->size) / a)
               + b * b * b * log((a + f->size) / b)) / (6.0 * a * b);
  } else {
    f->size = a;
    f->area = pi * a * a;
    f->Ix = f->Iy = pi * a * a * a * a / 4.0;
    f->rbar = 2.0 * a / 3.0;
  }
}

/* How far the point (x, y) (from O's vertical) is inside the face: 0 on its edge,
   negative outside (a centre of pressure there: the body tips). */
static double crt_face_edge_margin(const crt_face *f, double x, double y)
{
  const double dx = x - f->cx, dy = y - f->cy;
  if (f->kind == CRT_FACE_RECTANGLE) {
    const double mx = f->a - fabs(dx), my = f->b - fabs(dy);
    return mx < my ? mx : my;
  }
  return f->a - sqrt(dx * dx + dy * dy);
}

/* Linear pressure (affine, its centroid at the centre of pressure cp = (x, y) from O's
   vertical) stays positive over the face while this is >= 0, scaled as a length: cp in
   the kern |x'|/a + |y'|/b <= 1/3 of a rectangle (min(a, b) times the margin), |r'| <= R/4
   of a disc (r' = cp less the centroid); derive/face.py's kern_margin */
static double crt_face_kern_margin(const crt_face *f, double x, double y)
{
  const double dx = x - f->cx, dy = y - f->cy;
  if (f->kind == CRT_FACE_RECTANGLE)
    return (f->a < f->b ? f->a : f->b) * (1.0 / 3.0 - fabs(dx) / f->a - fabs(dy) / f->b);
  return f->a / 4.0 - sqrt(dx * dx + dy * dy);
}

/* The gradient k of the pressure over the face under N with its centre at cp: 0 for
   uniform pressure; linear, p = N/A + k.(r - c) with int p (r - c) dA = N (cp - c), so
   k = N (cp - c) / (I_x, I_y) */
static void crt_face_slope(const crt_face *f, int linear, double N, const double *cp,
                           double *k)
{
  k[0] = linear ? N * (cp[0] - f->cx) / f->Ix : 0.0;
  k[1] = linear ? N * (cp[1] - f->cy) / f->Iy : 0.0;
}

/* The primitives along an edge (tau the coordinate along it, eta the constant distance
   of its line from r0, h = |eta|): the integrals of 1/|q|, tau/|q|, tau^2/|q|, |q| and
   tau |q|, q = (tau, eta). */
static void crt_face_edge_prims(double tau, double eta, double h, double *P)
{
  const double L = sqrt(tau * tau + eta * eta);
  const double ash = asinh(tau / h);
  P[0] = ash;
  P[1] = L;
  P[2] = 0.5 * (tau * L - eta * eta * ash);
  P[3] = 0.5 * (tau * L + eta * eta * ash);
  P[4] = L * L * L / 3.0;
}

/* G = int p (r - r0)/|r - r0| dA and E = int p |r - r0| dA over a rectangle, as the
   signed triangles (r0, V_i, V_i+1), each in closed form (derive/face.py's
   _polygon_integrals, the same formulas) */
static void crt_face_polygon(const crt_face *f, double r0x, double r0y, double P_c,
                             const double *k, double *G, double *E)
{
  const double V[4][2] = { {f->cx + f->a, f->cy - f->b}, {f->cx + f->a, f->cy + f->b},
                          {f->cx - f->a, f->cy + f->b}, {f->cx - f->a, f->cy - f->b} };
  const double P0 = P_c + k[0] * (r0x - f->cx) + k[1] * (r0y - f->cy);
  int i, j;
  G[0] = G[1] = 0.0;
  *E = 0.0;
  for (i = 0; i < 4; ++i) {
    const double Ax = V[i][0] - r0x, Ay = V[i][1] - r0y;
    const double Bx = V[(i + 1) % 4][0] - r0x, By = V[(i + 1) % 4][1] - r0y;
    const double ell = sqrt((Bx - Ax) * (Bx - Ax) + (By - Ay) * (By - Ay));
    const double ex = (Bx - Ax) / ell, ey = (By - Ay) / ell;
    const double nx = -ey, ny = ex;
    const double eta = Ax * nx + Ay * ny;
    double lo[5], hi[5], I0, I1, K2, J0, J1, ke, kn, c2, c3, t1, gt, gn;
    if (eta == 0.0) continue;                 /* r0 on the edge's line: a flat triangle */
    ke = k[0] * ex + k[1] * ey;
    kn = k[0] * nx + k[1] * ny;
    t1 = Ax * ex + Ay * ey;
    crt_face_edge_prims(t1, eta, fabs(eta), lo);
    crt_face_edge_prims(t1 + ell, eta, fabs(eta), hi);
    for (j = 0; j < 5; ++j) hi[j] -= lo[j];
    I0 = hi[0]; I1 = hi[1]; K2 = hi[2]; J0 = hi[3]; J1 = hi[4];
    c2 = P0 / 2.0 + eta * kn / 3.0;
    c3 = P0 / 3.0 + eta * kn / 4.0;
    gt = c2 * I1 + ke / 3.0 * K2;
    gn = eta * (c2 * I0 + ke / 3.0 * I1);
    G[0] += -eta * (ex * gt + nx * gn);
    G[1] += -eta * (ey * gt + ny * gn);
    *E += -eta * (c3 * J0 + ke / 4.0 * J1);
  }
}

/* G, H = int p r.(r - r0)/|r - r0| dA and E over a disc, by the rules in the angle
   about r0 (derive/face.py's _disc_integrals) */
static void crt_face_disc(const crt_face *f, double r0x, double r0y, double P_c,
                          const double *k, double *G, double *H, double *E)
{
  const double pi = 3.14159265358979323846;
  const double R = f->a, dx = r0x - f->cx, dy = r0y - f->cy;
  const double delta = sqrt(dx * dx + dy * dy);
  const double P0 = P_c + k[0] * dx + k[1] * dy;
  const int inside = delta < R;
  const int m = inside ? 4 * CRT_FACE_ANGLE_N : CRT_FACE_ANGLE_N;
  const double th_c = inside ? 0.0 : atan2(-dy, -dx);
  int i;
  G[0] = G[1] = 0.0;
  *H = 0.0;
  *E = 0.0;
  for (i = 0; i < m; ++i) {
    double th, wt, lo, hi, ex, ey, de, ke, lo2, hi2, m1, m2;
    if (inside) {
      th = i * 2.0 * pi / m;
      wt = 2.0 * pi / m;
    } else {
      const double phi = crt_face_angle_x[i] * pi / 2.0;
      const double sn = (R / delta) * sin(phi);
      th = th_c + asin(sn);
      wt = crt_face_angle_w[i] * pi / 2.0 * (R / delta) * cos(phi) / sqrt(1.0 - sn * sn);
    }
    ex = cos(th);
    ey = sin(th);
    de = ex * dx + ey * dy;
    if (inside) {
      lo = 0.0;
      hi = -de + sqrt(R * R - delta * delta + de * de);
    } else {
      const double root = R * cos(crt_face_angle_x[i] * pi / 2.0);
      lo = -de - root;
      hi = -de + root;
    }
    ke = k[0] * ex + k[1] * ey;
    lo2 = lo * lo;
    hi2 = hi * hi;
    m1 = P0 * (hi2 - lo2) / 2.0 + ke * (hi2 * hi - lo2 * lo) / 3.0;
    m2 = P0 * (hi2 * hi - lo2 * lo) / 3.0 + ke * (hi2 * hi2 - lo2 * lo2) / 4.0;
    G[0] += wt * ex * m1;
    G[1] += wt * ey * m1;
    *H += wt * ((ex * r0x + ey * r0y) * m1 + m2);
    *E += wt * m2;
  }
}

/* the wrench and D by the product Gauss rule over the face (the instant centre far) */
static double crt_face_product(const crt_face *f, double P_c, const double *k, double mu,
                               const double *tw, double *W)
{
  const double pi = 3.14159265358979323846;
  const int n = CRT_FACE_FAR_N;
  const int m = f->kind == CRT_FACE_RECTANGLE ? n : 2 * n + 2;
  double D = 0.0;
  int i, j;
  W[0] = W[1] = W[2] = 0.0;
  for (i = 0; i < n; ++i)
    for (j = 0; j < m; ++j) {
      double ox, oy, wgt, x, y, ux, uy, speed, c;
      if (f->kind == CRT_FACE_RECTANGLE) {
        ox = f->a * crt_face_far_x[i];
        oy = f->b * crt_face_far_x[j];
        wgt = f->a * crt_face_far_w[i] * f->b * crt_face_far_w[j];
      } else {
        const double r = f->a * (crt_face_far_x[i] + 1.0) / 2.0;
        const double th = (j + 0.5) * 2.0 * pi / m;
        ox = r * cos(th);
        oy = r * sin(th);
        wgt = f->a * crt_face_far_w[i] / 2.0 * r * (2.0 * pi / m);
      }
      wgt *= P_c + k[0] * ox + k[1] * oy;
      x = ox + f->cx;
      y = oy + f->cy;
      ux = tw[0] - tw[2] * y;
      uy = tw[1] + tw[2] * x;
      speed = sqrt(ux * ux + uy * uy);
      if (!(speed > 0.0)) continue;
      c = -mu * wgt / speed;
      W[0] += c * ux;
      W[1] += c * uy;
      W[2] += x * c * uy - y * c * ux;
      D += mu * wgt * speed;
    }
  return D;
}

/* The friction on the body for the slip twist tw = (v_x, v_y, w) (face frame, at O)
   under the normal force N with the pressure's gradient k (k = 0: uniform): W = (F_x,
   F_y, T_z), T_z about O's vertical.  Returns D = mu int p |u| dA (>= 0). */
static double crt_face_wrench(const crt_face *f, double N, const double *k, double mu,
                              const double *tw, double *W)
{
  const double P_c = N / f->area;
  const double speed = sqrt(tw[0] * tw[0] + tw[1] * tw[1]);
  double r0x, r0y, G[2], H, E, sg;
  if (fabs(tw[2]) * f->size <= 1e-12 * speed) {          /* a translation */
    double cx, cy;
    if (speed == 0.0) {
      W[0] = W[1] = W[2] = 0.0;
      return 0.0;
    }
    cx = f->cx + k[0] * f->Ix / N;                       /* the pressure's centroid */
    cy = f->cy + k[1] * f->Iy / N;
    W[0] = -mu * N * tw[0] / speed;
    W[1] = -mu * N * tw[1] / speed;
    W[2] = cx * W[1] - cy * W[0];
    return mu * N * speed;
  }
  r0x = -tw[1] / tw[2];
  r0y = tw[0] / tw[2];
  if (sqrt((r0x - f->cx) * (r0x - f->cx) + (r0y - f->cy) * (r0y - f->cy))
      > CRT_FACE_FAR * f->size)
    return crt_face_product(f, P_c, k, mu, tw, W);
  if (f->kind == CRT_FACE_RECTANGLE) {
    crt_face_polygon(f, r0x, r0y, P_c, k, G, &E);
    H = r0x * G[0] + r0y * G[1] + E;
  } else {
    crt_face_disc(f, r0x, r0y, P_c, k, G, &H, &E);
  }
  sg = tw[2] > 0.0 ? 1.0 : -1.0;
  W[0] = mu * sg * G[1];
  W[1] = -mu * sg * G[0];
  W[2] = -mu * sg * H;
  return mu * fabs(tw[2]) * E;
}

/* D and its gradient in the plane's coordinates c (the scaled twist x = x0 + c0 e1 + c1
   e2; the gradient of D is minus the friction, scaled) */
static double crt_face_plane_value(const crt_face *f, double N, const double *k, double mu,
                                   const double *x0, const double *e1, const double *e2,
                                   const double *c, double *grad)
{
  double x[3], tw[3], W[3], D;
  int i;
  for (i = 0; i < 3; ++i) x[i] = x0[i] + c[0] * e1[i] + c[1] * e2[i];
  tw[0] = x[0]; tw[1] = x[1]; tw[2] = x[2] / f->size;
  D = crt_face_wrench(f, N, k, mu, tw, W);
  W[2] /= f->size;
  grad[0] = -(W[0] * e1[0] + W[1] * e1[1] + W[2] * e1[2]);
  grad[1] = -(W[0] * e2[0] + W[1] * e2[1] + W[2] * e2[2]);
  return D;
}

/* Bounds on the gauge, with Tc = T_z - (c x F)_z the torque about the centroid and the
   two parts gF = |F|/(mu N), gT = |Tc|/(mu N rbar).  Under uniform pressure (k = 0) each
   is the gauge of its part alone, the face being symmetric about its centroid (a
   translation attains gF, a spin about the centroid gT: D(v, w) >= D(0, w) by the
   symmetry and D's convexity): max(gF, gT) <= gamma <= gF + gT (the gauge is a norm).
   Under linear pressure p = P_c + k.(r - c) >= p_min > 0 over the face, D_p(xi) >=
   (p_min / P_c) D(xi) for every twist (D the uniform pressure's under the same N), so
   gamma <= (P_c / p_min) (gF + gT); the lower bound max(gF, gT) still holds (the
   translation's D is mu N |v| under any pressure, the spin's about the centroid mu N
   rbar |w|: int k.(r - c) |r - c| dA = 0); with p_min <= 0, or N <= 0, no upper bound
   (HUGE_VAL).  *part: under uniform pressure 1 when gF holds all of gamma to round-off
   (gT <= 1e-15 gF), 2 when gT does, else 0 (and 0 under linear pressure). */
static void crt_face_gauge_bounds(const crt_face *f, double N, const double *k, double mu,
                                  const double *W, double *lo, double *hi, int *part)
{
  const double Tc = W[2] - (f->cx * W[1] - f->cy * W[0]);
  const double gF = sqrt(W[0] * W[0] + W[1] * W[1]) / (mu * N);
  const double gT = fabs(Tc) / (mu * N * f->rbar);
  *part = 0;
  if (!(N > 0.0)) {
    *lo = 0.0;
    *hi = HUGE_VAL;
    return;
  }
  *lo = gF > gT ? gF : gT;
  if (k[0] != 0.0 || k[1] != 0.0) {
    const double P_c = N / f->area;
    const double p_min = P_c - (f->kind == CRT_FACE_RECTANGLE
                                ? fabs(k[0]) * f->a + fabs(k[1]) * f->b
                                : f->a * sqrt(k[0] * k[0] + k[1] * k[1]));
    *hi = p_min > 0.0 ? (gF + gT) * (P_c / p_min) : HUGE_VAL;
    return;
  }
  *hi = gF + gT;
  if (gF > 0.0 && gT <= 1e-15 * gF) *part = 1;
  else if (gT > 0.0 && gF <= 1e-15 * gT) *part = 2;
}

/* The gauge of the limit surface at the wrench W = (F_x, F_y, T_z): gamma = max W.xi /
   D(xi) (D with the coefficient mu), and xi[3] the unit scaled twist (v_x, v_y, size w)
   attaining it.  xi on entry: the last maximiser (a warm start when it has W.xi > 0),
   else W's own direction.  *evaluations counts the friction evaluations. */
static double crt_face_gauge(const crt_face *f, double N, const double *k, double mu,
                             const double *W, double *xi, long *evaluations)
{
  double Ws[3], e0[3], e1[3], e2[3], x0[3], c[2], g[2], Hi[4], nW, D, sx, lo, hi;
  int i, it, kmin = 0, stalls = 0, part;
  crt_face_gauge_bounds(f, N, k, mu, W, &lo, &hi, &part);
  if (part == 1) {                         /* a force through the centroid: a translation */
    const double F = sqrt(W[0] * W[0] + W[1] * W[1]);
    xi[0] = W[0] / F; xi[1] = W[1] / F; xi[2] = 0.0;
    return lo;
  }
  if (part == 2) {                         /* a torque alone: the spin about the centroid */
    const double w = W[2] - (f->cx * W[1] - f->cy * W[0]) > 0.0 ? 1.0 : -1.0;
    const double n = sqrt(f->cx * f->cx + f->cy * f->cy + f->size * f->size);
    xi[0] = w * f->cy / n; xi[1] = -w * f->cx / n; xi[2] = w * f->size / n;
    return lo;
  }
  Ws[0] = W[0]; Ws[1] = W[1]; Ws[2] = W[2] / f->size;
  nW = sqrt(Ws[0] * Ws[0] + Ws[1] * Ws[1] + Ws[2] * Ws[2]);
  if (nW == 0.0) {
    xi[0] = 1.0; xi[1] = 0.0; xi[2] = 0.0;
    return 0.0;
  }
  for (i = 0; i < 3; ++i) e0[i] = Ws[i] / nW;
  for (i = 1; i < 3; ++i)
    if (fabs(e0[i]) < fabs(e0[kmin])) kmin = i;
  /* e1 = e0 x (the axis least along e0), e2 = e0 x e1 */
  {
    double h[3] = {0.0, 0.0, 0.0}, n1;
    h[kmin] = 1.0;
    e1[0] = e0[1] * h[2] - e0[2] * h[1];
    e1[1] = e0[2] * h[0] - e0[0] * h[2];
    e1[2] = e0[0] * h[1] - e0[1] * h[0];
    n1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (i = 0; i < 3; ++i) e1[i] /= n1;
    e2[0] = e0[1] * e1[2] - e0[2] * e1[1];
    e2[1] = e0[2] * e1[0] - e0[0] * e1[2];
    e2[2] = e0[0] * e1[1] - e0[1] * e1[0];
  }
  for (i = 0; i < 3; ++i) x0[i] = e0[i] / nW;
  c[0] = c[1] = 0.0;
  sx = xi[0] * e0[0] + xi[1] * e0[1] + xi[2] * e0[2];
  if (sx > 0.0) {                          /* the warm start, on the plane W.x = 1 */
    for (i = 0; i < 3; ++i) {
      const double p = xi[i] / (sx * nW);
      c[0] += p * e1[i];
      c[1] += p * e2[i];
    }
  }
  D = crt_face_plane_value(f, N, k, mu, x0, e1, e2, c, g);
  ++*evaluations;
  /* the inverse Hessian: D is a norm, its curvature on the plane about D / |x|^2 */
  Hi[0] = Hi[3] = 1.0 / (nW * D);
  Hi[1] = Hi[2] = 0.0;
  for (it = 0; it < 200; ++it) {
    double p[2], cn[2], gn[2], Dn, s[2], y[2], sy, step = 1.0, slope;
    const double gnorm = sqrt(g[0] * g[0] + g[1] * g[1]);
    if (gnorm <= 1e-13 * D * nW) break;   /* the slip friction balances W to 1e-13 */
    p[0] = -(Hi[0] * g[0] + Hi[1] * g[1]);
    p[1] = -(Hi[2] * g[0] + Hi[3] * g[1]);
    slope = p[0] * g[0] + p[1] * g[1];
    if (!(slope < 0.0)) {                  /* not a descent: restart from the gradient */
      Hi[0] = Hi[3] = 1.0 / (nW * D);
      Hi[1] = Hi[2] = 0.0;
      p[0] = -Hi[0] * g[0];
      p[1] = -Hi[3] * g[1];
      slope = p[0] * g[0] + p[1] * g[1];
    }
    for (;;) {                             /* Armijo's backtracking */
      cn[0] = c[0] + step * p[0];
      cn[1] = c[1] + step * p[1];
      Dn = crt_face_plane_value(f, N, k, mu, x0, e1, e2, cn, gn);
      ++*evaluations;
      if (Dn <= D + 1e-4 * step * slope) break;
      step *= 0.5;
      if (step < 1e-12) break;
    }
    if (step < 1e-12) break;               /* no descent left: D is at round-off */
    s[0] = cn[0] - c[0]; s[1] = cn[1] - c[1];
    y[0] = gn[0] - g[0]; y[1] = gn[1] - g[1];
    c[0] = cn[0]; c[1] = cn[1];
    g[0] = gn[0]; g[1] = gn[1];
    /* D no longer decreasing: its rule's round-off (a disc's rules near the rim, 1e-10)
       is reached before the gradient's tolerance */
    stalls = D - Dn <= 1e-15 * D ? stalls + 1 : 0;
    D = Dn;
    if (stalls >= 2) break;
    sy = s[0] * y[0] + s[1] * y[1];
    if (sy > 0.0) {                        /* the BFGS update of the inverse Hessian */
      const double r = 1.0 / sy;
      const double Hy0 = Hi[0] * y[0] + Hi[1] * y[1], Hy1 = Hi[2] * y[0] + Hi[3] * y[1];
      const double yHy = y[0] * Hy0 + y[1] * Hy1;
      const double a = (1.0 + r * yHy) * r;
      Hi[0] += a * s[0] * s[0] - r * (Hy0 * s[0] + s[0] * Hy0);
      Hi[1] += a * s[0] * s[1] - r * (Hy0 * s[1] + s[0] * Hy1);
      Hi[2] += a * s[1] * s[0] - r * (Hy1 * s[0] + s[1] * Hy0);
      Hi[3] += a * s[1] * s[1] - r * (Hy1 * s[1] + s[1] * Hy1);
    }
  }
  {
    double nx;
    for (i = 0; i < 3; ++i) xi[i] = x0[i] + c[0] * e1[i] + c[1] * e2[i];
    nx = sqrt(xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]);
    for (i = 0; i < 3; ++i) xi[i] /= nx;
  }
  return 1.0 / D;
}

#endif /* CRT_FACE_H */
