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
 *   - a disc by fixed rules in the angle about r0: the trapezoid rule with 4n angles from
 *     r0 - c's direction when r0 is inside, n-point Gauss-Legendre in phi with
 *     sin(theta - theta_c) = (R/delta) sin(phi) when it is outside (n =
 *     CRT_FACE_ANGLE_N), the angles taken by the disc's symmetry in fours or pairs that
 *     share one square root, their sines and cosines tabulated; within CRT_FACE_RIM of
 *     the rim (CRT_FACE_RIM R < |r0 - c| < R / CRT_FACE_RIM), where the chord's square
 *     root nearly vanishes at one angle and those rules lose their rate (7e-8 off at 1e-4 R
 *     inside), in closed form by the complete elliptic integrals E and K (the
 *     arithmetic-geometric mean): the wrench and D to round-off (2e-15 of the wrench's
 *     scale against SciPy's adaptive quadrature) from 0.1 R inside to 0.1 R outside,
 *     the rim itself included;
 *   - r0 beyond CRT_FACE_FAR face sizes from the centroid: the product Gauss rule over
 *     the face (the slip field is analytic there; the triangles about r0 would cancel);
 *   - |w| size <= 1e-12 |v|: a translation, F = -mu N v/|v| at the pressure's centroid.
 * The integrals are linear in the pressure: crt_face_slip_set takes them once for a
 * twist, crt_face_apply gives the wrench under any N and k from them (crt_face_wrench is
 * the two).
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

/* The friction of one slip twist, linear in the pressure (P_c, k): its integrals over the
   face, from which crt_face_apply gives the wrench and D under any (N, k) at once (the
   linear pressure's centre found by crt_base_linear reads it four times).  kind: 0 no
   slip, 1 a translation (u: v/|v|), 2 about the instant centre r0 (sg = sign w, aw = |w|)
   with, p = P0 + k.(r - r0) and P0 = P_c + k.(r0 - c),
     G = int p (r - r0)/|r - r0| dA = P0 GP + M k,  E = int p |r - r0| dA = P0 EP + B.k,
   H = int p r.(r - r0)/|r - r0| dA = r0.G + E; 3 the product rule (r0 far), Wp[j] the
   (F_x, F_y, T_z, D) per unit mu of the pressures 1, x - c_x, y - c_y (j = 0, 1, 2). */
typedef struct {
  int kind;
  double u[2], speed;                   /* a translation */
  double r0[2], sg, aw;                 /* about r0 */
  double GP[2], M[4], EP, B[2];         /* M row-major */
  double Wp[3][4];                      /* the product rule */
} crt_face_slip;

/* the moments of a rectangle about r0, as the signed triangles (r0, V_i, V_i+1), each in
   closed form (derive/face.py's _polygon_integrals, the same formulas split by P0 and k) */
static void crt_face_polygon(const crt_face *f, int linear, crt_face_slip *m)
{
  const double V[4][2] = { {f->cx + f->a, f->cy - f->b}, {f->cx + f->a, f->cy + f->b},
                          {f->cx - f->a, f->cy + f->b}, {f->cx - f->a, f->cy - f->b} };
  const double r0x = m->r0[0], r0y = m->r0[1];
  int i, j;
  for (i = 0; i < 4; ++i) {
    const double Ax = V[i][0] - r0x, Ay = V[i][1] - r0y;
    const double Bx = V[(i + 1) % 4][0] - r0x, By = V[(i + 1) % 4][1] - r0y;
    const double ell = sqrt((Bx - Ax) * (Bx - Ax) + (By - Ay) * (By - Ay));
    const double ex = (Bx - Ax) / ell, ey = (By - Ay) / ell;
    const double nx = -ey, ny = ex;
    const double eta = Ax * nx + Ay * ny;
    double lo[5], hi[5], I0, I1, K2, J0, J1, t1, ge, gn, he, hn;
    if (eta == 0.0) continue;                 /* r0 on the edge's line: a flat triangle */
    t1 = Ax * ex + Ay * ey;
    crt_face_edge_prims(t1, eta, fabs(eta), lo);
    crt_face_edge_prims(t1 + ell, eta, fabs(eta), hi);
    for (j = 0; j < 5; ++j) hi[j] -= lo[j];
    I0 = hi[0]; I1 = hi[1]; K2 = hi[2]; J0 = hi[3]; J1 = hi[4];
    /* G += -eta (e gt + nu gn), gt = c2 I1 + ke/3 K2, gn = eta (c2 I0 + ke/3 I1), c2 =
       P0/2 + eta kn/3 (ke = k.e, kn = k.nu); E += -eta (c3 J0 + ke/4 J1), c3 = P0/3 +
       eta kn/4 */
    m->GP[0] += -eta * (ex * I1 + nx * eta * I0) / 2.0;
    m->GP[1] += -eta * (ey * I1 + ny * eta * I0) / 2.0;
    m->EP += -eta * J0 / 3.0;
    if (!linear) continue;
    ge = -eta * (ex * K2 + nx * eta * I1) / 3.0;      /* G's part along ke */
    gn = -eta * eta * (ex * I1 + nx * eta * I0) / 3.0; /* along kn */
    he = -eta * (ey * K2 + ny * eta * I1) / 3.0;
    hn = -eta * eta * (ey * I1 + ny * eta * I0) / 3.0;
    m->M[0] += ge * ex + gn * nx;
    m->M[1] += ge * ey + gn * ny;
    m->M[2] += he * ex + hn * nx;
    m->M[3] += he * ey + hn * ny;
    m->B[0] += -eta * (eta * J0 * nx + J1 * ex) / 4.0;
    m->B[1] += -eta * (eta * J0 * ny + J1 * ey) / 4.0;
  }
}

/* the moments of a disc about r0 by the rules in the angle about r0 (derive/face.py's
   _disc_integrals).  With e_d = (r0 - c)/delta and e_p = e_z x e_d, by the disc's symmetry
   GP = A e_d, M = Mdd e_d e_d^T + Mpp e_p e_p^T, B = Bd e_d; along the ray at the angle
   theta from e_d (cos c, sin s) the disc lies for rho in [lo, hi], and the radial
   integrals are powers of lo and hi.  Inside (delta < R): lo = 0, hi = S - delta c, S =
   sqrt(R^2 - delta^2 s^2), the trapezoid rule's angles in fours (+-c, +-s: one S);
   outside: the ray turned alpha from -e_d with sin(alpha) = (R/delta) sin(phi), lo, hi =
   delta cos(alpha) -+ R cos(phi), the rule's nodes in pairs +-phi.  No sine or cosine:
   the rules' own are tabulated (crt_face_rules.h).  Near the rim the same sums in closed
   form (crt_face_elliptic).

   crt_face_elliptic: the complete elliptic integrals E(k) and (1 - k^2) K(k) (finite at k
   = 1, where K diverges as log) from kp2 = 1 - k^2, by the arithmetic-geometric mean:
   a_0 = 1, b_0 = k', c_0 = k, a_n+1 = (a_n + b_n)/2, b_n+1 = sqrt(a_n b_n), c_n+1 = (a_n -
   b_n)/2; K = pi/(2 a_inf), E = K (1 - sum_n 2^(n-1) c_n^2) (Abramowitz and Stegun 17.6.3-4).
   c_n+1 = c_n^2/(4 a_n+1): stopped at c_n <= 1e-10 a_n, the next term is below 1e-20. */
static void crt_face_elliptic(double kp2, double *E, double *L)
{
  const double pi = 3.14159265358979323846;
  double a = 1.0, b = sqrt(kp2), c = 1.0, sum = 0.5 * (1.0 - kp2), pw = 0.5;
  int i;
  if (kp2 == 0.0) {                          /* k = 1: E = 1, K's log times 0 */
    *E = 1.0;
    *L = 0.0;
    return;
  }
  for (i = 0; i < 64 && fabs(c) > 1e-10 * a; ++i) {
    const double an = 0.5 * (a + b);
    c = 0.5 * (a - b);
    b = sqrt(a * b);
    a = an;
    pw *= 2.0;
    sum += pw * c * c;
  }
  *E = pi / (2.0 * a) * (1.0 - sum);
  *L = kp2 * pi / (2.0 * a);
}

static void crt_face_disc(const crt_face *f, crt_face_slip *m)
{
  const double pi = 3.14159265358979323846;
  const double R = f->a, dx = m->r0[0] - f->cx, dy = m->r0[1] - f->cy;
  const double delta = sqrt(dx * dx + dy * dy);
  const double edx = delta > 0.0 ? dx / delta : 1.0, edy = delta > 0.0 ? dy / delta : 0.0;
  double A = 0.0, Mdd = 0.0, Mpp = 0.0, E0 = 0.0, Bd = 0.0;
  int j;
  if (delta > CRT_FACE_RIM * R && delta < R / CRT_FACE_RIM) {
    /* near the rim, in closed form: the sums over the angle are integrals over [0, pi/2]
       of cos^2i sin^2j Delta^p (Delta = sqrt(1 - k^2 sin^2)), each E a + (1 - k^2) K b with
       a, b rational in k^2 (from U_m = int sin^2m / Delta: U_0 = K, U_1 = (K - E)/k^2,
       (2m + 1) k^2 U_m+1 = 2m (1 + k^2) U_m - (2m - 1) U_m-1).  Inside, k = delta/R and
       the four rays' hi = R Delta -+ delta cos; outside, k = R/delta, cos(alpha) = Delta(phi),
       root = R cos(phi), d alpha = k cos(phi)/Delta d phi.  kp2 = 1 - k^2 from R -+ delta. */
    const int in = delta < R;
    const double kp2 = in ? (R - delta) * (R + delta) / (R * R)
                          : (delta - R) * (delta + R) / (delta * delta);
    const double k2 = 1.0 - kp2, p2 = kp2 * kp2, d2 = delta * delta;
    double E, L, c2D, c2D3, c4D, s2c2D;
    crt_face_elliptic(kp2, &E, &L);
    c2D = ((1.0 + k2) * E - L) / (3.0 * k2);                          /* cos^2 Delta */
    c2D3 = ((8.0 - 3.0 * kp2 - 2.0 * p2) * E - (4.0 - kp2) * L) / (15.0 * k2);
    c4D = ((8.0 - 13.0 * kp2 + 3.0 * p2) * E - (4.0 - 6.0 * kp2) * L) / (15.0 * k2 * k2);
    s2c2D = (2.0 * (1.0 - kp2 + p2) * E - (1.0 + kp2) * L) / (15.0 * k2 * k2);
    if (in) {
      const double D3 = (2.0 * (1.0 + kp2) * E - L) / 3.0;
      const double s2D3 = ((2.0 + 3.0 * kp2 - 8.0 * p2) * E - (1.0 - 4.0 * kp2) * L)
                          / (15.0 * k2);
      A = -4.0 * delta * R * c2D;
      E0 = 4.0 * R * (R * R * D3 / 3.0 + d2 * c2D);
      Mdd = 4.0 * R * (R * R * c2D3 / 3.0 + d2 * c4D);
      Mpp = 4.0 * R * (R * R * s2D3 / 3.0 + d2 * s2c2D);
      Bd = -4.0 * delta * R * (R * R * c2D3 + d2 * c4D);
    } else {
      const double q = R / delta;
      const double c4_D = (2.0 * (1.0 - 2.0 * kp2) * E - (1.0 - 3.0 * kp2) * L)
                          / (3.0 * k2 * k2);                            /* cos^4 / Delta */
      const double s2c4_D = ((2.0 - 7.0 * kp2 - 3.0 * p2) * E - (1.0 - 9.0 * kp2) * L)
                            / (15.0 * k2 * k2 * k2);
      A = -4.0 * R * R * c2D;
      E0 = 4.0 * q * R * (R * R * c4_D + 3.0 * d2 * c2D) / 3.0;
      Mdd = 4.0 * q * R * (R * R * c4D + 3.0 * d2 * c2D3) / 3.0;
      Mpp = 4.0 * q * q * q * R * (R * R * s2c4_D + 3.0 * d2 * s2c2D) / 3.0;
      Bd = -4.0 * R * R * (R * R * c4D + d2 * c2D3);
    }
  } else if (delta < R) {
    const int n = CRT_FACE_ANGLE_N;
    const double h = 2.0 * pi / (4 * n), d2 = delta * delta;
    for (j = 0; j <= n; ++j) {
      /* the four angles +-theta, pi -+ theta: hi = S -+ delta c; summed over them, the
         sums of c hi^2/2, c^2 hi^3/3, s^2 hi^3/3, hi^3/3, c hi^4/4 (j = 0 and n: two
         angles, each counted twice) */
      const double c = crt_face_quarter_cos[j], s = crt_face_quarter_cos[n - j];
      const double wt = (j == 0 || j == n) ? 0.5 * h : h;
      const double S = sqrt(R * R - d2 * s * s), c2 = c * c;
      const double cube = wt * (4.0 / 3.0) * S * (S * S + 3.0 * d2 * c2);
      A += -4.0 * wt * delta * c2 * S;
      E0 += cube;
      Mdd += c2 * cube;
      Mpp += s * s * cube;
      Bd += -4.0 * wt * delta * c2 * S * (S * S + d2 * c2);
    }
  } else {
    for (j = 0; j < CRT_FACE_ANGLE_HALF; ++j) {
      const double sn = (R / delta) * crt_face_angle_sin[j];
      const double ca = sqrt(1.0 - sn * sn), root = R * crt_face_angle_cos[j];
      const double wt = crt_face_angle_w[j] * pi / 2.0 * (R / delta) * crt_face_angle_cos[j] / ca;
      /* the pair +-phi, the ray along -e_d turned +-alpha: (hi^2 - lo^2)/2 = 2 delta ca
         root, (hi^3 - lo^3)/3 = (2/3) root (root^2 + 3 delta^2 ca^2), (hi^4 - lo^4)/4 =
         2 delta ca root (root^2 + delta^2 ca^2); the ray's e_d component is -ca */
      const double cube = 2.0 * wt * (2.0 / 3.0) * root * (root * root + 3.0 * delta * delta * ca * ca);
      A += -2.0 * wt * ca * 2.0 * delta * ca * root;
      E0 += cube;
      Mdd += ca * ca * cube;
      Mpp += sn * sn * cube;
      Bd += -2.0 * wt * ca * 2.0 * delta * ca * root * (root * root + delta * delta * ca * ca);
    }
  }
  m->GP[0] = A * edx;
  m->GP[1] = A * edy;
  m->M[0] = Mdd * edx * edx + Mpp * edy * edy;
  m->M[1] = m->M[2] = (Mdd - Mpp) * edx * edy;
  m->M[3] = Mdd * edy * edy + Mpp * edx * edx;
  m->EP = E0;
  m->B[0] = Bd * edx;
  m->B[1] = Bd * edy;
}

/* the parts Wp by the product Gauss rule over the face (the instant centre far) */
static void crt_face_product(const crt_face *f, int linear, const double *tw,
                             crt_face_slip *m)
{
  const int n = CRT_FACE_FAR_N;
  const int nm = f->kind == CRT_FACE_RECTANGLE ? n : 2 * n + 2;
  int i, j, q;
  for (i = 0; i < n; ++i)
    for (j = 0; j < nm; ++j) {
      double ox, oy, wgt, x, y, ux, uy, speed, c, w4[4];
      if (f->kind == CRT_FACE_RECTANGLE) {
        ox = f->a * crt_face_far_x[i];
        oy = f->b * crt_face_far_x[j];
        wgt = f->a * crt_face_far_w[i] * f->b * crt_face_far_w[j];
      } else {
        const double pi = 3.14159265358979323846;
        const double r = f->a * (crt_face_far_x[i] + 1.0) / 2.0;
        ox = r * crt_face_far_cos[j];
        oy = r * crt_face_far_sin[j];
        wgt = f->a * crt_face_far_w[i] / 2.0 * r * (2.0 * pi / nm);
      }
      x = ox + f->cx;
      y = oy + f->cy;
      ux = tw[0] - tw[2] * y;
      uy = tw[1] + tw[2] * x;
      speed = sqrt(ux * ux + uy * uy);
      if (!(speed > 0.0)) continue;
      c = -wgt / speed;
      w4[0] = c * ux;
      w4[1] = c * uy;
      w4[2] = x * c * uy - y * c * ux;
      w4[3] = wgt * speed;
      for (q = 0; q < 4; ++q) m->Wp[0][q] += w4[q];
      if (linear)
        for (q = 0; q < 4; ++q) {
          m->Wp[1][q] += ox * w4[q];
          m->Wp[2][q] += oy * w4[q];
        }
    }
}

/* the slip's integrals for the twist tw = (v_x, v_y, w) (face frame, at O); their parts
   along k (M, B, Wp[1], Wp[2]) left 0 by a rectangle and the product rule unless linear
   (the wrench under uniform pressure only) */
static void crt_face_slip_set(const crt_face *f, int linear, const double *tw,
                              crt_face_slip *m)
{
  const double speed = sqrt(tw[0] * tw[0] + tw[1] * tw[1]);
  int i, q;
  if (fabs(tw[2]) * f->size <= 1e-12 * speed) {
    m->kind = speed == 0.0 ? 0 : 1;                      /* no slip; a translation */
    m->speed = speed;
    m->u[0] = speed > 0.0 ? tw[0] / speed : 0.0;
    m->u[1] = speed > 0.0 ? tw[1] / speed : 0.0;
    return;
  }
  m->r0[0] = -tw[1] / tw[2];
  m->r0[1] = tw[0] / tw[2];
  m->sg = tw[2] > 0.0 ? 1.0 : -1.0;
  m->aw = fabs(tw[2]);
  if (sqrt((m->r0[0] - f->cx) * (m->r0[0] - f->cx) + (m->r0[1] - f->cy) * (m->r0[1] - f->cy))
      > CRT_FACE_FAR * f->size) {
    m->kind = 3;
    for (i = 0; i < 3; ++i)
      for (q = 0; q < 4; ++q) m->Wp[i][q] = 0.0;
    crt_face_product(f, linear, tw, m);
    return;
  }
  m->kind = 2;
  m->GP[0] = m->GP[1] = m->EP = m->B[0] = m->B[1] = 0.0;
  for (i = 0; i < 4; ++i) m->M[i] = 0.0;
  if (f->kind == CRT_FACE_RECTANGLE) crt_face_polygon(f, linear, m);
  else crt_face_disc(f, m);
}

/* The friction on the body of the slip m under the normal force N with the pressure's
   gradient k (k = 0: uniform): W = (F_x, F_y, T_z), T_z about O's vertical.  Returns D =
   mu int p |u| dA (>= 0). */
static double crt_face_apply(const crt_face *f, const crt_face_slip *m, double N,
                             const double *k, double mu, double *W)
{
  const double P_c = N / f->area;
  if (m->kind == 0) {
    W[0] = W[1] = W[2] = 0.0;
    return 0.0;
  }
  if (m->kind == 1) {                                    /* at the pressure's centroid */
    const double cx = f->cx + k[0] * f->Ix / N, cy = f->cy + k[1] * f->Iy / N;
    W[0] = -mu * N * m->u[0];
    W[1] = -mu * N * m->u[1];
    W[2] = cx * W[1] - cy * W[0];
    return mu * N * m->speed;
  }
  if (m->kind == 3) {
    int q;
    double w4[4];
    for (q = 0; q < 4; ++q) w4[q] = mu * (P_c * m->Wp[0][q] + k[0] * m->Wp[1][q]
                                          + k[1] * m->Wp[2][q]);
    W[0] = w4[0]; W[1] = w4[1]; W[2] = w4[2];
    return w4[3];
  }
  {
    const double P0 = P_c + k[0] * (m->r0[0] - f->cx) + k[1] * (m->r0[1] - f->cy);
    const double G0 = P0 * m->GP[0] + m->M[0] * k[0] + m->M[1] * k[1];
    const double G1 = P0 * m->GP[1] + m->M[2] * k[0] + m->M[3] * k[1];
    const double E = P0 * m->EP + m->B[0] * k[0] + m->B[1] * k[1];
    const double H = m->r0[0] * G0 + m->r0[1] * G1 + E;
    W[0] = mu * m->sg * G1;
    W[1] = -mu * m->sg * G0;
    W[2] = -mu * m->sg * H;
    return mu * m->aw * E;
  }
}

/* crt_face_wrench's turning slip (w != 0): its integrals, then the wrench */
static double crt_face_turning(const crt_face *f, double N, const double *k, double mu,
                               const double *tw, double *W)
{
  crt_face_slip m;
  crt_face_slip_set(f, k[0] != 0.0 || k[1] != 0.0, tw, &m);
  return crt_face_apply(f, &m, N, k, mu, W);
}

/* The friction on the body for the slip twist tw = (v_x, v_y, w) (face frame, at O)
   under the normal force N with the pressure's gradient k (k = 0: uniform): W = (F_x,
   F_y, T_z), T_z about O's vertical.  Returns D = mu int p |u| dA (>= 0). */
static double crt_face_wrench(const crt_face *f, double N, const double *k, double mu,
                              const double *tw, double *W)
{
  const double speed = sqrt(tw[0] * tw[0] + tw[1] * tw[1]);
  if (fabs(tw[2]) * f->size <= 1e-12 * speed) {          /* a translation, at once */
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
  return crt_face_turning(f, N, k, mu, tw, W);
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
