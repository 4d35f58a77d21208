// The re-planning controller that `derive control` writes, compiled into a C++17 program
// with its own loop, as a robot's flight computer would run it: no Python, no runtime.
//
// The plant: the landing of derive/control/examples/land_push.toml (a sphere of radius
// 0.2 m dropped from 2 m with a tumble), 10 % heavier than the controller's model, its
// omega kicked at t = 0.2 s; stepped by RK4 (1e-4 s) on the generated flight RHS
// (carrier_general_flight_rhs), the gap of the sphere's lowest point watched
// (carrier_general_gap).  Every 20 ms the controller reads the state and returns the
// point's law as cubic segments from then on; the loop plays them (u and its first two
// derivatives, the RHS reads all nine).
//
// Exit status 0 when the body touches down within 2 deg of upright (the target) and the
// law the controller returned always continued the one in use (x, x' to 1e-12); the
// numbers are printed either way.
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "carrier.h"
#include "controller.h"

namespace {

constexpr int kNq = 18;
constexpr double kPeriod = 0.02, kStep = 1e-4, kRadius = 0.2;

// The law in use: cubic segments (knots, 12 coefficients per interval: x, y, z, each
// c0 s^3 + c1 s^2 + c2 s + c3 with s = t - knot); beyond the last knot the last cubic.
struct Law {
  std::vector<double> knots{0.0, 1.0};
  std::vector<double> coef = std::vector<double>(12, 0.0);   // P at rest at O
  void at(double t, double u[9]) const {
    std::size_t i = 0;
    while (i + 2 < knots.size() && t >= knots[i + 1]) ++i;
    const double s = t - knots[i];
    for (int c = 0; c < 3; ++c) {
      const double *k = &coef[12 * i + 4 * c];
      u[c] = ((k[0] * s + k[1]) * s + k[2]) * s + k[3];
      u[3 + c] = (3.0 * k[0] * s + 2.0 * k[1]) * s + k[2];
      u[6 + c] = 6.0 * k[0] * s + 2.0 * k[1];
    }
  }
};

void rhs(const Law &law, double t, const double *q, const double *p, double *dq) {
  double u[9];
  law.at(t, u);
  carrier_general_flight_rhs(q, u, p, dq);
}

void rk4(const Law &law, double t, double h, double *q, const double *p) {
  double k1[kNq], k2[kNq], k3[kNq], k4[kNq], y[kNq];
  rhs(law, t, q, p, k1);
  for (int i = 0; i < kNq; ++i) y[i] = q[i] + 0.5 * h * k1[i];
  rhs(law, t + 0.5 * h, y, p, k2);
  for (int i = 0; i < kNq; ++i) y[i] = q[i] + 0.5 * h * k2[i];
  rhs(law, t + 0.5 * h, y, p, k3);
  for (int i = 0; i < kNq; ++i) y[i] = q[i] + h * k3[i];
  rhs(law, t + h, y, p, k4);
  for (int i = 0; i < kNq; ++i) q[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
}

double gap(const Law &law, double t, const double *q, const double *p) {
  double u[9], s[3], h, v_n;
  const double center[3] = {0.0, 0.0, 0.0};
  law.at(t, u);
  carrier_lowest_point_sphere(q + 15, center, kRadius, s);
  carrier_general_gap(q, u, s, p, &h, &v_n);
  return h;
}

}  // namespace

int main() {
  // the plant: M 10 % above the model's 1.0 kg (the controller keeps 1.0)
  const double p[6] = {1.1, 0.5, 0.014, 0.016, 0.018, 9.81};
  // [initial] of the task: C at 2 m moving at 0.2 m/s, omega, the attitude of the
  // quaternion (0.98, 0.1, -0.15, 0.08) normalised
  double q[kNq] = {0.0, 0.0, 2.0, 0.2, 0.0, 0.0, 0.4, -0.3, 0.6};
  {
    double w = 0.98, a = 0.1, b = -0.15, c = 0.08;
    const double n = std::sqrt(w * w + a * a + b * b + c * c);
    w /= n; a /= n; b /= n; c /= n;
    const double A[9] = {1 - 2 * (b * b + c * c), 2 * (a * b - w * c), 2 * (a * c + w * b),
                         2 * (a * b + w * c), 1 - 2 * (a * a + c * c), 2 * (b * c - w * a),
                         2 * (a * c - w * b), 2 * (b * c + w * a), 1 - 2 * (a * a + b * b)};
    for (int i = 0; i < 9; ++i) q[9 + i] = A[i];
  }
  // the controller's memory: the caller's, once (ctl_sizeof() bytes, aligned for a double)
  std::vector<double> memory(static_cast<std::size_t>(ctl_sizeof()) / sizeof(double) + 1);
  ctl_init(memory.data());

  Law law;
  std::vector<double> knots(CTL_KNOTS), coef(12 * (CTL_KNOTS - 1));
  double t = 0.0, next_call = 0.0, worst_jump = 0.0;
  long k = 0;
  int laws = 0, calls = 0;
  bool kicked = false;
  while (t < 1.5) {
    if (t >= next_call - 1e-12) {           // a sample: read, re-plan, play
      double u[9];
      law.at(t, u);
      crt_call call{t, k == 0 ? 0 : 1, 0, kNq, q, u, k};
      int n = 0;
      ++k;
      ++calls;
      const int r = ctl_controller(memory.data(), &call, CTL_KNOTS, &n, knots.data(),
                                   coef.data());
      if (r < 0) { std::printf("FAIL: the controller refused the call at t = %g\n", t); return 1; }
      if (r == 1) {
        law.knots.assign(knots.begin(), knots.begin() + n);
        law.coef.assign(coef.begin(), coef.begin() + 12 * (n - 1));
        double v[9];
        law.at(t, v);
        for (int i = 0; i < 6; ++i) worst_jump = std::fmax(worst_jump, std::fabs(v[i] - u[i]));
        ++laws;
      }
      next_call += kPeriod;
    }
    if (!kicked && t >= 0.2 - 1e-12) {       // a kick: omega changed at once
      q[6] += 0.3;
      q[7] -= 0.2;
      kicked = true;
    }
    double before[kNq];
    for (int i = 0; i < kNq; ++i) before[i] = q[i];
    const double h = std::fmin(kStep, next_call - t);
    rk4(law, t, h, q, p);
    if (gap(law, t + h, q, p) < 0.0) {        // touchdown within this step: bisect
      double lo = 0.0, hi = h;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        double y[kNq];
        for (int i = 0; i < kNq; ++i) y[i] = before[i];
        rk4(law, t, mid, y, p);
        (gap(law, t + mid, y, p) > 0.0 ? lo : hi) = mid;
      }
      for (int i = 0; i < kNq; ++i) q[i] = before[i];
      rk4(law, t, hi, q, p);
      t += hi;
      // the angle between the attitude and the target (the identity): trace A = 1 + 2 cos
      const double c = 0.5 * (q[9] + q[13] + q[17] - 1.0);
      const double angle = std::acos(std::fmax(-1.0, std::fmin(1.0, c))) * 180.0 / std::acos(-1.0);
      long stats[CTL_NSTATS];
      ctl_stats(memory.data(), stats);
      std::printf("touchdown at t = %.6f s, %.3f deg from upright; %d calls, %d laws, %ld "
                  "QPs without a solution; worst jump of x, x' at a call %.2e\n",
                  t, angle, calls, laws, stats[CTL_STAT_FAILURES], worst_jump);
      const bool ok = angle < 2.0 && worst_jump < 1e-12 && laws > 10;
      std::printf("%s\n", ok ? "ok" : "FAIL");
      return ok ? 0 : 1;
    }
    t += h;
  }
  std::printf("FAIL: no touchdown\n");
  return 1;
}
