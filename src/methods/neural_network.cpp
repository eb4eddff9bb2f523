// The neural BTF's network (neural_network.hpp; Rainer, Jakob, Ghosh & Weyrich 2019): each
// layer's product over a whole batch by Eigen, back-propagation through the layers, and the
// squared error's gradient over chunks of samples added in a fixed order.
#include "methods/neural_network.hpp"

#include <omp.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "core/eigen_dense.hpp"
#include "core/random.hpp"
#include "core/vec3_ops.hpp"

namespace btfgmm::detail {
namespace {

// A batch's values one sample a column: the interface's row-major batch x n seen as n x batch.
template <class Real>
using Columns = Eigen::Matrix<Real, Eigen::Dynamic, Eigen::Dynamic>;
template <class Real>
using RowMajor = Eigen::Matrix<Real, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
template <class Real>
using Vector = Eigen::Matrix<Real, Eigen::Dynamic, 1>;
template <class Real>
using ColumnsOf = Eigen::Map<const Columns<Real>>;

// The squared error's gradient: the samples of a chunk; the bytes of the chunks' gradients
// held between two additions into the total (at least one chunk a thread, at most 64).
constexpr std::size_t kChunkSamples = 512;
constexpr std::size_t kHeldGradientBytes = std::size_t(64) << 20;

Eigen::Index to_index(std::size_t n) {
  return Eigen::Index(n);
}

// Layer `at`'s weights W_l (outputs x inputs) and biases b_l in the parameter vector.
template <class Real>
Eigen::Map<const RowMajor<Real>> layer_weights(const LayerLayout& at, const Real* theta) {
  return {theta + at.weights, to_index(at.outputs), to_index(at.inputs)};
}
template <class Real>
Eigen::Map<const Vector<Real>> layer_biases(const LayerLayout& at, const Real* theta) {
  return {theta + at.biases, to_index(at.outputs)};
}

// `values` (row-major, `rows` values a sample) one sample a column.
template <class Real>
ColumnsOf<Real> as_columns(std::span<const Real> values, std::size_t rows) {
  return {values.data(), to_index(rows), to_index(values.size() / rows)};
}

// The leaky ReLU, in place: max(z, kLeakySlope z) is z for z > 0 and kLeakySlope z otherwise.
template <class Real>
void leaky_relu(Columns<Real>& z) {
  z = z.cwiseMax(Real(kLeakySlope) * z);
}

// dE/dz from dE/da (`delta`, in place) through the leaky ReLU: its slope is 1 where a > 0 and
// kLeakySlope elsewhere (a has the sign of z).
template <class Real>
void through_leaky_relu(const Columns<Real>& a, Columns<Real>& delta) {
  delta = (a.array() > Real(0)).select(delta, Real(kLeakySlope) * delta);
}

// One batch's activations and its backward pass's scratch, kept between batches.
template <class Real>
struct Pass {
  std::vector<Columns<Real>> hidden;  // a_1 .. a_depth, width x batch each
  Columns<Real> output;               // y, 3 x batch
  Columns<Real> delta, delta_below;   // dE/dz of the layer at hand and of the layer below
};

// The input of layer l: the batch's inputs for l = 0, hidden layer l's activations above.
template <class Real>
ColumnsOf<Real> layer_input(const ColumnsOf<Real>& x, const Pass<Real>& pass, std::size_t l) {
  if (l == 0) return x;
  const Columns<Real>& a = pass.hidden[l - 1];
  return {a.data(), a.rows(), a.cols()};
}

// The forward pass: z = W_l a_l + b_l for the whole batch at once, the leaky ReLU on the hidden
// layers, the output linear.
template <class Real>
void forward_layers(const std::vector<LayerLayout>& layers, const Real* theta,
                    const ColumnsOf<Real>& x, Pass<Real>& pass) {
  pass.hidden.resize(layers.size() - 1);
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const bool hidden = l + 1 < layers.size();
    Columns<Real>& z = hidden ? pass.hidden[l] : pass.output;
    z.noalias() = layer_weights(layers[l], theta) * layer_input(x, pass, l);
    z.colwise() += layer_biases(layers[l], theta);
    if (hidden) leaky_relu(z);
  }
}

// Layer `at`'s gradient from its dE/dz (`delta`) and its input a: dE/dW = delta a^T,
// dE/db = delta summed over the batch. The sum adds delta's columns one after another: each
// bias's sum in sample order wherever the gradient lies (a vectorised row sum would sum the
// rows it peels to reach an aligned address in another order).
template <class Real>
void layer_gradient(const LayerLayout& at, const Columns<Real>& delta, const ColumnsOf<Real>& a,
                    Real* gradient) {
  Eigen::Map<RowMajor<Real>> weights(gradient + at.weights, to_index(at.outputs),
                                     to_index(at.inputs));
  weights.noalias() = delta * a.transpose();
  Eigen::Map<Vector<Real>> biases(gradient + at.biases, to_index(at.outputs));
  biases.setZero();
  for (Eigen::Index j = 0; j < delta.cols(); ++j) biases += delta.col(j);
}

// Back-propagation from dE/dy (in pass.delta) down the layers (the chain rule): each layer's
// gradient, dE/da_l = W_l^T delta_l, through the activation to the layer below; at the bottom
// dE/dx, of the first input_gradient.rows() inputs (all of them, or the latents alone).
template <class Real>
void backward_layers(const std::vector<LayerLayout>& layers, const Real* theta,
                     const ColumnsOf<Real>& x, Pass<Real>& pass, Real* gradient,
                     Eigen::Map<Columns<Real>>& input_gradient) {
  for (std::size_t l = layers.size(); l-- > 0;) {
    layer_gradient(layers[l], pass.delta, layer_input(x, pass, l), gradient);
    const auto w = layer_weights(layers[l], theta);
    if (l == 0) {
      input_gradient.noalias() = w.leftCols(input_gradient.rows()).transpose() * pass.delta;
      return;
    }
    pass.delta_below.noalias() = w.transpose() * pass.delta;
    through_leaky_relu(pass.hidden[l - 1], pass.delta_below);
    std::swap(pass.delta, pass.delta_below);
  }
}

// forward(), in float or double.
template <class Real>
void forward_batch(const NetworkShape& shape, std::span<const Real> parameters,
                   std::span<const Real> inputs, std::span<Real> outputs) {
  const std::size_t n = input_size(shape), batch = inputs.size() / n;
  assert(parameters.size() == parameter_count(shape));
  assert(inputs.size() == batch * n && outputs.size() == batch * kNetworkOutputs);
  Pass<Real> pass;
  forward_layers(layer_layout(shape), parameters.data(), as_columns(inputs, n), pass);
  Eigen::Map<Columns<Real>>(outputs.data(), to_index(kNetworkOutputs), to_index(batch)) =
      pass.output;
}

// backward(), in float or double: the forward pass, then back-propagation.
template <class Real>
void backward_batch(const NetworkShape& shape, std::span<const Real> parameters,
                    std::span<const Real> inputs, std::span<const Real> output_gradient,
                    std::span<Real> parameter_gradient, std::span<Real> input_gradient) {
  const std::size_t n = input_size(shape), batch = inputs.size() / n;
  assert(parameters.size() == parameter_count(shape));
  assert(parameter_gradient.size() == parameters.size());
  assert(inputs.size() == batch * n && input_gradient.size() == inputs.size());
  assert(output_gradient.size() == batch * kNetworkOutputs);
  const std::vector<LayerLayout> layers = layer_layout(shape);
  const ColumnsOf<Real> x = as_columns(inputs, n);
  Pass<Real> pass;
  forward_layers(layers, parameters.data(), x, pass);
  pass.delta = as_columns(output_gradient, kNetworkOutputs);
  Eigen::Map<Columns<Real>> dx(input_gradient.data(), to_index(n), to_index(batch));
  backward_layers(layers, parameters.data(), x, pass, parameter_gradient.data(), dx);
}

// What every chunk of the squared error's samples reads.
struct SquaredErrorSamples {
  std::size_t inputs = 0, latent = 0, samples = 0, parameters = 0;
  std::vector<LayerLayout> layers;
  std::span<const float> theta, x, targets;
};

// The sum of the squares of r's entries, one after another (in any thread, at any address).
double sum_of_squares(const Columns<float>& r) {
  double sum = 0.0;
  for (const float v : r.reshaped()) sum += double(v) * double(v);
  return sum;
}

// One chunk's squared error, returned, and its gradient: the parameters' into `gradient`, the
// latents' into the chunk's rows of `latents`. dE/dy = 2 (y - target).
double chunk_squared_error(const SquaredErrorSamples& s, std::size_t chunk, Pass<float>& pass,
                           float* gradient, float* latents) {
  const std::size_t first = chunk * kChunkSamples;
  const std::size_t count = std::min(kChunkSamples, s.samples - first);
  const ColumnsOf<float> x = as_columns(s.x.subspan(first * s.inputs, count * s.inputs), s.inputs);
  const auto targets = s.targets.subspan(first * kNetworkOutputs, count * kNetworkOutputs);
  forward_layers(s.layers, s.theta.data(), x, pass);
  pass.delta = pass.output - as_columns(targets, kNetworkOutputs);
  const double error = sum_of_squares(pass.delta);
  pass.delta *= 2.0f;
  Eigen::Map<Columns<float>> dx(latents + first * s.latent, to_index(s.latent), to_index(count));
  backward_layers(s.layers, s.theta.data(), x, pass, gradient, dx);
  return error;
}

// Chunks first .. first + count - 1 on `passes.size()` threads, each chunk's gradient into its
// slot of `gradients` and its error into `errors`.
void chunks_squared_error(const SquaredErrorSamples& s, std::size_t first, std::size_t count,
                          std::vector<Pass<float>>& passes, std::vector<float>& gradients,
                          std::vector<double>& errors, float* latents) {
#pragma omp parallel num_threads(int(passes.size()))
  {
    // This thread's products one thread each: Eigen would otherwise start threads of its own
    // in a team of one.
    omp_set_num_threads(1);
    Pass<float>& pass = passes[std::size_t(omp_get_thread_num())];
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t k = 0; k < std::ptrdiff_t(count); ++k)
      errors[std::size_t(k)] = chunk_squared_error(
          s, first + std::size_t(k), pass, &gradients[std::size_t(k) * s.parameters], latents);
  }
}

