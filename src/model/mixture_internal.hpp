// Shared pieces of the two EM paths (reference and grid): input checks, the M-step from
// sufficient statistics, and the bookkeeping of an iteration.
#pragma once

#include <array>
#include <chrono>
#include <vector>

#include "btfgmm/model/mixture.hpp"

namespace btfgmm::detail {

// Throws Error(kArgument) for an empty mixture, non-positive variances or weights, or a
// nonsense configuration.
void check_em_input(std::size_t samples, const ProductMixture& mix, const EmConfig& config);

// Eq. (5)-(7): w = s0 / N, mu = mu_old + s1 / s0, sigma^2 = s2 / s0 - (s1 / s0)^2 (the sums
// shifted by mu_old), floored at `floor`. Components with s0 < min_samples are removed (and
// the weights of the rest renormalised). Returns how many were removed.
std::size_t m_step(ProductMixture& mix, const std::vector<double>& s0,
                   const std::vector<std::array<double, kVariables>>& s1,
                   const std::vector<std::array<double, kVariables>>& s2, double n, double floor,
                   double min_samples);

// Appends L, computes the gain, sets `converged` when the gain is below epsilon, and calls
// the progress callback.
void record_iteration(EmResult& result, double ll, int iteration, const EmConfig& config,
                      std::size_t components, std::chrono::steady_clock::time_point start,
                      const EmCallback& progress);

// The components in the order of a k-d split of their means over the variables `dims`: the
// set is split recursively, at a multiple of `leaf`, along the variable whose means spread
// widest, so that every run of `leaf` components (a leaf) holds means close together. Ties
// are broken by index: the order is a function of the parameters alone.
std::vector<std::size_t> kd_order(const ProductMixture& mix, const std::vector<int>& dims,
                                  std::size_t leaf);

}  // namespace btfgmm::detail
