// The neural BTF's network on a compute device for the fit (docs/GPU.md, "The neural fit"):
// the squared error and its gradient over a batch of samples, what squared_error_gradient()
// computes on the CPU (methods/neural_network.hpp), by shaders/neural_gradient.comp (a
// sample's forward and backward pass an invocation) and shaders/neural_weight_gradient.comp (a
// parameter's sum over the samples an invocation, in sample order). The sums are in another
// order than the CPU's, in float: the gradient agrees with the CPU's to float rounding, and a
// run on the same device gives the same numbers bit for bit.
#pragma once

#include <cstddef>
#include <memory>
#include <span>

#include "btfgmm/gpu/compute_device.hpp"
#include "methods/neural_network.hpp"

namespace btfgmm::detail {

class NetworkGradientPass {
 public:
  // Buffers for batches of at most `most_samples` samples of `shape`. Throws Error(kArgument)
  // where the device cannot hold them or a software device cannot run the loops, naming
  // `device` cpu.
  NetworkGradientPass(ComputeDevice& device, const NetworkShape& shape, std::size_t most_samples);

  // The parameters the next passes use.
  void set_parameters(std::span<const float> parameters);
  // E and its gradient over the samples (inputs: samples x input_size, targets: samples x 3):
  // squared_error_gradient()'s result.
  SquaredErrorGradient gradient(std::span<const float> inputs, std::span<const float> targets);
  // E alone, each sample's added in order in double.
  double squared_error(std::span<const float> inputs, std::span<const float> targets);

 private:
  std::size_t run_samples(std::span<const float> inputs, std::span<const float> targets,
                          bool backward);
  double error_of(std::size_t samples);

  ComputeDevice& device_;
  NetworkShape shape_;
  std::size_t most_samples_, parameters_;
  std::shared_ptr<GpuBuffer> theta_, inputs_, targets_, act_, delta_, latents_, errors_, grad_;
  std::shared_ptr<GpuKernel> samples_kernel_, weights_kernel_;
};

}  // namespace btfgmm::detail