// How many chunks' gradients are held at once, within kHeldGradientBytes where the threads
// allow. Whatever it is, the chunks are added in chunk order: it changes no result.
std::size_t chunks_at_once(std::size_t parameters, std::size_t threads) {
  const std::size_t fit = kHeldGradientBytes / (parameters * sizeof(float));
  return std::max(threads, std::min<std::size_t>(fit, 64));
}

// The chunks' gradients added to `total`, in chunk order.
void add_in_chunk_order(const std::vector<float>& gradients, std::size_t count,
                        std::vector<double>& total) {
  for (std::size_t k = 0; k < count; ++k) {
    const float* g = &gradients[k * total.size()];
    for (std::size_t i = 0; i < total.size(); ++i) total[i] += double(g[i]);
  }
}

// He et al. 2015's uniform bound for a layer of n_l inputs: gain sqrt(3 / n_l), the gain
// sqrt(2 / (1 + slope^2)) before a leaky ReLU, 1 before the linear output.
double he_uniform_bound(std::size_t inputs, bool before_leaky_relu) {
  const double slope = double(kLeakySlope);
  const double gain = before_leaky_relu ? std::sqrt(2.0 / (1.0 + slope * slope)) : 1.0;
  return gain * std::sqrt(3.0 / double(inputs));
}

