// Shared pieces of the two EM paths (reference and grid): input checks, the M-step from
// sufficient statistics, and the bookkeeping of an iteration. The E step, Eq. (2)-(4), is in
// responsibilities.hpp.
#pragma once

#include <array>
#include <vector>

#include "btfgmm/core/text.hpp"
#include "btfgmm/model/mixture.hpp"

namespace btfgmm::detail {

// One variable's exponent of the Gaussian in Eq. (2): -(x - mu)^2 / (2 sigma^2). The same
// term is Eq. (10)'s, of one input (conditional.hpp).
inline double gauss_exponent(double x, double mean, double var) {
  const double d = x - mean;
  return -0.5 * d * d / var;
}

// Throws Error(kArgument) for an empty mixture, non-positive variances or weights, or a
// nonsense configuration.
void check_em_input(std::size_t samples, const ProductMixture& mix, const EmConfig& config);

// The sufficient statistics of the M-step, per component m and variable n, the sums over the
// samples of q_m(x) (s0), q_m(x) (x_n - mu_mn) (s1) and q_m(x) (x_n - mu_mn)^2 (s2), shifted
// by the means mu_mn the E pass started from.
struct SufficientStatistics {
  std::vector<double> s0;
  std::vector<std::array<double, kVariables>> s1, s2;
  explicit SufficientStatistics(std::size_t components)
      : s0(components, 0.0),
        s1(components, std::array<double, kVariables>{}),
        s2(components, std::array<double, kVariables>{}) {}
};

// The M-step, Eq. (5)-(7), from the sufficient statistics of `n` samples: w = s0 / N,
// mu = mu_old + s1 / s0, sigma^2 = s2 / s0 - (s1 / s0)^2 (the sums shifted by mu_old),
// floored at `floor`. Components with s0 < min_samples have vanished and are removed (and the
// weights of the rest renormalised). Returns how many were removed.
std::size_t m_step(ProductMixture& mix, const SufficientStatistics& stats, double n, double floor,
                   double min_samples);

// Appends L, computes the gain, sets `converged` when the gain is below epsilon, and calls
// the progress callback.
void record_iteration(EmResult& result, double ll, int iteration, const EmConfig& config,
                      std::size_t components, Clock::time_point start, const EmCallback& progress);

// The components in the order of a k-d split of their means over the variables `dims`: the
// set is split recursively, at a multiple of `leaf`, along the variable whose means spread
// widest, so that every run of `leaf` components (a leaf) holds means close together. Ties
// are broken by index: the order is a function of the parameters alone.
std::vector<std::size_t> kd_order(const ProductMixture& mix, const std::vector<int>& dims,
                                  std::size_t leaf);

}  // namespace btfgmm::detail
