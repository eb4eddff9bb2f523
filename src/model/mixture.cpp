// The pieces both EM paths share (mixture_internal.hpp): the input checks, the M-step
// (Eq. 5-7), the bookkeeping of an iteration, and the k-d order of the components.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "btfgmm/core/error.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {

void check_em_input(std::size_t samples, const ProductMixture& mix, const EmConfig& config) {
  if (mix.size() == 0)
    throw Error(Error::Kind::kArgument, "the mixture has no components; give at least one");
  if (samples == 0) throw Error(Error::Kind::kArgument, "no samples to fit");
  if (config.max_iterations < 1)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("iterations = {}: EM needs at least one iteration", config.max_iterations));
  if (!(config.epsilon >= 0.0))
    throw Error(Error::Kind::kArgument,
                fmt::format("epsilon = {}: give a relative gain >= 0", config.epsilon));
  if (!(config.variance_floor > 0.0))
    throw Error(Error::Kind::kArgument, "the variance floor must be positive");
  for (std::size_t m = 0; m < mix.size(); ++m) {
    if (!(mix.weight[m] > 0.0) || !std::isfinite(mix.weight[m]))
      throw Error(
          Error::Kind::kArgument,
          fmt::format("component {} has weight {}; weights must be positive", m, mix.weight[m]));
    for (int n = 0; n < kVariables; ++n)
      if (!(mix.var[m][n] > 0.0) || !std::isfinite(mix.var[m][n]) || !std::isfinite(mix.mean[m][n]))
        throw Error(Error::Kind::kArgument,
                    fmt::format("component {} variable {} has mean {} variance {}; need finite "
                                "means and positive variances",
                                m, n, mix.mean[m][n], mix.var[m][n]));
  }
}

std::size_t m_step(ProductMixture& mix, const SufficientStatistics& stats, double n, double floor,
                   double min_samples, const Periods& periods) {
  const auto& s0 = stats.s0;
  const auto& s1 = stats.s1;
  const auto& s2 = stats.s2;
  ProductMixture next;
  for (std::size_t m = 0; m < mix.size(); ++m) {
    if (!(s0[m] >= min_samples)) continue;  // vanished: "suppressed by EM"
    std::array<double, kVariables> mean{}, var{};
    for (int v = 0; v < kVariables; ++v) {
      const double shift = s1[m][v] / s0[m], period = periods[std::size_t(v)];
      mean[v] = wrap_into_period(mix.mean[m][v] + shift, period);                  // Eq. (6)
      var[v] = bounded_variance(s2[m][v] / s0[m] - shift * shift, floor, period);  // Eq. (7)
    }
    next.weight.push_back(s0[m] / n);  // Eq. (5)
    next.mean.push_back(mean);
    next.var.push_back(var);
  }
  const std::size_t dropped = mix.size() - next.size();
  if (next.size() == 0)
    throw Error(Error::Kind::kArgument,
                "every component vanished in EM; the data set is too small for the mixture");
  double total = 0.0;
  for (double w : next.weight) total += w;
  for (double& w : next.weight) w /= total;
  mix = std::move(next);
  return dropped;
}

void record_iteration(EmResult& result, double ll, int iteration, const EmConfig& config,
                      std::size_t components, Clock::time_point start, const EmCallback& progress) {
  EmProgress p;
  p.iteration = iteration;
  p.max_iterations = config.max_iterations;
  p.log_likelihood = ll;
  p.relative_gain = std::numeric_limits<double>::quiet_NaN();
  if (!result.log_likelihood.empty()) {
    const double prev = result.log_likelihood.back();
    p.relative_gain = (ll - prev) / std::max(std::abs(prev), 1e-300);
    if (config.epsilon > 0.0 && p.relative_gain < config.epsilon) result.converged = true;
  }
  result.log_likelihood.push_back(ll);
  result.iterations = iteration;
  p.components = components;
  p.dropped = result.dropped;
  p.seconds = seconds_since(start);
  result.seconds.push_back(p.seconds);
  result.components.push_back(std::uint32_t(components));
  if (progress) progress(p);
}

namespace {

void kd_split(const ProductMixture& mix, const std::vector<int>& dims, std::size_t leaf,
              std::size_t* first, std::size_t* last) {
  const std::size_t n = std::size_t(last - first);
  if (n <= leaf) return;
  int axis = dims.front();
  double widest = -1.0;
  for (const int d : dims) {
    double lo = INFINITY, hi = -INFINITY;
    for (const std::size_t* m = first; m != last; ++m) {
      lo = std::min(lo, mix.mean[*m][std::size_t(d)]);
      hi = std::max(hi, mix.mean[*m][std::size_t(d)]);
    }
    if (hi - lo > widest) {
      widest = hi - lo;
      axis = d;
    }
  }
  // The first half: half the leaves, rounded up.
  const std::size_t leaves = (n + leaf - 1) / leaf;
  std::size_t* mid = first + (leaves + 1) / 2 * leaf;
  if (mid >= last) return;
  const auto a = std::size_t(axis);
  std::nth_element(first, mid, last, [&](std::size_t p, std::size_t q) {
    const double x = mix.mean[p][a], y = mix.mean[q][a];
    return x < y || (x == y && p < q);
  });
  kd_split(mix, dims, leaf, first, mid);
  kd_split(mix, dims, leaf, mid, last);
}

}  // namespace

std::vector<std::size_t> kd_order(const ProductMixture& mix, const std::vector<int>& dims,
                                  std::size_t leaf) {
  std::vector<std::size_t> order(mix.size());
  for (std::size_t m = 0; m < order.size(); ++m) order[m] = m;
  if (!dims.empty() && leaf > 0)
    kd_split(mix, dims, leaf, order.data(), order.data() + order.size());
  return order;
}

}  // namespace btfgmm::detail
