// The generated library from C++17, as a robotics code base would use it: the header
// included by a C++ translation unit, the plain functions and CasADi's ABI called from
// C++, the derivatives read through their sparsity patterns.
//
// 1. jac_vertical_flight_rhs (derive/jacobians.py: generic forward differentiation of
//    the flight RHS) through the CasADi ABI, block d dq/d q densified from its pattern,
//    against carrier_vertical_flight_jacobian (derive/models.py: flight_jacobian, written
//    out by hand): two derivations of the same matrix, to 1e-12.
// 2. carrier_jac_general_impact, blocks d q_plus/d q and d I/d q, against central
//    differences of carrier_general_impact, to 1e-6.
//
// Exit status 0 when every check holds; the worst errors are printed either way.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "carrier.h"

namespace {

struct Rng {
  std::uint64_t state = 88172645463325252ULL;
  double uniform(double lo, double hi) {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return lo + (hi - lo) * static_cast<double>(state >> 11) / 9007199254740992.0;
  }
};

// A block of a jac_ function as a dense row-major matrix, from CasADi's compressed
// pattern: {rows, cols, 1} when dense, else {rows, cols, colind[cols + 1], row[nnz]}.
std::vector<double> densify(const casadi_int *sp, const double *nz, casadi_int &rows,
                            casadi_int &cols) {
  rows = sp[0];
  cols = sp[1];
  std::vector<double> out(static_cast<std::size_t>(rows * cols), 0.0);
  if (sp[2] == 1 && rows * cols != 0) {
    for (casadi_int c = 0; c < cols; ++c)
      for (casadi_int r = 0; r < rows; ++r) out[r * cols + c] = nz[c * rows + r];
    return out;
  }
  const casadi_int *colind = sp + 2, *row = sp + 2 + cols + 1;
  for (casadi_int c = 0; c < cols; ++c)
    for (casadi_int k = colind[c]; k < colind[c + 1]; ++k) out[row[k] * cols + c] = nz[k];
  return out;
}

struct State {
  std::array<double, 18> q;   // general layout
  std::array<double, 9> u;
  std::array<double, 6> p;
  std::array<double, 3> s;
  double e;
};

State random_state(Rng &rng) {
  State x{};
  const double b0 = rng.uniform(0.02, 1.0), b1 = rng.uniform(0.02, 1.0),
               b2 = rng.uniform(0.02, 1.0);
  x.p = {rng.uniform(0.5, 5.0), rng.uniform(0.05, 2.0), b1 + b2, b0 + b2, b0 + b1, 9.81};
  // a rotation from a random unit quaternion: a_ij = cos(fixed i, body j)
  double w = rng.uniform(-1, 1), a = rng.uniform(-1, 1), b = rng.uniform(-1, 1),
         c = rng.uniform(-1, 1);
  const double norm = std::sqrt(w * w + a * a + b * b + c * c);
  w /= norm; a /= norm; b /= norm; c /= norm;
  const double R[9] = {1 - 2 * (b * b + c * c), 2 * (a * b - w * c), 2 * (a * c + w * b),
                       2 * (a * b + w * c), 1 - 2 * (a * a + c * c), 2 * (b * c - w * a),
                       2 * (a * c - w * b), 2 * (b * c + w * a), 1 - 2 * (a * a + b * b)};
  for (int i = 0; i < 6; ++i) x.q[i] = rng.uniform(-1, 1);
  for (int i = 6; i < 9; ++i) x.q[i] = rng.uniform(-2, 2);
  for (int i = 0; i < 9; ++i) x.q[9 + i] = R[i];
  for (auto &v : x.u) v = rng.uniform(-1, 1);
  for (auto &v : x.s) v = rng.uniform(-1, 1);
  x.e = rng.uniform(0, 1);
  return x;
}

double relative(const std::vector<double> &a, const std::vector<double> &b) {
  double err = 0.0, scale = 1.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    err = std::max(err, std::fabs(a[i] - b[i]));
    scale = std::max(scale, std::fabs(b[i]));
  }
  return err / scale;
}

