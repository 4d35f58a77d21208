/*
 * crt_base_model.h: the base model's physics (issue 33) -- a box or a cylinder on its face,
 * driven by its points and rotors through their moments: the face and its frame from the
 * parameters, the moments turned into the face frame, the rest's wrench and the slip's
 * rates (the emitted base_stick, base_slip, base_twist of derive/base.py) with the
 * friction over the face (crt_face.h).  The model file (model_base.c) includes it after
 * the derived functions; crt_session.h keeps its memory, crt_base.h runs it.
 *
 * Hand-written C: this file is templates/runtime/crt_base_model.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * The face frame (derive/face.py's face_on): the vertical n (prm n0_x, n0_y, n0_z, body
 * axes) along a face normal of the box, or along the axis of the cylinder (to 1e-9); its
 * rows Q (a signed permutation of the body axes) turn body components into face ones,
 * so J stays diagonal and the moments are permuted: s -> Q s, Theta -> Q Theta Q^T.
 * Pressure (prm pressure, enum crt_pressure): uniform (N/A), or linear (affine, its
 * centroid at the centre of pressure cp: Sakharov 2015).  With linear pressure the slip's
 * friction depends on cp and cp (from the horizontal angular momentum) on the friction;
 * both affine, so the consistent cp is the root of an affine map in the plane, found
 * exactly from three evaluations (crt_base_linear).  State q = (X_O, Y_O, psi, X_O', Y_O',
 * psi'), fixed axes.
 */
#ifndef CRT_BASE_MODEL_H
#define CRT_BASE_MODEL_H

#include <math.h>

#include "crt_abi.h"
#include "crt_face.h"

typedef struct {
  crt_face face;
  double Q[9];                  /* rows: the face frame's axes in body axes */
  int qcol[3];                  /* Q as a signed permutation: row i is qsign[i] e_qcol[i] */
  double qsign[3];
  int identity;                 /* Q = E: the moments are already in the face frame */
  double pf[6];                 /* base_*'s p: M, m, J_x, J_y, J_z (face frame), g */
  double h;                     /* O's height above the plane */
  double mu, mu_s;              /* the kinetic and the static coefficient */
  int linear;                   /* the pressure is linear (else uniform) */
  double ell;                   /* the face's size: the scaled twist is (v, ell w) */
  double v_scale, t_scale;      /* sqrt(g ell), ell / v_scale */
  double zscale[NQ + 1];        /* the least scale of each of z = (t, q) in the step's error
                                   (crt_base_step): O's position ell, its velocity v_scale,
                                   t, psi and psi' none (0) */
} crt_base_body;

/* The body on its face from the parameters; returns -1, or the index (CRT_P_*) of the
   parameter at fault (n0_x: the vertical along no face normal; static_friction below
   friction; shape: neither a box nor a cylinder; pressure: no crt_pressure).  The body
   is usable either way. */
