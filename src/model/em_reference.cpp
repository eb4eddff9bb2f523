// The reference EM: Eq. (3)-(7) of the paper written out plainly on an explicit N x 9
// sample matrix, in double. It is the readable statement the fast grid path (em.cpp) is
// checked against, and it fits samples that do not lie on a grid (tests).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/mixture.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm {

namespace {

// log w_m + log F(x | mu_m, sigma_m), Eq. (2) in the log domain.
double log_weighted_density(const ProductMixture& mix, std::size_t m, const double* x) {
  double l = std::log(mix.weight[m]) - 0.5 * kVariables * std::log(2.0 * std::numbers::pi);
  for (int n = 0; n < kVariables; ++n) {
    const double d = x[n] - mix.mean[m][n];
    l -= 0.5 * d * d / mix.var[m][n] + 0.5 * std::log(mix.var[m][n]);
  }
  return l;
}

}  // namespace

double mean_log_likelihood(std::span<const double> samples, const ProductMixture& mixture) {
  const std::size_t n = samples.size() / kVariables;
  std::vector<double> l(mixture.size());
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t m = 0; m < mixture.size(); ++m)
      l[m] = log_weighted_density(mixture, m, &samples[i * kVariables]);
    const double mx = *std::max_element(l.begin(), l.end());
    double s = 0.0;
    for (double v : l) s += std::exp(v - mx);
    total += mx + std::log(s);
  }
  return total / double(n);
}

EmResult fit_em_reference(std::span<const double> samples, ProductMixture& mix,
                          const EmConfig& config, const EmCallback& progress) {
  detail::check_em_input(samples.size() / kVariables, mix, config);
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = samples.size() / kVariables;
  EmResult result;
  std::vector<double> l(mix.size()), q(mix.size());
  for (int it = 1; it <= config.max_iterations; ++it) {
    const std::size_t m_count = mix.size();
    // Sufficient statistics: sum q, sum q (x - mu_old), sum q (x - mu_old)^2.
    std::vector<double> s0(m_count, 0.0);
    std::vector<std::array<double, kVariables>> s1(m_count), s2(m_count);
    for (auto& a : s1) a.fill(0.0);
    for (auto& a : s2) a.fill(0.0);
    double total = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double* x = &samples[i * kVariables];
      // Eq. (4): q(m|x) = w_m F(x|m) / sum_j w_j F(x|j), by log-sum-exp.
      for (std::size_t m = 0; m < m_count; ++m) l[m] = log_weighted_density(mix, m, x);
      const double mx = *std::max_element(l.begin(), l.begin() + m_count);
      double s = 0.0;
      for (std::size_t m = 0; m < m_count; ++m) s += (q[m] = std::exp(l[m] - mx));
      total += mx + std::log(s);  // Eq. (3)
      for (std::size_t m = 0; m < m_count; ++m) {
        const double qm = q[m] / s;
        s0[m] += qm;
        for (int v = 0; v < kVariables; ++v) {
          const double d = x[v] - mix.mean[m][v];
          s1[m][v] += qm * d;
          s2[m][v] += qm * d * d;
        }
      }
    }
    const double ll = total / double(n);
    // Eq. (5)-(7), the variance from the shifted sums, floored; vanished components dropped.
    const std::size_t dropped = detail::m_step(mix, s0, s1, s2, double(n), config.variance_floor,
                                               config.min_component_samples);
    result.dropped += dropped;
    detail::record_iteration(result, ll, it, config, mix.size(), t0, progress);
    if (result.converged) break;
  }
  result.final_log_likelihood = mean_log_likelihood(samples, mix);
  return result;
}

}  // namespace btfgmm
