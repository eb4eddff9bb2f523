// The reference EM: Eq. (3)-(7) of the paper written out plainly on an explicit N x 9
// sample matrix, in double. It is the readable statement the fast grid path (em.cpp) is
// checked against, and it fits samples that do not lie on a grid (tests).
#include <span>
#include <vector>

#include "btfgmm/core/text.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/em_reference.hpp"
#include "btfgmm/model/mixture.hpp"
#include "model/mixture_internal.hpp"
#include "model/responsibilities.hpp"

namespace btfgmm {

namespace {

// log w_m F(x | m) of every component for the sample x, Eq. (2), into l; then Eq. (4):
// the responsibilities into q. Returns the sample's term of L, Eq. (3).
double e_step(const ProductMixture& mix, const double* x, const detail::Periods& periods,
              std::vector<double>& l, std::vector<double>& q) {
  const std::size_t m_count = mix.size();
  for (std::size_t m = 0; m < m_count; ++m) l[m] = detail::log_weighted_density(mix, m, x, periods);
  return detail::responsibilities(std::span(l.data(), m_count), std::span(q.data(), m_count));
}

// Adds one sample's responsibilities q to the sufficient statistics: sum q, sum q (x - mu_old),
// sum q (x - mu_old)^2 (for x and y, the minimum image of x - mu_old).
void accumulate(detail::SufficientStatistics& stats, const ProductMixture& mix, const double* x,
                const detail::Periods& periods, const std::vector<double>& q) {
  for (std::size_t m = 0; m < mix.size(); ++m) {
    const double qm = q[m];
    stats.s0[m] += qm;
    for (int v = 0; v < kVariables; ++v) {
      const double d = detail::wrapped_difference(x[v] - mix.mean[m][v], periods[std::size_t(v)]);
      stats.s1[m][v] += qm * d;
      stats.s2[m][v] += qm * d * d;
    }
  }
}

}  // namespace

double mean_log_likelihood(std::span<const double> samples, const ProductMixture& mixture,
                           const TilePeriod& tile) {
  const std::size_t n = samples.size() / kVariables;
  const detail::Periods periods = detail::variable_periods(tile);
  std::vector<double> l(mixture.size()), q(mixture.size());
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    total += e_step(mixture, &samples[i * kVariables], periods, l, q);
  return total / double(n);
}

EmResult fit_em_reference(std::span<const double> samples, ProductMixture& mix,
                          const EmConfig& config, const EmCallback& progress,
                          const TilePeriod& tile) {
  detail::check_em_input(samples.size() / kVariables, mix, config);
  const auto t0 = Clock::now();
  const std::size_t n = samples.size() / kVariables;
  const detail::Periods periods = detail::variable_periods(tile);
  EmResult result;
  std::vector<double> l(mix.size()), q(mix.size());
  for (int it = 1; it <= config.max_iterations; ++it) {
    // E step, Eq. (2)-(4): L and the sufficient statistics.
    detail::SufficientStatistics stats(mix.size());
    double total = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double* x = &samples[i * kVariables];
      total += e_step(mix, x, periods, l, q);
      accumulate(stats, mix, x, periods, q);
    }
    const double ll = total / double(n);
    // M-step, Eq. (5)-(7): the variance from the shifted sums, floored; vanished components
    // dropped.
    result.dropped += detail::m_step(mix, stats, double(n), config.variance_floor,
                                     config.min_component_samples, periods);
    detail::record_iteration(result, ll, it, config, mix.size(), t0, progress);
    if (result.converged) break;
  }
  result.final_log_likelihood = mean_log_likelihood(samples, mix, tile);
  return result;
}

}  // namespace btfgmm
