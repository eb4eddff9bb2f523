// The readable statement of EM, Eq. (3)-(7), on an explicit sample matrix: the reference the
// fast grid path (em.hpp) and scikit-learn are checked against.
#pragma once

#include <span>

#include "btfgmm/model/mixture.hpp"

namespace btfgmm {

// The readable statement of Eq. (3)-(7) on an explicit sample matrix (N x 9, row-major, in
// units): log-domain responsibilities, double accumulators, variances from sums shifted by
// the previous mean, the variance floor, vanished components dropped. Single-threaded. The
// reference the fast grid path is checked against. `tile`: the period of x and y when the
// samples are a tile's (their Gaussians then wrap, as fit_em's do); the default, {0, 0},
// leaves every variable unwrapped.
EmResult fit_em_reference(std::span<const double> samples, ProductMixture& mixture,
                          const EmConfig& config, const EmCallback& progress = {},
                          const TilePeriod& tile = {});

// Mean log-likelihood, Eq. (3), of samples (N x 9) under a mixture (`tile` as above).
double mean_log_likelihood(std::span<const double> samples, const ProductMixture& mixture,
                           const TilePeriod& tile = {});

}  // namespace btfgmm
