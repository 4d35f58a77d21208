/*
 * A controller-style fixed-step loop built against generated/c alone (no Python in the
 * build): the vertical model stepped with RK4, the impact map applied when the gap of a
 * spherical shell closes, and |K| (E1.9) checked constant between impacts.
 *
 * Exit status 0 when every check holds; the numbers are printed either way.
 */
#include <math.h>
#include <stdio.h>

#include "carrier.h"

#define NQ 8

/* point law in body axes: x = a sin(w t), y = b cos(v t), z = c sin(k t) */
static void law(double t, double u[9])
{
  const double a = 0.10, w = 3.0, b = 0.05, v = 2.0, c = 0.20, k = 5.0;
  u[0] = a * sin(w * t);          u[1] = b * cos(v * t);          u[2] = c * sin(k * t);
  u[3] = a * w * cos(w * t);      u[4] = -b * v * sin(v * t);     u[5] = c * k * cos(k * t);
  u[6] = -a * w * w * sin(w * t); u[7] = -b * v * v * cos(v * t); u[8] = -c * k * k * sin(k * t);
}

static void rhs(double t, const double *q, const double *p, double *dq)
{
  double u[9];
  law(t, u);
  carrier_vertical_flight_rhs(q, u, p, dq);
}

static void rk4(double t, double dt, double *q, const double *p)
{
  double k1[NQ], k2[NQ], k3[NQ], k4[NQ], tmp[NQ];
  int i;
  rhs(t, q, p, k1);
  for (i = 0; i < NQ; ++i) tmp[i] = q[i] + 0.5 * dt * k1[i];
  rhs(t + 0.5 * dt, tmp, p, k2);
  for (i = 0; i < NQ; ++i) tmp[i] = q[i] + 0.5 * dt * k2[i];
  rhs(t + 0.5 * dt, tmp, p, k3);
  for (i = 0; i < NQ; ++i) tmp[i] = q[i] + dt * k3[i];
  rhs(t + dt, tmp, p, k4);
  for (i = 0; i < NQ; ++i) q[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
}

static double kinetic_moment_norm(double t, const double *q, const double *p)
{
  double u[9], K[3];
  law(t, u);
  carrier_vertical_kinetic_moment(q, u, p, K);
  return sqrt(K[0] * K[0] + K[1] * K[1] + K[2] * K[2]);
}

int main(void)
{
  const double p[6] = {1.0, 0.3, 0.10, 0.12, 0.14, 9.81};   /* M, m, J_x, J_y, J_z, g */
  const double center[3] = {0.02, -0.01, 0.03}, radius = 0.5, e = 0.8;
  const double dt = 1e-3, t_end = 3.0;
  /* Z_C, Z_C', omega, n (a unit vector, tilted) */
  double q[NQ] = {1.2, 0.0, 0.8, -0.5, 2.0, 0.0, 0.0, 0.0};
  double t = 0.0, k_ref, worst_drift = 0.0, largest_jump = 0.0, h_before = 1.0;
  int impacts = 0, steps = 0, failures = 0;
  const double tilt = 0.3;
  q[5] = sin(tilt); q[6] = 0.0; q[7] = cos(tilt);
  k_ref = kinetic_moment_norm(t, q, p);

  while (t < t_end - 0.5 * dt) {
    double u[9], s[3], h, v_n;
    rk4(t, dt, q, p);
    t += dt;
    ++steps;
    {
      const double k_now = kinetic_moment_norm(t, q, p);
      const double drift = fabs(k_now - k_ref) / k_ref;
      if (drift > worst_drift) worst_drift = drift;
    }
    law(t, u);
    carrier_lowest_point_sphere(q + 5, center, radius, s);
    carrier_vertical_gap(q, u, s, p, &h, &v_n);
    /* the gap closes: it changed sign over the step and S moves down */
    if (h < 0.0 && h_before >= 0.0 && v_n < 0.0) {
      double q_plus[NQ], impulse, v_after, h_after, k_after;
      int i;
      carrier_vertical_impact(q, u, s, p, e, q_plus, &impulse);
      carrier_vertical_gap(q_plus, u, s, p, &h_after, &v_after);
      if (!(impulse > 0.0) || fabs(v_after + e * v_n) > 1e-12 * (1.0 + fabs(v_n))) {
        printf("impact %d violates Newton's law: I=%g v-=%g v+=%g\n", impacts, impulse,
               v_n, v_after);
        ++failures;
      }
      for (i = 0; i < NQ; ++i) q[i] = q_plus[i];
      k_after = kinetic_moment_norm(t, q, p);
      if (fabs(k_after - k_ref) / k_ref > largest_jump)
        largest_jump = fabs(k_after - k_ref) / k_ref;
      k_ref = k_after;             /* |K| is constant again until the next impact */
      ++impacts;
    }
    h_before = h;
  }
  printf("steps %d, impacts %d, max relative drift of |K| between impacts %.3e, "
         "largest relative jump of |K| at an impact %.3e, |n| - 1 = %.3e\n",
         steps, impacts, worst_drift, largest_jump,
         sqrt(q[5] * q[5] + q[6] * q[6] + q[7] * q[7]) - 1.0);
  if (impacts < 2) { printf("FAIL: expected at least two impacts\n"); ++failures; }
  if (worst_drift > 1e-9) { printf("FAIL: |K| drifts between impacts\n"); ++failures; }
  if (largest_jump < 1e-3) { printf("FAIL: the impacts did not change |K|\n"); ++failures; }
  return failures ? 1 : 0;
}
