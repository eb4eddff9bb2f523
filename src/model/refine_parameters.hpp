// The refinement for the prediction's parameters as one vector for Adam (core/adam.hpp):
// packed from a mixture and its gradient, unpacked within EM's bounds, and each entry's rate
// and epsilon (model/refine_gradient.cpp, gradient_epochs; docs/ALGORITHM.md).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/refine.hpp"
#include "core/adam.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {

// The parameters as one vector, 16 a component: a_m, mu_m0..8, s_m0..5.
constexpr std::size_t kParams = 1 + kVariables + kInputs;

inline std::vector<double> pack(const ProductMixture& mix) {
  std::vector<double> th(mix.size() * kParams);
  for (std::size_t k = 0; k < mix.size(); ++k) {
    double* t = &th[k * kParams];
    t[0] = std::log(mix.weight[k]);
    for (int n = 0; n < kVariables; ++n) t[1 + n] = mix.mean[k][std::size_t(n)];
    for (int n = 0; n < kInputs; ++n) t[1 + kVariables + n] = std::log(mix.var[k][std::size_t(n)]);
  }
  return th;
}

inline std::vector<double> pack(const PredictionGradient& g) {
  std::vector<double> th(g.log_weight.size() * kParams);
  for (std::size_t k = 0; k < g.log_weight.size(); ++k) {
    double* t = &th[k * kParams];
    t[0] = g.log_weight[k];
    for (int n = 0; n < kVariables; ++n) t[1 + n] = g.mean[k][std::size_t(n)];
    for (int n = 0; n < kInputs; ++n) t[1 + kVariables + n] = g.log_var[k][std::size_t(n)];
  }
  return th;
}

// The mixture of a parameter vector: w the softmax of a, the input means of x and y wrapped
// into the tile, the variances kept where EM keeps them (bounded_variance).
inline void unpack(const std::vector<double>& th, ProductMixture& mix, const Periods& periods) {
  double top = -INFINITY, sum = 0.0;
  for (std::size_t k = 0; k < mix.size(); ++k) top = std::max(top, th[k * kParams]);
  for (std::size_t k = 0; k < mix.size(); ++k) sum += std::exp(th[k * kParams] - top);
  for (std::size_t k = 0; k < mix.size(); ++k) {
    const double* t = &th[k * kParams];
    mix.weight[k] = std::exp(t[0] - top) / sum;
    for (int n = 0; n < kVariables; ++n)
      mix.mean[k][std::size_t(n)] = wrap_into_period(t[1 + n], periods[std::size_t(n)]);
    for (int n = 0; n < kInputs; ++n)
      mix.var[k][std::size_t(n)] = bounded_variance(std::exp(t[1 + kVariables + n]), kVarianceFloor,
                                                    periods[std::size_t(n)]);
  }
}

// The log variances of the parameter vector set to those of the mixture unpacked from it,
// which bounded_variance kept within EM's floor and ceiling: a step past a bound is projected
// back onto it, so that the next step away from the bound moves the variance at once.
inline void keep_within_bounds(std::vector<double>& theta, const ProductMixture& mix) {
  for (std::size_t k = 0; k < mix.size(); ++k)
    for (int n = 0; n < kInputs; ++n)
      theta[k * kParams + 1 + kVariables + std::size_t(n)] = std::log(mix.var[k][std::size_t(n)]);
}

// Whether entry j of a component's kParams (pack) is one of its colour means.
constexpr bool is_colour_mean(std::size_t j) {
  return j >= 1 + kInputs && j < 1 + kVariables;
}

// The Adam rate of each entry of the parameter vector (core/adam.hpp): `colour_rate` for the
// colour means, `rate` for the others.
inline auto rate_of_parameter(double rate, double colour_rate) {
  return [rate, colour_rate](std::size_t i) {
    return is_colour_mean(i % kParams) ? colour_rate : rate;
  };
}

// Adam's epsilon (core/adam.hpp) of each parameter of the refinement. The colour means start
// at their least-squares refit (refine.cpp), where their gradient is zero but for rounding:
// with an epsilon far below every gradient, Adam's first step moves each by its full rate in
// the direction of its rounding's sign, and the same fit on another device, whose sums round
// otherwise, goes another way (0.25 level apart after 3 steps of an 8 x 8 tile). Theirs is
// kColourEpsilon times the largest gradient a colour mean can have on the first minibatch,
// 2 sqrt(n E) for its n samples of squared error E (Cauchy-Schwarz): a colour mean whose
// gradient is rounding's (about 1e-7 of that bound) hardly moves, one whose gradient is a
// thousandth of it takes its full step. The other parameters keep adam_epsilon.
constexpr double kColourEpsilon = 1e-5;

inline std::array<double, kParams> adam_epsilons(const PredictionGradient& first) {
  std::array<double, kParams> e;
  e.fill(adam_epsilon<double>());
  const double bound = 2.0 * std::sqrt(double(first.samples) * first.error);
  for (std::size_t j = 0; j < kParams; ++j)
    if (is_colour_mean(j)) e[j] = std::max(e[j], kColourEpsilon * bound);
  return e;
}

}  // namespace btfgmm::detail