static int crt_base_body_set(crt_base_body *b, const double *prm)
{
  const int shape = (int)prm[CRT_P_shape];
  double n[3], norm, c[3], sign;
  int k = 0, i, j, fault = -1;
  for (i = 0; i < 3; ++i) n[i] = prm[CRT_P_n0_x + i];
  norm = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  for (i = 1; i < 3; ++i)
    if (fabs(n[i]) > fabs(n[k])) k = i;
  if (!(norm > 0.0) || !(fabs(fabs(n[k]) / norm - 1.0) <= 1e-9)) fault = CRT_P_n0_x;
  if (shape == CRT_SHAPE_CYLINDER && k != 2) fault = CRT_P_n0_x;
  if (shape != CRT_SHAPE_CYLINDER && shape != CRT_SHAPE_BOX) fault = CRT_P_shape;
  sign = n[k] >= 0.0 ? 1.0 : -1.0;
  /* third = sign e_k, first = e_(k+1), second = third x first */
  for (i = 0; i < 9; ++i) b->Q[i] = 0.0;
  b->Q[(k + 1) % 3] = 1.0;
  b->Q[3 + (k + 2) % 3] = sign;
  b->Q[6 + k] = sign;
  for (i = 0; i < 3; ++i)
    for (j = 0; j < 3; ++j)
      if (b->Q[3 * i + j] != 0.0) { b->qcol[i] = j; b->qsign[i] = b->Q[3 * i + j]; }
  b->identity = 1;
  for (i = 0; i < 3; ++i) b->identity &= b->qcol[i] == i && b->qsign[i] == 1.0;
  for (i = 0; i < 3; ++i) {
    c[i] = 0.0;
    for (j = 0; j < 3; ++j) c[i] += b->Q[3 * i + j] * prm[CRT_P_center_x + j];
  }
  if (shape == CRT_SHAPE_CYLINDER) {
    crt_face_set(&b->face, CRT_FACE_DISC, prm[CRT_P_size_a], 0.0, c[0], c[1]);
    b->h = prm[CRT_P_size_b] - c[2];
  } else {
    double ext[3];
    for (i = 0; i < 3; ++i) {
      ext[i] = 0.0;
      for (j = 0; j < 3; ++j) ext[i] += fabs(b->Q[3 * i + j]) * prm[CRT_P_size_a + j];
    }
    crt_face_set(&b->face, CRT_FACE_RECTANGLE, ext[0], ext[1], c[0], c[1]);
    b->h = ext[2] - c[2];
  }
  b->pf[0] = prm[CRT_P_M];
  b->pf[1] = prm[CRT_P_m];
  for (i = 0; i < 3; ++i) {                /* J_f = Q J Q^T: J permuted */
    b->pf[2 + i] = 0.0;
    for (j = 0; j < 3; ++j) b->pf[2 + i] += b->Q[3 * i + j] * b->Q[3 * i + j] * prm[CRT_P_J_x + j];
  }
  b->pf[5] = prm[CRT_P_g];
  b->mu = prm[CRT_P_friction];
  b->mu_s = prm[CRT_P_static_friction];
  if (!(b->mu_s >= b->mu) && fault < 0) fault = CRT_P_static_friction;
  b->linear = prm[CRT_P_pressure] == (double)CRT_PRESSURE_LINEAR;
  if (!b->linear && prm[CRT_P_pressure] != (double)CRT_PRESSURE_UNIFORM && fault < 0)
    fault = CRT_P_pressure;
  b->ell = b->face.size;
  b->v_scale = sqrt(b->pf[5] * b->ell);
  b->t_scale = b->ell / b->v_scale;
  b->zscale[0] = b->zscale[3] = b->zscale[6] = 0.0;
  b->zscale[1] = b->zscale[2] = b->ell;
  b->zscale[4] = b->zscale[5] = b->v_scale;
  return fault;
}

/* The moments u (body axes, derive/layout.py's MOMENTS) in the face frame: each vector
   (MODEL_MOMENTS_VECTORS) turned by Q, each symmetric tensor's upper triangle
   (MODEL_MOMENTS_TENSORS, entries 00 01 02 11 12 22) by Q . Q^T -- Q a signed permutation,
   so each entry is one entry of u with a sign: (Q S Q^T)_rc = sign_r sign_c S_(col_r col_c) */
static void crt_base_face_moments(const crt_base_body *b, const double *u, double *uf)
{
  static const int vectors[] = MODEL_MOMENTS_VECTORS;
  static const int tensors[] = MODEL_MOMENTS_TENSORS;
  static const int row[6] = {0, 0, 0, 1, 1, 2}, col[6] = {0, 1, 2, 1, 2, 2};
  static const int upper[3][3] = { {0, 1, 2}, {1, 3, 4}, {2, 4, 5} };   /* S_ij's entry */
  int v, i;
  for (v = 0; v < (int)(sizeof vectors / sizeof vectors[0]); ++v) {
    const int o = vectors[v];
    for (i = 0; i < 3; ++i) uf[o + i] = b->qsign[i] * u[o + b->qcol[i]];
  }
  for (v = 0; v < (int)(sizeof tensors / sizeof tensors[0]); ++v) {
    const int o = tensors[v];
    for (i = 0; i < 6; ++i)
      uf[o + i] = b->qsign[row[i]] * b->qsign[col[i]]
                  * u[o + upper[b->qcol[row[i]]][b->qcol[col[i]]]];
  }
}

/* The pressure's gradient k over the face under N with its centre at cp (0: uniform) */
static void crt_base_slope(const crt_base_body *b, double N, const double *cp, double *k)
{
  crt_face_slope(&b->face, b->linear, N, cp, k);
}

/* At rest: the friction wrench W = (F_x, F_y, T_z) the rest needs, N and the centre of
   pressure cp (face frame, from O's vertical) */