void check_size(std::size_t value, std::size_t max, const char* what) {
  if (value >= 1 && value <= max) return;
  throw Error(Error::Kind::kArgument, "the neural network's " + std::string(what) + " " +
                                          std::to_string(value) + " is outside 1.." +
                                          std::to_string(max) + ": give one in that range");
}

}  // namespace

void check_network_shape(const NetworkShape& shape) {
  check_size(shape.latent, kMaxLatent, "latent size (values per texel)");
  check_size(shape.width, kMaxWidth, "width (units per hidden layer)");
  check_size(shape.depth, kMaxDepth, "depth (hidden layers)");
}

std::size_t input_size(const NetworkShape& shape) {
  return shape.latent + kDirectionInputs;
}

std::vector<LayerLayout> layer_layout(const NetworkShape& shape) {
  std::vector<LayerLayout> layers(shape.depth + 1);
  std::size_t at = 0;
  for (std::size_t l = 0; l < layers.size(); ++l) {
    LayerLayout& layer = layers[l];
    layer.inputs = l == 0 ? input_size(shape) : shape.width;
    layer.outputs = l == shape.depth ? kNetworkOutputs : shape.width;
    layer.weights = at;
    layer.biases = at + layer.outputs * layer.inputs;
    at = layer.biases + layer.outputs;
  }
  return layers;
}

