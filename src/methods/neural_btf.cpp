// The neural BTF as a representation (Rainer, Jakob, Ghosh & Weyrich 2019): evaluation of any
// pixel at any pair of directions by the shared network, the model file's payload, its reader
// and the ladder of sizes. The fit is in neural_btf_fit.cpp.
#include "btfgmm/methods/neural_btf.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "btfgmm/core/error.hpp"
#include "methods/neural_btf_internal.hpp"
#include "methods/pca_methods.hpp"
#include "model/conditional.hpp"

namespace btfgmm {
namespace {

constexpr std::string_view kMethod = "neural";

// The queries of predict() evaluated together: one forward pass a block, the blocks shared
// among the threads (the block, not the thread count, sets each result).
constexpr std::size_t kQueryBlock = 1024;

// The latents' neighbours for the compact encoding: each latent dimension an image of the tile.
detail::FactorLayout latent_layout(const ModelFrame& f) {
  return {.across = std::size_t(f.width), .channels = 1};
}

void check_queries(std::span<const Query> queries, std::span<float> rgb) {
  if (rgb.size() < queries.size() * 3)
    throw Error(Error::Kind::kArgument, "predict: the output holds fewer than 3 floats a query");
  for (const Query& q : queries) {
    detail::check_direction(q.light, "light");
    detail::check_direction(q.view, "view");
    if (!std::isfinite(q.x) || !std::isfinite(q.y))
      throw Error(Error::Kind::kArgument,
                  fmt::format("query position ({}, {}) is not finite", q.x, q.y));
  }
}

// The network's outputs (samples x 3) for `inputs` (samples x input_size), in blocks of
// exactly kQueryBlock samples, the last padded with zeros: Eigen's product then takes one path
// for every block (where one sample alone would take the matrix-vector one, and another sum
// order), so a sample's output is the same bits whatever the samples beside it, as a query's
// answer must be (the same from eval, predict, decode and render).
void forward_in_blocks(const detail::NetworkShape& shape, std::span<const float> theta,
                       std::span<const float> inputs, float* out) {
  const std::size_t n = detail::input_size(shape), samples = inputs.size() / n;
  std::vector<float> block(kQueryBlock * n), y(kQueryBlock * detail::kNetworkOutputs);
  for (std::size_t first = 0; first < samples; first += kQueryBlock) {
    const std::size_t count = std::min(kQueryBlock, samples - first);
    std::fill(std::copy_n(&inputs[first * n], count * n, block.begin()), block.end(), 0.0f);
    detail::forward(shape, theta, block, y);
    std::copy_n(y.begin(), count * detail::kNetworkOutputs, out + first * detail::kNetworkOutputs);
  }
}

// Queries first .. first + count - 1 (count <= kQueryBlock): their inputs, one forward pass,
// the outputs scaled.
void predict_block(const NeuralBtf& m, std::span<const Query> queries, std::size_t first,
                   std::size_t count, float* rgb) {
  const detail::NetworkShape shape = detail::network_shape(m.shape());
  const std::size_t n = detail::input_size(shape), L = shape.latent;
  std::vector<float> inputs(count * n);
  for (std::size_t k = 0; k < count; ++k) {
    const Query& q = queries[first + k];
    detail::bilinear_latent(m, q.x, q.y, &inputs[k * n]);
    detail::encode_directions(to_vector(q.light), to_vector(q.view),
                              std::span(inputs).subspan(k * n + L, detail::kDirectionInputs));
  }
  float* out = rgb + first * 3;
  forward_in_blocks(shape, m.network_parameters(), inputs, out);
  for (std::size_t i = 0; i < count * 3; ++i) out[i] *= m.scale();
}

// One decoded image, pair (light, view) at width x height pixels: each texel of the tile once
// (its own latent, forward in blocks: a texel's answer is the same bits among any others),
// then the tile repeated.
void decode_image(const NeuralBtf& m, const Direction& light, const Direction& view, int width,
                  int height, float* rgb) {
  const detail::NetworkShape shape = detail::network_shape(m.shape());
  const std::size_t n = detail::input_size(shape), L = shape.latent;
  const ModelFrame& f = m.frame();
  const std::size_t texels = std::size_t(f.width) * std::size_t(f.height);
  float directions[detail::kDirectionInputs];
  detail::encode_directions(to_vector(light), to_vector(view), directions);
  std::vector<float> inputs(texels * n), tile(texels * detail::kNetworkOutputs);
  for (std::size_t p = 0; p < texels; ++p) {
    std::copy_n(&m.latents()[p * L], L, &inputs[p * n]);
    std::copy_n(directions, detail::kDirectionInputs, &inputs[p * n + L]);
  }
  forward_in_blocks(shape, m.network_parameters(), inputs, tile.data());
  for (float& v : tile) v *= m.scale();
  detail::repeat_tile(tile.data(), f.width, f.height, width, height, rgb);
}

// Error(kFormat) through `r` for a scale that is not a positive finite number.
float get_scale(detail::ByteReader& r) {
  const float scale = r.get<float>("scale");
  if (!std::isfinite(scale) || scale <= 0.0f)
    r.fail(fmt::format("the output scale {} is not a positive finite number", scale));
  return scale;
}

}  // namespace

namespace detail {

// A texel's latent at a real tile position: bilinear between the four texels around it (texel
// centres at whole coordinates; the tile wraps); at a whole position the texel's own latent,
// exactly (weights of 0 are skipped).
void bilinear_latent(const NeuralBtf& m, double qx, double qy, float* out) {
  const ModelFrame& f = m.frame();
  const std::size_t L = m.shape().latent;
  const double x = detail::tile_coordinate(qx, f.width), y = detail::tile_coordinate(qy, f.height);
  const int x0 = int(std::floor(x)) % f.width, y0 = int(std::floor(y)) % f.height;
  const double fx = x - std::floor(x), fy = y - std::floor(y);
  const int xs[2] = {x0, (x0 + 1) % f.width}, ys[2] = {y0, (y0 + 1) % f.height};
  const double wx[2] = {1.0 - fx, fx}, wy[2] = {1.0 - fy, fy};
  std::fill(out, out + L, 0.0f);
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const double w = wy[dy] * wx[dx];
      if (w == 0.0) continue;
      const std::size_t p = std::size_t(ys[dy]) * std::size_t(f.width) + std::size_t(xs[dx]);
      for (std::size_t j = 0; j < L; ++j)
        out[j] = float(double(out[j]) + w * double(m.latents()[p * L + j]));
    }
}

NetworkShape network_shape(const NeuralShape& s) {
  return {.latent = s.latent, .width = s.width, .depth = s.depth};
}

std::vector<float> latent_rows(std::span<const float> latents, std::size_t latent) {
  return transposed(latents, latents.size() / latent, latent);
}

std::vector<float> latent_columns(std::span<const float> rows, std::size_t latent) {
  return transposed(rows, latent, rows.size() / latent);
}

}  // namespace detail

