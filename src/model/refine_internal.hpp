// The gradient rounds of the fit for the prediction (refine_gradient.cpp), called by
// refine_for_prediction (refine.cpp).
#pragma once

#include <algorithm>
#include <cstddef>

#include "btfgmm/model/refine.hpp"

namespace btfgmm::detail {

// The stride (GridWeights::kept) that takes about `wanted` of `samples` samples: at least
// `wanted`, fewer than twice as many (all of them when there are fewer).
inline std::size_t subsample_stride(std::size_t samples, std::size_t wanted) {
  return std::max<std::size_t>(1, samples / std::max<std::size_t>(wanted, 1));
}

// From a mixture whose colour means were just refitted (prediction error `error` on the
// samples of `stride`): config.rounds rounds of Adam steps on every parameter, each closed by
// the colour refit and kept only where it lowers the error. Returns the lowest error reached,
// its mixture in `mix`; adds the passes and steps made to `out` and sets its `stopped`.
double gradient_rounds(const SampleSet& samples, ProductMixture& mix, int threads,
                       std::size_t stride, const GradientConfig& config, double error,
                       PredictionRefinement& out);

}  // namespace btfgmm::detail