std::size_t parameter_count(const NetworkShape& shape) {
  const LayerLayout last = layer_layout(shape).back();
  return last.biases + last.outputs;
}

void encode_directions(const Vec3& light, const Vec3& view, std::span<float> out) {
  assert(out.size() == kDirectionInputs);
  const Vec3 l = normalized(light), v = normalized(view);
  const Vec3 h = normalized(l + v);
  std::size_t i = 0;
  for (const Vec3& d : {l, v, h})
    for (const double c : {d.x, d.y, d.z}) out[i++] = float(c);
}

std::vector<float> initial_parameters(const NetworkShape& shape, std::uint64_t seed) {
  check_network_shape(shape);
  std::vector<float> theta(parameter_count(shape), 0.0f);
  SplitMix64 draw(seed);
  const std::vector<LayerLayout> layers = layer_layout(shape);
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const double bound = he_uniform_bound(layers[l].inputs, l + 1 < layers.size());
    const std::size_t weights = layers[l].outputs * layers[l].inputs;
    for (std::size_t i = 0; i < weights; ++i)
      theta[layers[l].weights + i] = float(draw.uniform(-bound, bound));
  }
  return theta;
}

void forward(const NetworkShape& shape, std::span<const float> parameters,
             std::span<const float> inputs, std::span<float> outputs) {
  forward_batch(shape, parameters, inputs, outputs);
}

void forward(const NetworkShape& shape, std::span<const double> parameters,
             std::span<const double> inputs, std::span<double> outputs) {
  forward_batch(shape, parameters, inputs, outputs);
}

void backward(const NetworkShape& shape, std::span<const float> parameters,
              std::span<const float> inputs, std::span<const float> output_gradient,
              std::span<float> parameter_gradient, std::span<float> input_gradient) {
  backward_batch(shape, parameters, inputs, output_gradient, parameter_gradient, input_gradient);
}

void backward(const NetworkShape& shape, std::span<const double> parameters,
              std::span<const double> inputs, std::span<const double> output_gradient,
              std::span<double> parameter_gradient, std::span<double> input_gradient) {
  backward_batch(shape, parameters, inputs, output_gradient, parameter_gradient, input_gradient);
}

SquaredErrorGradient squared_error_gradient(const NetworkShape& shape,
                                            std::span<const float> parameters,
                                            std::span<const float> inputs,
                                            std::span<const float> targets, int threads) {
  const SquaredErrorSamples s{.inputs = input_size(shape),
                              .latent = shape.latent,
                              .samples = targets.size() / kNetworkOutputs,
                              .parameters = parameter_count(shape),
                              .layers = layer_layout(shape),
                              .theta = parameters,
                              .x = inputs,
                              .targets = targets};
  assert(parameters.size() == s.parameters && targets.size() == s.samples * kNetworkOutputs);
  assert(inputs.size() == s.samples * s.inputs);
  SquaredErrorGradient out{.error = 0.0,
                           .parameters = std::vector<float>(s.parameters),
                           .latents = std::vector<float>(s.samples * s.latent)};
  std::vector<Pass<float>> passes(std::size_t(threads > 0 ? threads : omp_get_max_threads()));
  const std::size_t at_once = chunks_at_once(s.parameters, passes.size());
  std::vector<float> gradients(at_once * s.parameters);
  std::vector<double> errors(at_once), total(s.parameters, 0.0);
  const std::size_t chunks = (s.samples + kChunkSamples - 1) / kChunkSamples;
  for (std::size_t first = 0; first < chunks; first += at_once) {
    const std::size_t count = std::min(at_once, chunks - first);
    chunks_squared_error(s, first, count, passes, gradients, errors, out.latents.data());
    add_in_chunk_order(gradients, count, total);
    for (std::size_t k = 0; k < count; ++k) out.error += errors[k];
  }
  std::transform(total.begin(), total.end(), out.parameters.begin(),
                 [](double g) { return float(g); });
  return out;
}

}  // namespace btfgmm::detail