NeuralBtf::NeuralBtf(ModelFrame frame, NeuralShape shape, FactorEncoding encoding, float scale,
                     std::vector<float> latents, std::vector<float> parameters)
    : frame_(std::move(frame)),
      shape_(shape),
      encoding_(encoding),
      scale_(scale),
      latents_(std::move(latents)),
      parameters_(std::move(parameters)) {}

std::string_view NeuralBtf::method() const {
  return kMethod;
}

std::string NeuralBtf::size_text() const {
  return fmt::format("L = {}, {} x {}", shape_.latent, shape_.depth, shape_.width);
}

std::uint64_t neural_btf_parameter_count(const ModelFrame& frame, const NeuralShape& shape) {
  return std::uint64_t(frame.pixels()) * shape.latent +
         detail::parameter_count(detail::network_shape(shape));
}

std::uint64_t NeuralBtf::parameter_count() const {
  return neural_btf_parameter_count(frame_, shape_);
}

void NeuralBtf::predict(std::span<const Query> queries, std::span<float> rgb) const {
  check_queries(queries, rgb);
  if (device_) return detail::predict_on(*device_, *this, queries, rgb);
  const std::size_t blocks = (queries.size() + kQueryBlock - 1) / kQueryBlock;
#pragma omp parallel
  {
    omp_set_num_threads(1);  // Eigen's products one thread each
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t b = 0; b < std::ptrdiff_t(blocks); ++b) {
      const std::size_t first = std::size_t(b) * kQueryBlock;
      predict_block(*this, queries, first, std::min(kQueryBlock, queries.size() - first),
                    rgb.data());
    }
  }
}

