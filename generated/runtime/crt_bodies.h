/*
 * crt_bodies.h: the internal bodies seen through their moments (the models with
 * MODEL_MOMENTS: moments, moments_rough) -- the law's u of n_points points and n_rotors
 * rotors (crt_law.h: point j's x, y, z and two derivatives at 9 j, rotor r's psi, psi',
 * psi'' at 9 n_points + 3 r) summed into the MODEL_MOMENTS_COUNT moments that the model's
 * functions read in its place (derive/layout.py's MOMENTS: s, s', s'', Theta, Theta', h,
 * h' about O in body axes): per point the emitted point_moments(m_j, its nine numbers),
 * per rotor rotor_moments(a_r, I_r, (psi', psi'')) into h and h' (from
 * MODEL_MOMENTS_SPIN).  crt_session.h's crt_u sums them once per evaluation of the law.
 *
 * Hand-written C: this file is templates/runtime/crt_bodies.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * The bodies' numbers are parameters (crt_abi.h, derive/abi.py): n_points, n_rotors,
 * m_1..m_n (the points' masses), a_r_x, a_r_y, a_r_z (rotor r's unit axis, body axes) and
 * I_r (its axial moment); m is the points' total.  A law of one point (crt_set_law_program,
 * crt_set_law_table) is one point of mass m_1 and no rotor.
 */
#ifndef CRT_BODIES_H
#define CRT_BODIES_H

#include <math.h>

#include "crt_abi.h"
#include "crt_law.h"            /* crt_law: its kind and its bodies */

/* The last sum: the moments of the law's evaluation number `stamp` (the session's count
   of law evaluations; -1: none).  A new evaluation, a new law or a new run changes the
   count or resets the stamp, so the sum is redone exactly when the law's u is new. */
typedef struct {
  long stamp;
  double u[MODEL_MOMENTS_COUNT];
} crt_moments;

/* the points and rotors of the law set (one point for a law of one point) */
static void crt_bodies_count(const crt_law *L, int *n_points, int *n_rotors)
{
  if (L->kind == CRT_LAW_BODIES) {
    *n_points = L->n_points;
    *n_rotors = L->n_rotors;
  } else {
    *n_points = 1;
    *n_rotors = 0;
  }
}

/* The first of the bodies' parameters that breaks its rule (CRT_P_*), or -1 (crt_init
   then refuses with CRT_BAD_PARAMETERS): n_points and n_rotors those of the law; each
   point's mass >= 0 and m their sum (to 1e-12 of it); each rotor's axis a unit vector (to
   1e-9) and its axial moment >= 0. */
static int crt_bodies_fault(const crt_law *L, const double *prm)
{
  double total = 0.0;
  int n_points, n_rotors, j;
  crt_bodies_count(L, &n_points, &n_rotors);
  if (prm[CRT_P_n_points] != (double)n_points) return CRT_P_n_points;
  if (prm[CRT_P_n_rotors] != (double)n_rotors) return CRT_P_n_rotors;
  for (j = 0; j < n_points; ++j) {
    if (!(prm[CRT_P_m_1 + j] >= 0.0)) return CRT_P_m_1 + j;
    total += prm[CRT_P_m_1 + j];
  }
  if (!(fabs(prm[CRT_P_m] - total) <= 1e-12 * total)) return CRT_P_m;
  for (j = 0; j < n_rotors; ++j) {
    const double *a = prm + CRT_P_a_1_x + 3 * j;
    if (!(fabs(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] - 1.0) <= 2e-9)) return CRT_P_a_1_x + 3 * j;
    if (!(prm[CRT_P_I_1 + j] >= 0.0)) return CRT_P_I_1 + j;
  }
  return -1;
}

/* the moments u[MODEL_MOMENTS_COUNT] of the bodies whose law gave b (crt_law_eval) */
static void crt_bodies_sum(const crt_law *L, const double *prm, const double *b, double *u)
{
  double share[MODEL_MOMENTS_COUNT], spin[6];
  int n_points, n_rotors, i, j;
  crt_bodies_count(L, &n_points, &n_rotors);
  /* the first point's share written in place (no zeroing, no sum of one: the stores and
     their loads alike in width, which a vectorised zero-and-add was not) */
  if (n_points > 0) point_moments(prm[CRT_P_m_1], b, u);
  else
    for (i = 0; i < MODEL_MOMENTS_COUNT; ++i) u[i] = 0.0;
  for (j = 1; j < n_points; ++j) {
    point_moments(prm[CRT_P_m_1 + j], b + 9 * j, share);
    for (i = 0; i < MODEL_MOMENTS_COUNT; ++i) u[i] += share[i];
  }
  for (j = 0; j < n_rotors; ++j) {
    rotor_moments(prm + CRT_P_a_1_x + 3 * j, prm[CRT_P_I_1 + j], b + 9 * n_points + 3 * j + 1,
                  spin);
    for (i = 0; i < 6; ++i) u[MODEL_MOMENTS_SPIN + i] += spin[i];
  }
}

#endif /* CRT_BODIES_H */
