// What the neural BTF's representation (neural_btf.cpp) and its fit (neural_btf_fit.cpp)
// share: the network's shape and the latents' two layouts.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "btfgmm/methods/neural_btf.hpp"
#include "methods/neural_network.hpp"

namespace btfgmm::detail {

NetworkShape network_shape(const NeuralShape& s);

// The latents (pixels x L, a texel's together, as the network reads them) as L rows of a value
// per texel (as the file stores them: a row per latent dimension, each quantised with its own
// offset and step), and back.
std::vector<float> latent_rows(std::span<const float> latents, std::size_t latent);
std::vector<float> latent_columns(std::span<const float> rows, std::size_t latent);

}  // namespace btfgmm::detail
