/*
 * crt_math.h: the small arithmetic every part of the runtime shares -- max and min, the
 * unit round-off, and sin and cos together (crt_sincos).  Needs only <math.h> and the
 * constants of crt_constants.h: Darboux-Keller (crt_dk.h) and the law (crt_law.h) build
 * on it alone.
 *
 * Hand-written C: this file is templates/runtime/crt_math.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_MATH_H
#define CRT_MATH_H

#include <math.h>

#include "crt_constants.h"     /* CRT_SINCOS_*: the constants of crt_sincos */

#define CRT_EPS 2.220446049250313e-16     /* double precision unit round-off x 2 */

static inline double crt_max(double a, double b) { return a > b ? a : b; }
static inline double crt_min(double a, double b) { return a < b ? a : b; }

/* sin and cos of x together (derive/emit/sincos.py): Cody and Waite's reduction
   r = x - k pi/2 = hi + lo with pi/2 in three parts (k times the first two exact for
   |k| < 2^20), Taylor polynomials on |r| <= pi/4, the quadrant k mod 4.  Within 0.75
   ulp measured (tests/test_law.py holds it to 1); arguments beyond CRT_SINCOS_MAX and
   non-finite ones go to the C library. */
static inline void crt_sincos(double x, double *s, double *c)
{
  double kd, a, nb, hi, bv, av, lo, z, z2, z4, sr, cr, h, w;
  int quadrant;
  if (!(fabs(x) < CRT_SINCOS_MAX)) {
    *s = sin(x);
    *c = cos(x);
    return;
  }
  kd = floor(x * CRT_SINCOS_TWO_OVER_PI + 0.5);
  quadrant = (int)(kd - 4.0 * floor(0.25 * kd));
  a = x - kd * CRT_SINCOS_PIO2_1;               /* exact (Sterbenz) */
  nb = -(kd * CRT_SINCOS_PIO2_2);               /* exact (33 + 20 bits) */
  hi = a + nb;                                  /* TwoSum: hi + lo = a + nb exactly */
  bv = hi - a;
  av = hi - bv;
  lo = ((a - av) + (nb - bv)) - kd * CRT_SINCOS_PIO2_3;
  /* lo reaches about 20 ulp of hi for |k| near 2^20 (k pi/2 - k (p1 + p2)): the terms
     of first order in lo take cos hi and sin hi to 1e-3, not 1 and hi */
  z = hi * hi;
  z2 = z * z;
  z4 = z2 * z2;
  sr = hi + (hi * z * CRT_SINCOS_SIN_POLY(z, z2, z4)
            + lo * (1.0 - z * (0.5 - z * (1.0 / 24.0))));
  h = 0.5 * z;
  w = 1.0 - h;
  cr = w + (((1.0 - w) - h)
           + (z2 * CRT_SINCOS_COS_POLY(z, z2, z4) - hi * lo * (1.0 - z * (1.0 / 6.0))));
  switch (quadrant) {
    case 0: *s = sr; *c = cr; break;
    case 1: *s = cr; *c = -sr; break;
    case 2: *s = -sr; *c = -cr; break;
    default: *s = -cr; *c = sr; break;
  }
}

#endif /* CRT_MATH_H */
