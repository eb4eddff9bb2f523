// The network of the neural BTF (Rainer, Jakob, Ghosh & Weyrich 2019, "Neural BTF Compression
// and Interpolation", Eurographics): a multilayer perceptron shared by every texel of the tile,
// whose input is a texel's latent vector and an encoding of a light and a view direction, and
// whose output is that texel's RGB for the pair (the paper's decoder). Its forward pass
// over a batch, its backward pass (the gradient w.r.t. every parameter and every input: the
// latents are fitted too) and the squared error's gradient over many samples, the same bit for
// bit on any number of threads.
//
// Layers. Layer l = 0..depth maps n_l values to n_{l+1}: n_0 = input_size(shape) (the latent,
// then the directions' encoding), n_1 = ... = n_depth = width, n_{depth+1} = 3 (RGB). A hidden
// layer is a_{l+1} = leaky(W_l a_l + b_l), the output layer y = W_depth a_depth + b_depth
// (linear: radiance is not bounded above, and a linear output does not clip the gradient).
//
// Parameters. One flat vector, layer after layer: W_l (n_{l+1} x n_l, row-major: one output's
// weights together), then b_l (n_{l+1}); layer_layout() gives the offsets.
//
// Batches. `batch` samples, row-major: a sample's inputs together (batch x input_size), its
// outputs together (batch x 3).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "btfgmm/core/directions.hpp"

namespace btfgmm::detail {

// The network's size: L values of latent per texel, `depth` hidden layers of `width` units.
struct NetworkShape {
  std::size_t latent = 0;
  std::size_t width = 0;
  std::size_t depth = 0;
};

// What a shape may be: a latent of 1..kMaxLatent values, 1..kMaxDepth hidden layers of
// 1..kMaxWidth units.
constexpr std::size_t kMaxLatent = 256;
constexpr std::size_t kMaxWidth = 512;
constexpr std::size_t kMaxDepth = 16;

constexpr std::size_t kDirectionInputs = 9;  // encode_directions' values
constexpr std::size_t kNetworkOutputs = 3;   // RGB

// The hidden layers' activation, the leaky ReLU (Maas, Hannun & Ng 2013): z for z > 0,
// kLeakySlope z otherwise. Leaky rather than plain: a unit whose input is negative for every
// sample still passes a gradient, to its weights and to the latents below it, so no unit and
// no texel's latent stops learning; the slope is the same number in float and double.
constexpr float kLeakySlope = 0.01f;

// Error(kArgument) for a shape outside the ranges above, naming the size at fault.
void check_network_shape(const NetworkShape& shape);

// latent + kDirectionInputs.
std::size_t input_size(const NetworkShape& shape);

// Where layer l's parameters lie in the flat vector.
struct LayerLayout {
  std::size_t inputs = 0, outputs = 0;  // n_l, n_{l+1}
  std::size_t weights = 0, biases = 0;  // offsets of W_l and b_l
};
std::vector<LayerLayout> layer_layout(const NetworkShape& shape);  // depth + 1 layers

// The number of parameters: the sum over layers of n_{l+1} (n_l + 1).
std::size_t parameter_count(const NetworkShape& shape);

// The network's direction inputs (kDirectionInputs values into `out`): x, y, z of the light,
// of the view and of their half vector (Rusinkiewicz 1998), each normalised here. The paper's
// decoder takes the light and view directions; the half vector is added because a specular
// highlight is narrow around half vectors near the normal, a function of neither direction
// alone, which a small network would otherwise have to build from the two in its first layers.
// Opposite directions (both grazing, never measured) give a zero half vector.
void encode_directions(const Vec3& light, const Vec3& view, std::span<float> out);

// The parameters at the start of a fit, from `seed`: each layer's weights uniform in
// [-b, b] with b = gain sqrt(3 / n_l) (He et al. 2015's initialisation, the "Kaiming uniform":
// gain sqrt(2 / (1 + kLeakySlope^2)) before a leaky ReLU, 1 before the linear output), biases
// zero. The same vector for the same seed on any machine. Checks the shape.
std::vector<float> initial_parameters(const NetworkShape& shape, std::uint64_t seed);

// The outputs (batch x 3) of the inputs (batch x input_size) by Eigen's matrix products over
// the whole batch (which Eigen may run on OpenMP's threads). Float, as the model stores it;
// double, the reference the tests check the gradient with.
void forward(const NetworkShape& shape, std::span<const float> parameters,
             std::span<const float> inputs, std::span<float> outputs);
void forward(const NetworkShape& shape, std::span<const double> parameters,
             std::span<const double> inputs, std::span<double> outputs);

// Back-propagation through the batch: given dE/dy (batch x 3), dE/dtheta for every parameter
// (parameter_count values, the layout of the parameters, summed over the batch) and dE/dx for
// every input (batch x input_size; the first `latent` columns are the latents' gradient).
void backward(const NetworkShape& shape, std::span<const float> parameters,
              std::span<const float> inputs, std::span<const float> output_gradient,
              std::span<float> parameter_gradient, std::span<float> input_gradient);
void backward(const NetworkShape& shape, std::span<const double> parameters,
              std::span<const double> inputs, std::span<const double> output_gradient,
              std::span<double> parameter_gradient, std::span<double> input_gradient);

// The squared error E = sum over samples and channels of (y - target)^2 and its gradient.
struct SquaredErrorGradient {
  double error = 0.0;
  std::vector<float> parameters;  // dE/dtheta, parameter_count values
  std::vector<float> latents;     // dE/dx of the latent inputs: samples x latent, row-major
};

// E and its gradient over `samples` = targets.size() / 3 samples (inputs: samples x input_size,
// targets: samples x 3). The samples are cut into chunks of a fixed size whatever the number of
// threads; each chunk's gradient is computed alone, on one of `threads` threads (0: OpenMP's
// default), and the chunks' gradients and errors are added in chunk order, in double: the same
// result bit for bit for any number of threads.
SquaredErrorGradient squared_error_gradient(const NetworkShape& shape,
                                            std::span<const float> parameters,
                                            std::span<const float> inputs,
                                            std::span<const float> targets, int threads);

}  // namespace btfgmm::detail
