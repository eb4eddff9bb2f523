// Shared pieces of the two EM paths (reference and grid): input checks, the M-step from
// sufficient statistics, and the bookkeeping of an iteration. The E step, Eq. (2)-(4), is in
// responsibilities.hpp.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "btfgmm/core/text.hpp"
#include "btfgmm/model/mixture.hpp"

namespace btfgmm::detail {

// ---- The tile wraps (docs/ALGORITHM.md, "The tile wraps") ------------------------------------
//
// x and y are periodic, with the tile's width W and height H: the Gaussians of x and y wrap
// around the tile. Exactly, a wrapped Gaussian is the sum over the images of its mean,
// sum_k N(x | mu + k P, sigma^2). Every evaluator takes instead the minimum image: the one
// image nearest to x, N(x | mu + k* P, sigma^2) with x - mu - k* P in [-P/2, P/2]. It is
// continuous in x across the wrap (at the antipode x = mu + P/2 the two nearest images give
// the same value), costs one rounding per term instead of one exp per image (3 where one was),
// and differs from the sum over the images by the images left out, each at least P/2 away:
// at most ~2 exp(-(P/2)^2 / (2 sigma^2)) of the component's peak density, 2 e^-8 = 7e-4 at
// sigma = P/8 (kMaxWrappedDeviation, the largest deviation EM gives a wrapped variable; at
// P/4 it would be 0.27, and the slope's change of sign at the antipode a visible crease).
// EM is the same approximation throughout: the E-step's densities take the minimum image, and
// the M-step's shifted sums take the minimum image of x - mu_old (the chart of the circle
// centred on the old mean), so the new mean is mu_old plus the mean offset, wrapped back into
// [0, P), and the variance the mean squared offset from it. That is
// the mean and variance that maximise the expected log-likelihood within the chart, and the
// chart's squared offsets bound the minimum image's from above, so each iteration still does
// not decrease the objective (a generalised EM step); they agree unless a sample sits near
// the antipode of the old mean, where the component's density is below e^-8 of its peak.

// The period of each of the nine variables: W for x, H for y, 0 (not periodic) for the rest.
using Periods = std::array<double, kVariables>;
inline Periods variable_periods(const TilePeriod& tile) {
  Periods p{};
  p[0] = tile.width;
  p[1] = tile.height;
  return p;
}

// The minimum image of a difference d of a variable of period P: d - P round(d / P), in
// [-P/2, P/2]; d itself when P is 0 (a variable that does not wrap).
inline double wrapped_difference(double d, double period) {
  return period > 0.0 ? d - period * std::nearbyint(d / period) : d;
}

// A value of a variable of period P as its representative in [0, P) (one already there is
// returned as is); x itself when P is 0.
inline double wrap_into_period(double x, double period) {
  if (!(period > 0.0) || (x >= 0.0 && x < period)) return x;
  double r = std::fmod(x, period);
  if (r < 0) r += period;
  return r >= period ? 0.0 : r;
}

// The range EM keeps a variance in: the floor, and for a wrapped variable of period P the
// ceiling (kMaxWrappedDeviation P)^2 under which the minimum image holds.
inline double bounded_variance(double var, double floor, double period) {
  const double v = std::max(var, floor);
  if (!(period > 0.0)) return v;
  const double top = kMaxWrappedDeviation * period;
  return std::max(std::min(v, top * top), floor);
}

// One variable's exponent of the Gaussian in Eq. (2): -(x - mu)^2 / (2 sigma^2), for a
// variable of period P with x - mu in the minimum image (P = 0: not periodic). The same term
// is Eq. (10)'s, of one input (conditional.hpp).
inline double gauss_exponent(double x, double mean, double var, double period) {
  const double d = wrapped_difference(x - mean, period);
  return -0.5 * d * d / var;
}

// Throws Error(kArgument) for an empty mixture, non-positive variances or weights, or a
// nonsense configuration.
void check_em_input(std::size_t samples, const ProductMixture& mix, const EmConfig& config);

// The sufficient statistics of the M-step, per component m and variable n, the sums over the
// samples of q_m(x) (s0), q_m(x) (x_n - mu_mn) (s1) and q_m(x) (x_n - mu_mn)^2 (s2), shifted
// by the means mu_mn the E pass started from (x_n - mu_mn: its minimum image for x and y).
struct SufficientStatistics {
  std::vector<double> s0;
  std::vector<std::array<double, kVariables>> s1, s2;
  explicit SufficientStatistics(std::size_t components)
      : s0(components, 0.0),
        s1(components, std::array<double, kVariables>{}),
        s2(components, std::array<double, kVariables>{}) {}
};

// The M-step, Eq. (5)-(7), from the sufficient statistics of `n` samples: w = s0 / N,
// mu = mu_old + s1 / s0, sigma^2 = s2 / s0 - (s1 / s0)^2 (the sums shifted by mu_old; for the
// wrapped variables, of the minimum images of x - mu_old, and the new mean wrapped into
// [0, P)), kept within bounded_variance(). Components with s0 < min_samples have vanished and
// are removed (and the weights of the rest renormalised). Returns how many were removed.
std::size_t m_step(ProductMixture& mix, const SufficientStatistics& stats, double n, double floor,
                   double min_samples, const Periods& periods);

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
