// The causal autoregressive random field (Haindl & Filip, PAMI 2007, Sec. 4.1-4.2; Haindl &
// Simberova 1992): estimate, neighbourhood selection, synthesis.
#include "methods/car.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>

#include "core/eigen_dense.hpp"
#include "core/random.hpp"

namespace btfgmm::detail {
namespace {

// The offsets at Chebyshev distance `radius` that precede the pixel, row by row.
void add_causal_ring(int radius, std::vector<Offset>& out) {
  for (int dy = -radius; dy <= 0; ++dy)
    for (int dx = -radius; dx <= radius; ++dx) {
      const Offset s{dx, dy};
      if (causal(s) && std::max(std::abs(dx), std::abs(dy)) == radius &&
          std::find(out.begin(), out.end(), s) == out.end())
        out.push_back(s);
    }
}

// The per-channel means of a field.
std::vector<double> channel_means(const Field& y) {
  std::vector<double> m(std::size_t(y.channels), 0.0);
  for (std::size_t i = 0; i < y.values.size(); ++i) m[i % m.size()] += y.values[i];
  for (double& v : m) v /= double(y.pixels());
  return m;
}

// The data matrix Z, a row [Y_r - mean; X_r - mean] for every pixel r whose neighbourhood
// lies inside the field.
Eigen::MatrixXd data_matrix(const Field& y, std::span<const Offset> nb,
                            const std::vector<double>& mean, int margin) {
  int left = margin, right = margin, top = margin;
  for (const Offset& s : nb)
    left = std::max(left, -s.dx), right = std::max(right, s.dx), top = std::max(top, -s.dy);
  const int d = y.channels, cols = d * int(nb.size() + 1);
  const int w = y.width - left - right, h = y.height - top;
  assert(w > 0 && h > 0);
  Eigen::MatrixXd z(Eigen::Index(w) * h, cols);
  Eigen::Index row = 0;
  for (int py = top; py < y.height; ++py)
    for (int px = left; px < y.width - right; ++px, ++row) {
      for (int c = 0; c < d; ++c) z(row, c) = y.at(px, py, c) - mean[std::size_t(c)];
      for (std::size_t k = 0; k < nb.size(); ++k)
        for (int c = 0; c < d; ++c)
          z(row, d * int(k + 1) + c) = y.at(px + nb[k].dx, py + nb[k].dy, c) - mean[std::size_t(c)];
    }
  return z;
}

// Haindl & Simberova 1992's decision rule for a neighbourhood of eta offsets (d-dimensional
// pixels, t rows of data, beta(t) = t with beta(0) = 1; the terms of beta(0) alone, a constant
// of the prior, left out): D = -(d/2) ln|Vxx| - ((beta(t) - eta + d + 2)/2) ln|lambda|
//   + (d^2 eta / 2) ln pi + sum_{i=1..d} ln Gamma((beta(t) - eta + d + 2 - i) / 2).
double decision(double log_det_vxx, double log_det_lambda, int d, std::size_t eta, double t) {
  const double e = double(eta), dd = double(d);
  double sum = 0.0;
  for (int i = 1; i <= d; ++i) sum += std::lgamma((t - e + dd + 2 - i) / 2.0);
  return -dd / 2.0 * log_det_vxx - (t - e + dd + 2) / 2.0 * log_det_lambda +
         dd * dd * e / 2.0 * std::log(std::numbers::pi) + sum;
}

// The largest |dx| or |dy| of a neighbourhood.
int reach_of(std::span<const Offset> nb) {
  int reach = 0;
  for (const Offset& s : nb) reach = std::max({reach, std::abs(s.dx), std::abs(s.dy)});
  return reach;
}

}  // namespace

std::vector<Offset> causal_neighbourhood(int order) {
  std::vector<Offset> out = {{-1, 0}, {0, -1}};
  if (order >= 2) out.insert(out.end(), {{-1, -1}, {1, -1}});
  if (order >= 3) out.insert(out.end(), {{-2, 0}, {0, -2}});
  if (order >= 4) add_causal_ring(2, out);
  if (order >= 5) add_causal_ring(3, out);
  return out;
}

std::size_t CarModel::parameter_count() const {
  const std::size_t dd = std::size_t(d);
  return dd * dd * eta() + dd * (dd + 1) / 2 + dd;
}

CarModel estimate_car(const Field& y, std::span<const Offset> neighbourhood, int margin) {
  for ([[maybe_unused]] const Offset& s : neighbourhood) assert(causal(s));
  CarModel m;
  m.d = y.channels;
  m.neighbourhood.assign(neighbourhood.begin(), neighbourhood.end());
  m.mean = channel_means(y);
  const Eigen::MatrixXd z = data_matrix(y, neighbourhood, m.mean, margin);
  const Eigen::Index d = m.d, n = z.cols() - d;
  assert(z.rows() > z.cols());
  const Eigen::MatrixXd v = z.transpose() * z;  // V = sum_r [Y; X][Y; X]^T
  Eigen::MatrixXd vxx = v.bottomRightCorner(n, n);
  vxx.diagonal().array() += 1e-12 * vxx.trace() / double(n);  // V0: a vanishing prior
  const Eigen::MatrixXd vxy = v.bottomLeftCorner(n, d);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(vxx);
  const Eigen::MatrixXd gamma_t = ldlt.solve(vxy);  // gamma^T = Vxx^-1 Vxy
  const Eigen::MatrixXd lambda = v.topLeftCorner(d, d) - vxy.transpose() * gamma_t;
  const double t = double(z.rows());
  m.gamma.resize(std::size_t(d * n));
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      m.gamma.data(), d, n) = gamma_t.transpose();
  m.sigma.resize(std::size_t(d * d));
  Eigen::Map<Eigen::MatrixXd>(m.sigma.data(), d, d) = lambda / t;  // beta(t) = t
  const double log_det_vxx = ldlt.vectorD().array().abs().log().sum();
  const double log_det_lambda = std::log(std::max(lambda.determinant(), 1e-300));
  m.decision = decision(log_det_vxx, log_det_lambda, m.d, m.eta(), t);
  return m;
}