// check 1: the CasADi ABI of jac_vertical_flight_rhs against the hand-derived Jacobian
double flight_jacobians_agree(const State &x) {
  constexpr int n = 8;
  const double qv[n] = {x.q[2], x.q[5], x.q[6], x.q[7], x.q[8], x.q[15], x.q[16], x.q[17]};
  double A[n * n];
  carrier_vertical_flight_jacobian(qv, x.u.data(), x.p.data(), A);

  casadi_int n_arg = 0, n_res = 0, n_iw = 0, n_w = 0;
  jac_vertical_flight_rhs_work(&n_arg, &n_res, &n_iw, &n_w);
  if (n_arg != vertical_flight_rhs_n_in() + vertical_flight_rhs_n_out() || n_res != 3)
    return 1.0;
  std::vector<std::vector<double>> blocks(static_cast<std::size_t>(n_res));
  std::vector<double *> res(static_cast<std::size_t>(n_res));
  for (casadi_int k = 0; k < n_res; ++k) {
    const casadi_int *sp = jac_vertical_flight_rhs_sparsity_out(k);
    const casadi_int nnz = sp[2] == 1 ? sp[0] * sp[1] : sp[2 + sp[1]];
    blocks[k].assign(static_cast<std::size_t>(nnz), 0.0);
    res[k] = blocks[k].data();
  }
  const double *arg[4] = {qv, x.u.data(), x.p.data(), nullptr};   // nominal dq: not read
  if (jac_vertical_flight_rhs(arg, res.data(), nullptr, nullptr, 0) != 0) return 1.0;
  casadi_int rows = 0, cols = 0;
  const std::vector<double> dense =
      densify(jac_vertical_flight_rhs_sparsity_out(0), blocks[0].data(), rows, cols);
  if (rows != n || cols != n) return 1.0;
  return relative(dense, std::vector<double>(A, A + n * n));
}

// check 2: the impact map's Jacobian in q against central differences
double impact_jacobian_matches_differences(const State &x) {
  // blocks of carrier_jac_general_impact, sized from the ABI's patterns
  std::vector<std::vector<double>> nz;
  for (casadi_int k = 0; k < jac_general_impact_n_out(); ++k) {
    const casadi_int *sp = jac_general_impact_sparsity_out(k);
    nz.emplace_back(static_cast<std::size_t>(sp[2] == 1 ? sp[0] * sp[1] : sp[2 + sp[1]]));
  }
  // block order: (q_plus, I) x (q, u, s, p, e)
  carrier_jac_general_impact(x.q.data(), x.u.data(), x.s.data(), x.p.data(), x.e,
                             nz[0].data(), nz[1].data(), nz[2].data(), nz[3].data(),
                             nz[4].data(), nz[5].data(), nz[6].data(), nz[7].data(),
                             nz[8].data(), nz[9].data());
  casadi_int rows = 0, cols = 0;
  const auto dqp = densify(jac_general_impact_sparsity_out(0), nz[0].data(), rows, cols);
  const auto dI = densify(jac_general_impact_sparsity_out(5), nz[5].data(), rows, cols);
  std::vector<double> fd_qp(18 * 18), fd_I(18), want_qp(dqp), want_I(dI);
  const double h = 1e-6;
  for (int k = 0; k < 18; ++k) {
    std::array<double, 18> plus = x.q, minus = x.q, qp_plus{}, qp_minus{};
    double i_plus = 0.0, i_minus = 0.0;
    plus[k] += h;
    minus[k] -= h;
    carrier_general_impact(plus.data(), x.u.data(), x.s.data(), x.p.data(), x.e,
                           qp_plus.data(), &i_plus);
    carrier_general_impact(minus.data(), x.u.data(), x.s.data(), x.p.data(), x.e,
                           qp_minus.data(), &i_minus);
    for (int i = 0; i < 18; ++i) fd_qp[i * 18 + k] = (qp_plus[i] - qp_minus[i]) / (2 * h);
    fd_I[k] = (i_plus - i_minus) / (2 * h);
  }
  return std::max(relative(fd_qp, want_qp), relative(fd_I, want_I));
}

}  // namespace

int main() {
  Rng rng;
  double worst_flight = 0.0, worst_impact = 0.0;
  for (int it = 0; it < 200; ++it) {
    const State x = random_state(rng);
    worst_flight = std::max(worst_flight, flight_jacobians_agree(x));
    worst_impact = std::max(worst_impact, impact_jacobian_matches_differences(x));
  }
  std::printf("C++ %ld: jac_vertical_flight_rhs vs vertical_flight_jacobian %.2e, "
              "jac_general_impact vs central differences %.2e\n",
              static_cast<long>(__cplusplus), worst_flight, worst_impact);
  int failures = 0;
  if (!(worst_flight < 1e-12)) { std::printf("FAIL: flight Jacobians differ\n"); ++failures; }
  if (!(worst_impact < 1e-6)) { std::printf("FAIL: impact Jacobian\n"); ++failures; }
  return failures ? 1 : 0;
}
