// What the neural BTF's representation (neural_btf.cpp) and its fit (neural_btf_fit.cpp)
// share: the network's shape, the latents' two layouts and their interpolation, and the
// network on a compute device.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/methods/neural_btf.hpp"
#include "methods/neural_network.hpp"

namespace btfgmm::detail {

NetworkShape network_shape(const NeuralShape& s);

// A fit's minibatch over `training` samples: about 64 steps an epoch, 128 to 4096 samples.
std::size_t neural_batch_size(std::size_t training);
// The Adam steps of one epoch over `training` samples, at least one.
std::size_t neural_epoch_steps(std::size_t training);
// The most epochs of a fit over `training` samples where `iterations` is not given
// (kNeuralDefaultEpochs .. kNeuralMostSteps, methods/neural_btf.hpp): a bound in work, as the
// refinement's kDefaultRefineSteps, so the same model on any machine at any load.
int neural_default_epochs(std::size_t training);

// The latents (pixels x L, a texel's together, as the network reads them) as L rows of a value
// per texel (as the file stores them: a row per latent dimension, each quantised with its own
// offset and step), and back.
std::vector<float> latent_rows(std::span<const float> latents, std::size_t latent);
std::vector<float> latent_columns(std::span<const float> rows, std::size_t latent);

// A texel's latent at a real tile position into out[0 .. L): bilinear between the four texels
// around it (the tile wraps); at a whole position the texel's own, exactly.
void bilinear_latent(const NeuralBtf& m, double qx, double qy, float* out);

// The network's forward pass on a compute device (neural_btf_gpu.cpp, shaders/
// neural_forward.comp), one query an invocation, in float: predict() and decode() of `m`
// there, within float rounding of the CPU's (the sums in another order). Throws Error
// (kArgument) where the device cannot hold the work or a software device cannot run the
// layers' loops, naming `device` cpu; Error(kIo) for a device fault.
void predict_on(ComputeDevice& device, const NeuralBtf& m, std::span<const Query> queries,
                std::span<float> rgb);
Btf decode_on(ComputeDevice& device, const NeuralBtf& m, const DirectionSet& lights,
              const DirectionSet& views, int width, int height);

}  // namespace btfgmm::detail