CarModel select_car(const Field& y, int max_order) {
  // The largest order the image can take, whose margin every candidate then shares: each
  // is estimated on the same pixels, so that their decisions compare.
  int top = 1;
  for (int order = 2; order <= max_order; ++order) {
    const auto nb = causal_neighbourhood(order);
    const int reach = reach_of(nb);
    const double rows = double(y.width - 2 * reach) * double(y.height - reach);
    if (rows < 4.0 * double(y.channels * int(nb.size() + 1))) break;
    top = order;
  }
  const int margin = reach_of(causal_neighbourhood(top));
  CarModel best = estimate_car(y, causal_neighbourhood(1), margin);
  for (int order = 2; order <= top; ++order) {
    CarModel m = estimate_car(y, causal_neighbourhood(order), margin);
    if (m.decision > best.decision) best = std::move(m);
  }
  return best;
}

std::vector<double> white_noise(std::size_t n, std::uint64_t seed) {
  SplitMix64 rng(mix64(seed ^ 0x6361722D6E6F6973ULL));
  std::vector<double> out(n);
  for (std::size_t i = 0; i < n; i += 2) {
    const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
    const double r = std::sqrt(-2.0 * std::log(u1)), a = 2.0 * std::numbers::pi * u2;
    out[i] = r * std::cos(a);
    if (i + 1 < n) out[i + 1] = r * std::sin(a);
  }
  return out;
}

