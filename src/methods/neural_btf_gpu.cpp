// The neural BTF's network on a compute device (docs/GPU.md, "Decoding on the GPU"): the
// queries' latents and direction encodings uploaded, the forward pass of
// methods/neural_network.hpp made by shaders/neural_forward.comp, one query an invocation.
// The inputs are the CPU's (bilinear_latent, encode_directions), so a query's answer differs
// from predict()'s on the CPU only by the order of the float sums.
#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/model/predict_gpu.hpp"
#include "gpu/device_check.hpp"
#include "methods/neural_btf_internal.hpp"
#include "model/conditional.hpp"
#include "model/gpu_passes.hpp"

namespace btfgmm::detail {
namespace {

constexpr std::uint32_t kForwardGroup = 64;  // neural_forward.comp's local size

struct ForwardPush {
  std::uint32_t latents, width, depth, pixels, grid, first, count;
  float scale;
};

// The shader's inputs: rows of L latent values and rows of the 9 direction values. On the
// grid, query i is texel i % pixels of pair i / pixels; otherwise query i has row i of each.
struct ForwardInputs {
  std::vector<float> latents, directions;
  std::size_t queries = 0, pixels = 0;
  bool grid = false;
};

ForwardInputs query_rows(const NeuralBtf& m, std::span<const Query> queries) {
  ForwardInputs in;
  const std::size_t L = m.shape().latent;
  in.queries = in.pixels = queries.size();
  in.latents.resize(queries.size() * L);
  in.directions.resize(queries.size() * kDirectionInputs);
  for (std::size_t k = 0; k < queries.size(); ++k) {
    bilinear_latent(m, queries[k].x, queries[k].y, &in.latents[k * L]);
    encode_directions(to_vector(queries[k].light), to_vector(queries[k].view),
                      std::span(in.directions).subspan(k * kDirectionInputs, kDirectionInputs));
  }
  return in;
}

ForwardInputs grid_rows(const NeuralBtf& m, const DirectionSet& lights, const DirectionSet& views) {
  ForwardInputs in;
  in.grid = true;
  in.pixels = m.frame().pixels();
  in.queries = in.pixels * lights.size() * views.size();
  in.latents.assign(m.latents().begin(), m.latents().end());
  in.directions.resize(lights.size() * views.size() * kDirectionInputs);
  for (std::size_t l = 0; l < lights.size(); ++l)
    for (std::size_t v = 0; v < views.size(); ++v)
      encode_directions(to_vector(lights[l]), to_vector(views[v]),
                        std::span(in.directions)
                            .subspan((l * views.size() + v) * kDirectionInputs, kDirectionInputs));
  return in;
}

// The iterations of the shader's loop nest for one query: the inputs gathered, then each
// layer's outputs times its inputs.
std::size_t forward_iterations(const NetworkShape& shape) {
  std::size_t n = input_size(shape);
  for (const LayerLayout& layer : layer_layout(shape)) n += layer.outputs * (layer.inputs + 1);
  return n + kNetworkOutputs;
}

// The RGB of every query (3 floats a query), in runs of at most kGpuDecodeQueries. Refused before
// any transfer where the device cannot hold or run the work.
std::vector<float> network_colours(ComputeDevice& device, const NeuralBtf& m,
                                   const ForwardInputs& in) {
  const NetworkShape shape = network_shape(m.shape());
  if (in.queries > std::numeric_limits<std::uint32_t>::max())
    throw Error(Error::Kind::kArgument,
                fmt::format("{} queries at once are more than the GPU's prediction numbers "
                            "(2^32 - 1); decode fewer images at once",
                            in.queries));
  const std::size_t run = std::max<std::size_t>(1, std::min(in.queries, kGpuDecodeQueries));
  const double bytes =
      4.0 * double(m.network_parameters().size() + in.latents.size() + in.directions.size()) +
      12.0 * double(run);
  check_device_holds(device.info(), bytes,
                     std::max(12.0 * double(run), 4.0 * double(in.latents.size())),
                     fmt::format("the network's predictions of {} queries", in.queries));
  check_loop_nest(device.info(), forward_iterations(shape), "the network's layers");
  const auto parameters = uploaded(device, m.network_parameters());
  const auto latents = uploaded(device, in.latents), directions = uploaded(device, in.directions);
  const auto colours = device.buffer(run * 3 * sizeof(float));
  const auto kernel = device.kernel("neural_forward.spv", 4, sizeof(ForwardPush));
  std::vector<float> out(in.queries * 3);
  GpuBuffer* bound[] = {parameters.get(), latents.get(), directions.get(), colours.get()};
  for (std::size_t first = 0; first < in.queries; first += run) {
    const std::size_t count = std::min(run, in.queries - first);
    const ForwardPush push{std::uint32_t(shape.latent), std::uint32_t(shape.width),
                           std::uint32_t(shape.depth),  std::uint32_t(in.pixels),
                           std::uint32_t(in.grid),      std::uint32_t(first),
                           std::uint32_t(count),        m.scale()};
    const auto [gx, gy] = groups_for(count, kForwardGroup);
    device.run(*kernel, bound, bytes_of(push), gx, gy);
    device.download_values<float>(*colours, std::span(out).subspan(first * 3, count * 3));
  }
  return out;
}

}  // namespace

void predict_on(ComputeDevice& device, const NeuralBtf& m, std::span<const Query> queries,
                std::span<float> rgb) {
  if (queries.empty()) return;
  const std::vector<float> colours = network_colours(device, m, query_rows(m, queries));
  std::copy(colours.begin(), colours.end(), rgb.begin());
}

Btf decode_on(ComputeDevice& device, const NeuralBtf& m, const DirectionSet& lights,
              const DirectionSet& views, int width, int height) {
  const ModelFrame& f = m.frame();
  limits::check_memory(double(lights.size()) * double(views.size()) *
                           (double(width) * height + double(f.pixels())) * 12.0,
                       fmt::format("decoding {} images of {}x{} pixels on the GPU",
                                   lights.size() * views.size(), width, height),
                       "decode a smaller size (`size`) or fewer directions (`light`, `view`)");
  Btf out(lights, views, width, height, f.format);
  out.set_origin(f.origin);
  if (lights.size() * views.size() == 0) return out;
  const std::vector<float> tiles = network_colours(device, m, grid_rows(m, lights, views));
  for (std::size_t l = 0; l < lights.size(); ++l)
    for (std::size_t v = 0; v < views.size(); ++v)
      repeat_tile(&tiles[(l * views.size() + v) * f.pixels() * 3], f.width, f.height, width, height,
                  out.image(l, v));
  return out;
}

}  // namespace btfgmm::detail
