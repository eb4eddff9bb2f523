// A fit from a BTF tile to a model: mean BRDF, samples, initialisation and EM.
#pragma once

#include <cstddef>
#include <cstdint>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model.hpp"

namespace btfgmm {

struct FitConfig {
  std::size_t components = 600;
  std::uint64_t seed = 1;
  EmConfig em;
};

// Where an interrupted fit stands: the mixture after result.iterations iterations.
struct FitState {
  ProductMixture mixture;
  EmResult result;
};

// Mean BRDF, samples, initialisation and EM on a BTF tile. With `resume`, EM continues from
// that state instead of a fresh initialisation (the same tile and settings are the caller's
// to check: see checkpoint.hpp). `after_iteration` as for fit_em. If the fit was interrupted
// (config.em.stop), *state receives where it stands and the returned model is empty.
BtfModel fit_model(const Btf& btf, const FitConfig& config, const EmCallback& progress = {},
                   const FitState* resume = nullptr, const EmStateCallback& after_iteration = {},
                   FitState* state = nullptr);

}  // namespace btfgmm