static void crt_base_rest(const crt_base_body *b, const double *uf, double *W, double *N,
                          double *cp)
{
  base_stick(uf, b->pf, b->h, W, N, cp);
}

/* The slip's rates under linear pressure at the twist tw: the centre of pressure c that
   the slip's own friction gives back.  The friction is linear in the pressure, so
   affine in c (crt_face_slope); base_slip's cp is affine in the friction (the planar
   mass matrix solved, then the horizontal angular momentum): F(c) = cp(W(c)) - c is an
   affine map of the plane, known exactly from its values at the face's centroid c0 and
   at c0 + ell e_x, c0 + ell e_y; its root c* = c0 - A^-1 F(c0), and the rates are those
   at c*.  The face's integrals are taken once (crt_face_slip_set), the four wrenches read
   from them.  A singular A (no consistent pressure: cp's own shift by the friction's moment
   equal to c's) gives NaN rates, a nonfinite stop. */
static void crt_base_linear(const crt_base_body *b, const double *uf, const double *q,
                            const double *tw, double N0, double *dq, double *N,
                            double *cp)
{
  const double ell = b->ell;
  double c[3][2], F[3][2], k[2], W[3], det, x0, x1;
  crt_face_slip m;                          /* the face's integrals, once for the twist */
  int j;
  crt_face_slip_set(&b->face, 1, tw, &m);
  for (j = 0; j < 3; ++j) {
    c[j][0] = b->face.cx + (j == 1 ? ell : 0.0);
    c[j][1] = b->face.cy + (j == 2 ? ell : 0.0);
    crt_base_slope(b, N0, c[j], k);
    crt_face_apply(&b->face, &m, N0, k, b->mu, W);
    base_slip(q, uf, b->pf, b->h, W, dq, N, cp);
    F[j][0] = cp[0] - c[j][0];
    F[j][1] = cp[1] - c[j][1];
  }
  {                                         /* A's columns: (F_j - F_0) / ell */
    const double a00 = (F[1][0] - F[0][0]) / ell, a10 = (F[1][1] - F[0][1]) / ell;
    const double a01 = (F[2][0] - F[0][0]) / ell, a11 = (F[2][1] - F[0][1]) / ell;
    det = a00 * a11 - a01 * a10;
    if (!(fabs(det) > 1e-12 * (fabs(a00 * a11) + fabs(a01 * a10)))) {
      for (j = 0; j < NQ; ++j) dq[j] = NAN;
      return;
    }
    x0 = -(a11 * F[0][0] - a01 * F[0][1]) / det;
    x1 = -(-a10 * F[0][0] + a00 * F[0][1]) / det;
  }
  c[0][0] += x0;
  c[0][1] += x1;
  crt_base_slope(b, N0, c[0], k);
  crt_face_apply(&b->face, &m, N0, k, b->mu, W);
  base_slip(q, uf, b->pf, b->h, W, dq, N, cp);
}

/* The slip's rates dq/dt at q, with N and cp; the friction that of the slip's own twist
   (dir = 0), or of the unit scaled twist dir (v_x, v_y, ell w) (a slip from rest) */
static void crt_base_rates(const crt_base_body *b, const double *uf, const double *q,
                           const double *dir, double *dq, double *N, double *cp)
{
  static const double k0[2] = {0.0, 0.0};            /* uniform pressure */
  double W[3], tw[3], N0, cp0[2];
  base_stick(uf, b->pf, b->h, W, &N0, cp0);         /* N: the same at rest and in slip */
  if (dir) {
    tw[0] = dir[0]; tw[1] = dir[1]; tw[2] = dir[2] / b->ell;
  } else {
    base_twist(q, tw);
  }
  if (b->linear) {
    crt_base_linear(b, uf, q, tw, N0, dq, N, cp);
    return;
  }
  crt_face_wrench(&b->face, N0, k0, b->mu, tw, W);
  base_slip(q, uf, b->pf, b->h, W, dq, N, cp);
}

/* |xi|: the slip's scaled twist's norm, sqrt(|V_O|^2 + (ell psi')^2) */
static double crt_base_rho(const crt_base_body *b, const double *q)
{
  return sqrt(q[3] * q[3] + q[4] * q[4] + b->ell * b->ell * q[5] * q[5]);
}

#endif /* CRT_BASE_MODEL_H */