std::vector<double> cholesky_factor(std::span<const double> sigma, int d) {
  Eigen::MatrixXd s = Eigen::Map<const Eigen::MatrixXd>(sigma.data(), d, d);
  s = 0.5 * (s + s.transpose());
  Eigen::LLT<Eigen::MatrixXd> llt(s);
  for (double ridge = 1e-9; llt.info() != Eigen::Success && ridge < 1e9; ridge *= 10)
    llt.compute(s + Eigen::MatrixXd::Identity(d, d) * ridge * std::max(s.trace(), 1e-12));
  std::vector<double> out(std::size_t(d * d), 0.0);
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      out.data(), d, d) = llt.matrixL().toDenseMatrix();
  return out;
}

Field synthesise_car(const CarModel& m, int width, int height, std::uint64_t seed, int passes) {
  const int d = m.d;
  const std::size_t eta = m.eta(), n = std::size_t(d) * eta;
  const std::vector<double> l = cholesky_factor(m.sigma, d);
  Field y(width, height, d);  // mean 0 while synthesising
  std::vector<double> x(n);
  const std::vector<double> eps = white_noise(y.values.size(), mix64(seed));
  for (int pass = 0; pass < passes; ++pass) {
    for (int py = 0; py < height; ++py)
      for (int px = 0; px < width; ++px) {
        for (std::size_t k = 0; k < eta; ++k)
          for (int c = 0; c < d; ++c)
            x[k * std::size_t(d) + std::size_t(c)] =
                y.wrapped(px + m.neighbourhood[k].dx, py + m.neighbourhood[k].dy, c);
        const double* e = &eps[y.index(px, py)];
        for (int c = 0; c < d; ++c) {
          const double* g = &m.gamma[std::size_t(c) * n];
          double v = 0.0;
          for (std::size_t j = 0; j < n; ++j) v += g[j] * x[j];
          for (int j = 0; j <= c; ++j) v += l[std::size_t(c * d + j)] * e[j];
          y.at(px, py, c) = v;
        }
      }
  }
  // The level's mean restored: the field's own mean, which a model near its unit root lets
  // wander, replaced by the model's.
  const std::vector<double> drift = channel_means(y);
  for (std::size_t i = 0; i < y.values.size(); ++i)
    y.values[i] += m.mean[i % std::size_t(d)] - drift[i % std::size_t(d)];
  return y;
}

constexpr int kStabilitySide = 128;

double stabilise_car(CarModel& m, double data_trace, int width, int height) {
  // Tested on a field of at least kStabilitySide pixels a side: an estimate past its unit root
  // grows along the raster order, slowly enough on a coarse level's few pixels to pass there
  // and blow up in a synthesis of a larger size.
  const int w = std::max(width, kStabilitySide), h = std::max(height, kStabilitySide);
  double factor = 1.0;
  for (int attempt = 0; attempt < 60; ++attempt) {
    const Field f = synthesise_car(m, w, h, 1);
    const std::vector<double> mean = channel_means(f);
    double trace = 0.0;
    for (std::size_t i = 0; i < f.values.size(); ++i) {
      const double v = f.values[i] - mean[i % mean.size()];
      trace += v * v;
    }
    trace /= double(f.pixels());
    if (std::isfinite(trace) && trace <= kMaxVarianceGain * data_trace) {
      // The synthesis is linear in the noise: Sigma scaled by data / synthesis gives this
      // synthesis the data's variance exactly (what the shrink, or an estimate near its unit
      // root, took away or added).
      if (trace > 0.0 && data_trace > 0.0)
        for (double& s : m.sigma) s *= data_trace / trace;
      return factor;
    }
    for (double& g : m.gamma) g *= 0.95;
    factor *= 0.95;
  }
  return factor;
}

std::string neighbourhood_text(std::span<const Offset> n) {
  std::vector<std::string> parts;
  for (const Offset& s : n) parts.push_back(fmt::format("({},{})", s.dx, s.dy));
  return fmt::format("{} neighbours {}", n.size(), fmt::join(parts, " "));
}

}  // namespace btfgmm::detail
