// The neural BTF's squared error and gradient on a compute device (neural_network_gpu.hpp).
#include "methods/neural_network_gpu.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <cstdint>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "gpu/device_check.hpp"
#include "model/gpu_passes.hpp"

namespace btfgmm::detail {
namespace {

constexpr std::uint32_t kGroup = 64;  // both shaders' local size

struct SamplesPush {
  std::uint32_t latents, width, depth, count, backward;
};

struct WeightsPush {
  std::uint32_t inputs, outputs, weights, act_at, delta_at, act_row, delta_row, count;
};

// A sample's kept values: its layers' inputs (the input, each hidden layer's output) and its
// layers' output gradients (each hidden layer's, the output's).
std::size_t activation_row(const NetworkShape& shape) {
  return input_size(shape) + shape.depth * shape.width;
}
std::size_t delta_row(const NetworkShape& shape) {
  return shape.depth * shape.width + kNetworkOutputs;
}

// The iterations of neural_gradient.comp's loops for one sample: the input copied, each layer's
// products forward, and back down to the latents.
std::size_t sample_iterations(const NetworkShape& shape) {
  std::size_t n = input_size(shape);
  for (const LayerLayout& layer : layer_layout(shape)) n += 2 * layer.outputs * (layer.inputs + 1);
  return n;
}

}  // namespace

NetworkGradientPass::NetworkGradientPass(ComputeDevice& device, const NetworkShape& shape,
                                         std::size_t most_samples)
    : device_(device),
      shape_(shape),
      most_samples_(std::max<std::size_t>(most_samples, 1)),
      parameters_(parameter_count(shape)) {
  check_network_shape(shape);
  const double n = double(most_samples_);
  const double kept = n * double(activation_row(shape) + delta_row(shape));
  const double bytes = 4.0 * (2.0 * double(parameters_) + kept +
                              n * double(input_size(shape) + shape.latent + kNetworkOutputs + 1));
  check_device_holds(device.info(), bytes, 4.0 * n * double(activation_row(shape)),
                     fmt::format("the network's gradient over {} samples", most_samples_));
  check_loop_nest(device.info(), std::max(sample_iterations(shape), most_samples_),
                  "the network's gradient");
  auto floats = [&](double count) {
    return device.buffer(std::max<std::size_t>(std::size_t(count), 4) * sizeof(float));
  };
  theta_ = floats(double(parameters_));
  grad_ = floats(double(parameters_));
  inputs_ = floats(n * double(input_size(shape)));
  targets_ = floats(n * double(kNetworkOutputs));
  act_ = floats(n * double(activation_row(shape)));
  delta_ = floats(n * double(delta_row(shape)));
  latents_ = floats(n * double(shape.latent));
  errors_ = floats(n);
  samples_kernel_ = device.kernel("neural_gradient.spv", 7, sizeof(SamplesPush));
  weights_kernel_ = device.kernel("neural_weight_gradient.spv", 3, sizeof(WeightsPush));
}

void NetworkGradientPass::set_parameters(std::span<const float> parameters) {
  assert(parameters.size() == parameters_);
  device_.upload_values<float>(*theta_, parameters);
}

std::size_t NetworkGradientPass::run_samples(std::span<const float> inputs,
                                             std::span<const float> targets, bool backward) {
  const std::size_t samples = targets.size() / kNetworkOutputs;
  assert(samples <= most_samples_ && inputs.size() == samples * input_size(shape_));
  if (samples == 0) return 0;
  device_.upload_values<float>(*inputs_, inputs);
  device_.upload_values<float>(*targets_, targets);
  const SamplesPush push{std::uint32_t(shape_.latent), std::uint32_t(shape_.width),
                         std::uint32_t(shape_.depth), std::uint32_t(samples),
                         std::uint32_t(backward)};
  GpuBuffer* bound[] = {theta_.get(), inputs_.get(),  targets_.get(), act_.get(),
                        delta_.get(), latents_.get(), errors_.get()};
  const auto [gx, gy] = groups_for(samples, kGroup);
  device_.run(*samples_kernel_, bound, bytes_of(push), gx, gy);
  return samples;
}

double NetworkGradientPass::error_of(std::size_t samples) {
  std::vector<float> errors(samples);
  device_.download_values<float>(*errors_, std::span(errors));
  double sum = 0.0;
  for (const float e : errors) sum += double(e);
  return sum;
}

SquaredErrorGradient NetworkGradientPass::gradient(std::span<const float> inputs,
                                                   std::span<const float> targets) {
  SquaredErrorGradient out{
      .error = 0.0, .parameters = std::vector<float>(parameters_, 0.0f), .latents = {}};
  const std::size_t samples = run_samples(inputs, targets, true);
  out.latents.resize(samples * shape_.latent);
  if (samples == 0) return out;
  GpuBuffer* bound[] = {act_.get(), delta_.get(), grad_.get()};
  const std::vector<LayerLayout> layers = layer_layout(shape_);
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const WeightsPush push{std::uint32_t(layers[l].inputs),
                           std::uint32_t(layers[l].outputs),
                           std::uint32_t(layers[l].weights),
                           std::uint32_t(l == 0 ? 0 : input_size(shape_) + (l - 1) * shape_.width),
                           std::uint32_t(l * shape_.width),
                           std::uint32_t(activation_row(shape_)),
                           std::uint32_t(delta_row(shape_)),
                           std::uint32_t(samples)};
    const auto [gx, gy] = groups_for(layers[l].outputs * (layers[l].inputs + 1), kGroup);
    device_.run(*weights_kernel_, bound, bytes_of(push), gx, gy);
  }
  device_.download_values<float>(*grad_, std::span(out.parameters));
  device_.download_values<float>(*latents_, std::span(out.latents));
  out.error = error_of(samples);
  return out;
}

double NetworkGradientPass::squared_error(std::span<const float> inputs,
                                          std::span<const float> targets) {
  return error_of(run_samples(inputs, targets, false));
}

}  // namespace btfgmm::detail