Btf NeuralBtf::decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
                      double /*tolerance: every value is exact*/) const {
  detail::check_decode_request(lights, views, width, height);
  if (device_) return detail::decode_on(*device_, *this, lights, views, width, height);
  Btf out(lights, views, width, height, frame_.format);
  out.set_origin(frame_.origin);
  const std::size_t pairs = lights.size() * views.size();
#pragma omp parallel
  {
    omp_set_num_threads(1);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t j = 0; j < std::ptrdiff_t(pairs); ++j) {
      const std::size_t l = std::size_t(j) / views.size(), v = std::size_t(j) % views.size();
      decode_image(*this, lights[l], views[v], width, height, out.image(l, v));
    }
  }
  return out;
}

bool NeuralBtf::compute_on(std::shared_ptr<ComputeDevice> device) {
  device_ = std::move(device);
  return true;
}

std::vector<std::uint8_t> NeuralBtf::payload() const {
  detail::ByteWriter w;
  detail::put_frame(w, frame_);
  w.put<std::uint32_t>(std::uint32_t(shape_.latent));
  w.put<std::uint32_t>(std::uint32_t(shape_.width));
  w.put<std::uint32_t>(std::uint32_t(shape_.depth));
  w.put<float>(scale_);
  w.put<std::uint8_t>(std::uint8_t(encoding_));
  detail::put_factors(w, detail::latent_rows(latents_, shape_.latent), frame_.pixels(), encoding_,
                      latent_layout(frame_));
  detail::put_factors(w, parameters_, parameters_.size(), FactorEncoding::kF16);
  return std::move(w.bytes);
}

std::vector<std::pair<std::string, std::string>> NeuralBtf::details() const {
  const std::size_t network = detail::parameter_count(detail::network_shape(shape_));
  return {
      {"network",
       fmt::format("{} hidden layers of {} units (leaky ReLU), {} inputs, RGB out", shape_.depth,
                   shape_.width, detail::input_size(detail::network_shape(shape_)))},
      {"latents", fmt::format("{} values per texel, {} x {} texels", shape_.latent, frame_.width,
                              frame_.height)},
      {"latent encoding", std::string(to_string(encoding_))},
      {"network encoding", "f16"},
      {"output scale", fmt::format("{:g}", scale_)},
      {"stored values", fmt::format("{} ({} latents, {} network parameters)", parameter_count(),
                                    latents_.size(), network)},
  };
}

std::unique_ptr<Representation> read_neural_btf(std::span<const std::uint8_t> payload,
                                                std::uint32_t flags, const std::string& name) {
  detail::ByteReader r(payload, "model file", name, "fit the model again");
  detail::expect_no_flags(r, flags);
  ModelFrame f = detail::get_frame(r);
  NeuralShape shape;
  shape.latent = detail::get_count(r, 1, detail::kMaxLatent, "latent size");
  shape.width = detail::get_count(r, 1, detail::kMaxWidth, "network width");
  shape.depth = detail::get_count(r, 1, detail::kMaxDepth, "network depth");
  const float scale = get_scale(r);
  const FactorEncoding e = detail::get_encoding(r);
  const std::size_t network = detail::parameter_count(detail::network_shape(shape));
  detail::expect_bytes_for(r, double(f.pixels()) * double(shape.latent), e,
                           fmt::format("{} latents of {} texels", shape.latent, f.pixels()));
  auto rows =
      detail::get_factors_as(r, payload, shape.latent, f.pixels(), e, "latents", latent_layout(f));
  detail::expect_bytes_for(r, double(network), FactorEncoding::kF16,
                           fmt::format("{} network parameters", network));
  auto theta =
      detail::get_factors_as(r, payload, 1, network, FactorEncoding::kF16, "network parameters");
  detail::expect_end(r);
  return std::make_unique<NeuralBtf>(std::move(f), shape, e, scale,
                                     detail::latent_columns(rows, shape.latent), std::move(theta));
}

