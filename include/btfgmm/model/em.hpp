// EM for the mixture on the sample grid, Eq. (3)-(7) (docs/ALGORITHM.md): the fast path every
// fit uses. The readable statement of the same equations is em_reference.hpp's fit_em_reference.
#pragma once

#include <functional>
#include <memory>

#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {

// EM, Eq. (3)-(7), on the sample grid (docs/ALGORITHM.md, "The grid path"): per iteration the
// spatial and angular parts of every component's log density are tabulated once, samples are
// processed in blocks, responsibilities folded into sufficient statistics at once (no N x M
// matrix). Statistics are accumulated per light in fixed chunks of pixels and reduced in a fixed
// order (chunks, then lights, over every process of a distributed set, docs/SCALING.md), so
// the result does not depend on the number of threads.
//
// To resume an interrupted fit, pass the mixture and the EmResult it returned (or that a
// checkpoint holds): iterations continue from result.iterations + 1, and the outcome is bit
// for bit that of an uninterrupted fit. `after_iteration` is called after every M-step with
// the state a resume needs (to write checkpoints).
using EmStateCallback = std::function<void(const ProductMixture&, const EmResult&)>;
EmResult fit_em(const SampleSet& samples, ProductMixture& mixture, const EmConfig& config,
                const EmCallback& progress = {}, const EmResult* resume = nullptr,
                const EmStateCallback& after_iteration = {});

// L of Eq. (3), the mean log-likelihood of the sample set under `mixture`, by fit_em's E pass
// (`threads` 0: all cores; `tile_wraps` as EmConfig's).
double mean_log_likelihood(const SampleSet& samples, const ProductMixture& mixture, int threads = 0,
                           bool tile_wraps = true);

// The seconds one iteration of fit_em on `samples` from `start` would take on this machine,
// timed on about 1/32 of the lights it holds (EM's tables in whole, the E pass of those
// lights scaled to all of them, the M-step): the estimate a fit states before EM. EM's
// components narrow as it goes and its skip of negligible ones gains: the E pass is timed on
// `start` and on `start` with its variances scaled by kLaterVariance, the iterations EM spends
// mostly in, and the mean of the two is returned. Throws as check_em_size before any work.
// With `device`, the iteration's E pass is timed on that device (docs/GPU.md).
double estimate_em_iteration_seconds(const SampleSet& samples, const ProductMixture& start,
                                     int threads = 0,
                                     const std::shared_ptr<ComputeDevice>& device = nullptr);
// The same from M = `components` equal components spread over the whole set, none negligible:
// a bound rather than an estimate, where the fit's start is not at hand.
double estimate_em_iteration_seconds(const SampleSet& samples, std::size_t components,
                                     int threads = 0,
                                     const std::shared_ptr<ComputeDevice>& device = nullptr);

}  // namespace btfgmm
