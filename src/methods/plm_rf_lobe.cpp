// One Lafortune lobe per texel, view and channel (Filip, Haindl 2004, step 1; the lobe of
// Lafortune, Foo, Torrance, Greenberg 1997 with the view folded into its coefficients),
// fitted by Levenberg-Marquardt (Marquardt 1963: damping scaled by the normal matrix's
// diagonal).
#include "methods/plm_rf_lobe.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>
#include "core/eigen_dense.hpp"

#include "btfgmm/methods/plm_rf.hpp"

namespace btfgmm {

float lafortune_lobe(float rho, float cx, float cy, float cz, float n, const Vec3& w) {
  const float b = cx * float(w.x) + cy * float(w.y) + cz * float(w.z);
  return b > 0.0f ? rho * std::pow(b, n) : 0.0f;
}

namespace detail {

void lobe_image(const float* lobes, std::size_t n, const Vec3& w, float* out) {
  const float* rho = lobes;
  const float *cx = lobes + n, *cy = lobes + 2 * n, *cz = lobes + 3 * n, *e = lobes + 4 * n;
  for (std::size_t j = 0; j < n; ++j) out[j] = lafortune_lobe(rho[j], cx[j], cy[j], cz[j], e[j], w);
}

namespace {

using Params = std::array<double, 5>;  // rho, cx, cy, cz, n
using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat5 = Eigen::Matrix<double, 5, 5>;

double lobe_value(const Params& p, const Vec3& w) {
  const double b = p[1] * w.x + p[2] * w.y + p[3] * w.z;
  return b > 0.0 ? p[0] * std::pow(b, p[4]) : 0.0;
}

double squared_error(const Params& p, std::span<const Vec3> w, std::span<const double> y) {
  double sum = 0.0;
  for (std::size_t i = 0; i < w.size(); ++i) {
    const double r = lobe_value(p, w[i]) - y[i];
    sum += r * r;
  }
  return sum;
}

// The lobe's value at w and its gradient in (rho, cx, cy, cz, n).
double lobe_gradient(const Params& p, const Vec3& w, Vec5& g) {
  g.setZero();
  const double b = p[1] * w.x + p[2] * w.y + p[3] * w.z;
  if (!(b > 0.0)) return 0.0;
  const double bn = std::pow(b, p[4]), value = p[0] * bn;
  g(0) = bn;
  if (b > 1e-12) {
    const double d = p[0] * p[4] * bn / b;
    g(1) = d * w.x;
    g(2) = d * w.y;
    g(3) = d * w.z;
    g(4) = value * std::log(b);
  }
  return value;
}

// Back to the stored form without changing the function: the axis to unit length (rho takes
// its scale), n into [0, kMaxLobeExponent], rho >= 0. False when the axis vanished.
bool normalise(Params& p) {
  const double len = std::sqrt(p[1] * p[1] + p[2] * p[2] + p[3] * p[3]);
  if (!(len > 1e-12) || !std::isfinite(len)) return false;
  p[4] = std::clamp(p[4], 0.0, kMaxLobeExponent);
  p[0] = std::max(0.0, p[0] * std::pow(len, p[4]));
  for (int k = 1; k <= 3; ++k) p[std::size_t(k)] /= len;
  return std::isfinite(p[0]);
}

// The best start on a grid of axes and exponents, rho in closed form for each.
Params start_values(std::span<const Vec3> w, std::span<const double> y) {
  std::size_t brightest = 0;
  Vec3 mean;
  double syy = 0.0;
  for (std::size_t i = 0; i < w.size(); ++i) {
    if (y[i] > y[brightest]) brightest = i;
    const double q = y[i] > 0.0 ? y[i] * y[i] : 0.0;
    mean.x += q * w[i].x;
    mean.y += q * w[i].y;
    mean.z += q * w[i].z;
    syy += y[i] * y[i];
  }
  const std::array<Vec3, 3> axes = {w[brightest], mean, Vec3{0.0, 0.0, 1.0}};
  Params best = {0.0, 0.0, 0.0, 1.0, 1.0};
  double best_cost = syy;
  for (const Vec3& axis : axes)
    for (double n : {0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0}) {
      Params p = {1.0, axis.x, axis.y, axis.z, n};
      if (!normalise(p)) continue;
      p[0] = 1.0;
      double sff = 0.0, sfy = 0.0;
      for (std::size_t i = 0; i < w.size(); ++i) {
        const double f = lobe_value(p, w[i]);
        sff += f * f;
        sfy += f * y[i];
      }
      if (!(sff > 0.0) || !(sfy > 0.0)) continue;
      p[0] = sfy / sff;
      const double cost = syy - p[0] * sfy;
      if (cost < best_cost) {
        best_cost = cost;
        best = p;
      }
    }
  return best;
}

// The normal equations' matrix J^T J and J^T r at p.
void normal_equations(const Params& p, std::span<const Vec3> w, std::span<const double> y,
                      Mat5& jtj, Vec5& jtr) {
  jtj.setZero();
  jtr.setZero();
  Vec5 g;
  for (std::size_t i = 0; i < w.size(); ++i) {
    const double r = lobe_gradient(p, w[i], g) - y[i];
    jtj.selfadjointView<Eigen::Lower>().rankUpdate(g);
    jtr += g * r;
  }
  jtj = jtj.selfadjointView<Eigen::Lower>();
}

}  // namespace

LobeParameters fit_lafortune_lobe(std::span<const Vec3> w, std::span<const double> y,
                                  int iterations) {
  Params p = start_values(w, y);
  double cost = squared_error(p, w, y), lambda = 1e-3;
  Mat5 jtj;
  Vec5 jtr;
  for (int it = 0; it < iterations && cost > 0.0; ++it) {
    normal_equations(p, w, y, jtj, jtr);
    const double floor = 1e-12 * std::max(jtj.diagonal().maxCoeff(), 1e-300);
    bool accepted = false;
    const double before = cost;
    while (!accepted && lambda < 1e12) {
      Mat5 a = jtj;
      for (int k = 0; k < 5; ++k) a(k, k) += lambda * std::max(jtj(k, k), floor);
      const Vec5 step = a.ldlt().solve(-jtr);
      Params q = p;
      for (std::size_t k = 0; k < 5; ++k) q[k] += step(Eigen::Index(k));
      const double c = normalise(q) ? squared_error(q, w, y) : cost;
      if (c < cost) {
        p = q;
        cost = c;
        lambda = std::max(lambda * 0.3, 1e-12);
        accepted = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!accepted || before - cost <= 1e-12 * before) break;
  }
  return {p[0], p[1], p[2], p[3], p[4]};
}

}  // namespace detail
}  // namespace btfgmm
