// The neural BTF's shader (render/shader.hpp; Rainer, Jakob, Ghosh & Weyrich 2019): the
// latents and the network's layers as glsl/neural.glsl reads them, the network evaluated per
// pixel in the fragment shader.
#include <algorithm>

#include "btfgmm/methods/neural_btf.hpp"
#include "methods/neural_btf_internal.hpp"
#include "render/shader_tables.hpp"

namespace btfgmm::detail {
namespace {

std::size_t groups_of(std::size_t n) {
  return (n + 3) / 4;
}

// The latents: a texel's L values in groups of four, the last group padded with zeros.
std::size_t add_latents(ShaderBuilder& b, const NeuralBtf& m) {
  const std::size_t L = m.shape().latent, groups = groups_of(L), first = b.size();
  const auto latents = m.latents();
  auto value = [&](std::size_t p, std::size_t j) { return j < L ? latents[p * L + j] : 0.0f; };
  for (std::size_t p = 0; p < m.frame().pixels(); ++p)
    for (std::size_t g = 0; g < groups; ++g)
      b.texel(value(p, 4 * g), value(p, 4 * g + 1), value(p, 4 * g + 2), value(p, 4 * g + 3));
  return first;
}

// Where input i of layer `layer` lies in the shader's groups of four: the first layer's latent
// values in their groups, then the light, view and half vectors a group each (x, y, z, 0);
// a hidden layer's units in order.
std::size_t shader_slot(std::size_t layer, std::size_t i, std::size_t latent) {
  if (layer > 0 || i < latent) return i;
  const std::size_t d = i - latent;  // 0..8: light, view, half
  return 4 * groups_of(latent) + 4 * (d / 3) + d % 3;
}

// One output's row: its weights at their inputs' slots, then its bias.
void add_row(ShaderBuilder& b, std::span<const float> theta, const LayerLayout& layer,
             std::size_t index, std::size_t o, std::size_t latent, std::size_t input_groups) {
  std::vector<float> row(4 * input_groups + 4, 0.0f);
  if (o < layer.outputs) {
    for (std::size_t i = 0; i < layer.inputs; ++i)
      row[shader_slot(index, i, latent)] = theta[layer.weights + o * layer.inputs + i];
    row[4 * input_groups] = theta[layer.biases + o];
  }
  for (std::size_t t = 0; t < row.size(); t += 4)
    b.texel(row[t], row[t + 1], row[t + 2], row[t + 3]);
}

}  // namespace

ShaderExport neural_shader(const Representation& model) {
  const auto& m = dynamic_cast<const NeuralBtf&>(model);
  const NetworkShape shape = network_shape(m.shape());
  const std::vector<LayerLayout> layers = layer_layout(shape);
  ShaderBuilder b("neural");
  add_common(b, model.frame());
  const std::size_t latent_groups = groups_of(shape.latent);
  const std::size_t first_inputs = latent_groups + 3;  // the latent, light, view, half
  const std::size_t latents = add_latents(b, m);
  const std::size_t table = b.size();
  std::size_t most_groups = first_inputs;
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const std::size_t in = l == 0 ? first_inputs : groups_of(layers[l].inputs);
    b.texel(float(in), float(groups_of(layers[l].outputs)));
    most_groups = std::max({most_groups, in, groups_of(layers[l].outputs)});
  }
  const std::size_t rows = b.size();
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const std::size_t in = l == 0 ? first_inputs : groups_of(layers[l].inputs);
    for (std::size_t o = 0; o < 4 * groups_of(layers[l].outputs); ++o)
      add_row(b, m.network_parameters(), layers[l], l, o, shape.latent, in);
  }
  b.constant("BTF_NEURAL_LATENTS", latents);
  b.constant("BTF_NEURAL_LATENT_GROUPS", latent_groups);
  b.constant("BTF_NEURAL_LAYERS", layers.size());
  b.constant("BTF_NEURAL_LAYER_TABLE", table);
  b.constant("BTF_NEURAL_ROWS", rows);
  b.constant("BTF_NEURAL_GROUPS", most_groups);
  b.float_constant("BTF_NEURAL_SCALE", m.scale());
  b.float_constant("BTF_NEURAL_SLOPE", kLeakySlope);
  b.include("neural.glsl");
  return b.finish(false);
}

}  // namespace btfgmm::detail