namespace {

// The ladder's path of shapes, growing: below the default width, small networks of a short
// latent; then the latent grown at the default network to L = 16; then the network widened
// at L = 16 to kNeuralWidestRung units; then the latent grown at that width (tiles of many
// texels). On generated knit 25 x 25 the width pays where a longer latent does not (docs/
// BENCHMARKS.md, "Widening the network at the high rates": L = 16, 2 x 128 at 50 KB over
// L = 64, 2 x 64 at 57 KB by 1.2 dB).
std::vector<NeuralShape> ladder_path() {
  std::vector<NeuralShape> path;
  for (std::size_t width : {8, 16, 32}) path.push_back({2, width, kNeuralDefaultDepth});
  for (std::size_t width : {16, 32}) path.push_back({4, width, kNeuralDefaultDepth});
  for (std::size_t latent : {2, 4, 8, 16})
    path.push_back({latent, kNeuralDefaultWidth, kNeuralDefaultDepth});
  for (std::size_t width : {96, 128, 192, 256}) path.push_back({16, width, kNeuralDefaultDepth});
  for (std::size_t latent : {32, 64, 128})
    path.push_back({latent, kNeuralWidestRung, kNeuralDefaultDepth});
  return path;
}

int fields_apart(const NeuralShape& a, const NeuralShape& b) {
  return int(a.latent != b.latent) + int(a.width != b.width) + int(a.depth != b.depth);
}

// `chosen` (indices of `path`, increasing) with, between two that differ in more than one
// size, the shape of the path between them that differs from each in one (the path's corner):
// so the rungs on either side of it differ in one size, which the budget's quick search varies.
std::vector<std::size_t> with_corners(const std::vector<NeuralShape>& path,
                                      const std::vector<std::size_t>& chosen) {
  std::vector<std::size_t> out;
  for (const std::size_t i : chosen) {
    if (!out.empty() && fields_apart(path[out.back()], path[i]) > 1)
      for (std::size_t k = out.back() + 1; k < i; ++k)
        if (fields_apart(path[out.back()], path[k]) == 1 && fields_apart(path[k], path[i]) == 1) {
          out.push_back(k);
          break;
        }
    out.push_back(i);
  }
  return out;
}

}  // namespace

std::vector<FitOptions> neural_btf_ladder(const ModelFrame& frame) {
  // For each ratio the nearest shape of the path (in log ratio), each once, in the path's
  // order (which grows in parameters), with the corners between.
  const std::vector<NeuralShape> path = ladder_path();
  std::vector<std::size_t> chosen;
  for (double target : {3000.0, 1600.0, 800.0, 400.0, 200.0, 100.0}) {
    std::size_t best = 0;
    double best_gap = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < path.size(); ++i) {
      const double ratio = frame.data_values() / double(neural_btf_parameter_count(frame, path[i]));
      const double gap = std::abs(std::log(ratio / target));
      if (gap < best_gap) best = i, best_gap = gap;
    }
    if (std::find(chosen.begin(), chosen.end(), best) == chosen.end()) chosen.push_back(best);
  }
  std::sort(chosen.begin(), chosen.end());
  std::vector<FitOptions> out;
  for (const std::size_t i : with_corners(path, chosen)) {
    FitOptions s;
    s.components = path[i].latent;
    s.width = path[i].width;
    s.depth = path[i].depth;
    out.push_back(s);
  }
  return out;
}

FitOptions neural_byte_probe(const FitOptions& s) {
  FitOptions probe = s;
  probe.iterations = kNeuralProbeEpochs;
  return probe;
}

std::unique_ptr<Representation> neural_without_latents(const Representation& model) {
  const auto* m = dynamic_cast<const NeuralBtf*>(&model);
  if (!m)
    throw Error(Error::Kind::kArgument,
                fmt::format("a {} model is not a neural BTF", model.method()));
  auto out = std::make_unique<NeuralBtf>(
      m->frame(), m->shape(), m->encoding(), m->scale(),
      std::vector<float>(m->latents().size(), 0.0f),
      std::vector<float>(m->network_parameters().begin(), m->network_parameters().end()));
  out->set_provenance(m->provenance());
  return out;
}

}  // namespace btfgmm
