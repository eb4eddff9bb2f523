// The probabilistic BTF models (Haindl & Filip, PAMI 2007): a subspace's synthesis for any
// (light, view), shaded with the range map's relief; the payload.
#include "btfgmm/methods/texture_models.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/model/model_file.hpp"
#include "methods/colour_texture.hpp"
#include "methods/factors.hpp"
#include "methods/image_moments.hpp"
#include "methods/pyramid.hpp"
#include "methods/relief_structure.hpp"
#include "model/conditional.hpp"

namespace btfgmm {
namespace {

std::size_t nearest(const DirectionSet& set, const Direction& d) {
  std::size_t best = 0;
  double best_angle = 1e300;
  for (std::size_t i = 0; i < set.size(); ++i)
    if (const double a = angular_distance_deg(set[i], d); a < best_angle) best_angle = a, best = i;
  return best;
}

// The range map's unit normals (-hx, -hy, 1)/|.|, central differences on the torus.
std::vector<float> normals_of(std::span<const float> h, int w, int ht) {
  std::vector<float> n(h.size() * 3);
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) {
      const auto at = [&](int i, int j) {
        return double(h[std::size_t(((j + ht) % ht) * w + (i + w) % w)]);
      };
      const double hx = (at(x + 1, y) - at(x - 1, y)) / 2, hy = (at(x, y + 1) - at(x, y - 1)) / 2;
      const double len = std::sqrt(hx * hx + hy * hy + 1);
      float* p = &n[std::size_t(y * w + x) * 3];
      p[0] = float(-hx / len), p[1] = float(-hy / len), p[2] = float(1 / len);
    }
  return n;
}

// The bump shading's numerator max(0, n.l) at a range-map pixel.
float lit(const float* n, const Vec3& l) {
  return float(std::max(0.0, n[0] * l.x + n[1] * l.y + n[2] * l.z));
}

// Its mean over the map under `light`, the shading's denominator (1 where the light grazes the
// whole map, to leave the synthesis as it is there).
float mean_lit(std::span<const float> normals, const Direction& light) {
  const Vec3 l = to_vector(light);
  double sum = 0;
  for (std::size_t i = 0; i < normals.size(); i += 3) sum += lit(&normals[i], l);
  const double mean = sum / double(normals.size() / 3);
  return mean > 1e-3 ? float(mean) : 0.0f;
}

}  // namespace

TextureModel::TextureModel(std::string_view method, ModelFrame frame,
                           std::vector<std::uint8_t> labels, std::vector<Subspace> subspaces,
                           std::vector<float> heights, std::uint64_t seed,
                           FactorEncoding range_encoding,
                           std::shared_ptr<const detail::ImageMoments> moments,
                           std::shared_ptr<const std::vector<detail::ReliefStructure>> relief)
    : method_(method),
      frame_(std::move(frame)),
      labels_(std::move(labels)),
      subspaces_(std::move(subspaces)),
      heights_(std::move(heights)),
      seed_(seed),
      range_encoding_(range_encoding),
      moments_(std::move(moments)),
      relief_(std::move(relief)) {
  normals_ = normals_of(heights_, frame_.width, frame_.height);
  if (relief_)
    relief_features_ = std::make_shared<detail::ReliefFeatures>(
        detail::relief_features(heights_, frame_.width, frame_.height));
  for (const Direction& l : frame_.lights) mean_lit_.push_back(mean_lit(normals_, l));
  synthesise_tiles();
}

void TextureModel::synthesise_tiles() {
  tiles_.assign(subspaces_.size(), {});
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t k = 0; k < std::ptrdiff_t(subspaces_.size()); ++k)
    tiles_[std::size_t(k)] = synthesise_subspace(std::size_t(k), frame_.width, frame_.height);
  measure_shaded_tiles();
}

std::vector<float> TextureModel::synthesise_subspace(std::size_t k, int width, int height) const {
  detail::Field f = subspaces_[k]->synthesise(width, height, seed_);
  if (relief_)
    detail::add_relief_shape((*relief_)[k], *relief_features_, f.values.data(), width, height);
  std::vector<float> out(f.values.begin(), f.values.end());
  if (moments_) detail::match_marginal(out.data(), f.pixels(), moments_->marginals[k]);
  return out;
}

void TextureModel::measure_shaded_tiles() {
  shaded_moments_.clear();
  if (!moments_) return;
  const std::size_t nl = frame_.lights.size(), pixels = frame_.pixels();
  shaded_moments_.assign(subspaces_.size() * nl * 6, 0.0f);
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t l = 0; l < std::ptrdiff_t(nl); ++l) {
    const Lighting lighting = lighting_of(frame_.lights[std::size_t(l)]);
    std::vector<float> img(pixels * 3);
    for (std::size_t k = 0; k < subspaces_.size(); ++k) {
      light_synthesis(k, lighting, tiles_[k], frame_.width, frame_.height, img.data());
      float* m = &shaded_moments_[(k * nl + std::size_t(l)) * 6];
      detail::measure_moments(img.data(), pixels, m, m + 3);
    }
  }
}

TextureModel::Lighting TextureModel::lighting_of(const Direction& light) const {
  return {.shade = shading(light),
          .measured = to_vector(frame_.lights[nearest(frame_.lights, light)])};
}

void TextureModel::light_synthesis(std::size_t k, const Lighting& lighting,
                                   std::span<const float> s, int width, int height,
                                   float* out) const {
  std::copy(s.begin(), s.end(), out);
  if (relief_)
    detail::add_relief_slope((*relief_)[k], *relief_features_, lighting.measured, out, width,
                             height);
  const std::vector<float>& shade = lighting.shade;
  const int tw = frame_.width, th = frame_.height;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float b = shade[std::size_t((y % th) * tw + x % tw)];
      float* p = &out[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3];
      for (std::size_t c = 0; c < 3; ++c) p[c] *= b;
    }
}

void TextureModel::set_synthesis_seed(std::uint64_t seed, std::string_view) {
  seed_ = seed;
  synthesise_tiles();
}

std::string TextureModel::size_text() const {
  return fmt::format("c = {}", subspaces_.size());
}

std::uint64_t TextureModel::parameter_count() const {
  std::uint64_t n = labels_.size() + heights_.size();
  if (moments_) n += labels_.size() * 6 + subspaces_.size() * 3 * detail::kQuantiles;
  if (relief_) n += relief_->size() * 3 * detail::kReliefFeatures;
  for (const Subspace& s : subspaces_) n += s->parameter_count();
  return n;
}

std::size_t TextureModel::image_of(const Direction& light, const Direction& view) const {
  return nearest(frame_.lights, light) * frame_.views.size() + nearest(frame_.views, view);
}

std::size_t TextureModel::label_of(const Direction& light, const Direction& view) const {
  return labels_[image_of(light, view)];
}

std::uint32_t TextureModel::file_flags() const {
  return (moments_ ? kImageMoments | kPredictedImageMoments : 0) | (relief_ ? kReliefStructure : 0);
}

float TextureModel::shading(std::size_t pixel, const Direction& light) const {
  const float mean = mean_lit_[nearest(frame_.lights, light)];
  if (mean <= 0.0f) return 1.0f;
  return 1.0f + kRelief * (lit(&normals_[pixel * 3], to_vector(light)) / mean - 1.0f);
}

std::vector<float> TextureModel::shading(const Direction& light) const {
  const float mean = mean_lit_[nearest(frame_.lights, light)];
  const Vec3 l = to_vector(light);
  std::vector<float> out(normals_.size() / 3, 1.0f);
  if (mean > 0.0f)
    for (std::size_t p = 0; p < out.size(); ++p)
      out[p] = 1.0f + kRelief * (lit(&normals_[p * 3], l) / mean - 1.0f);
  return out;
}

// Bilinear between the four nearest pixels of the tile-sized synthesis, the tile repeating
// (as the measured data is read): at a pixel centre, the pixel as decode gives it.
void TextureModel::predict(std::span<const Query> queries, std::span<float> rgb) const {
  const long long w = frame_.width, h = frame_.height;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    const Query& q = queries[i];
    detail::check_direction(q.light, "light");
    detail::check_direction(q.view, "view");
    const std::size_t image = image_of(q.light, q.view), k = labels_[image];
    const std::vector<float>& tile = tiles_[k];
    const Vec3 lit = to_vector(frame_.lights[image / frame_.views.size()]);
    const double fx = std::floor(q.x), fy = std::floor(q.y);
    const double wx = q.x - fx, wy = q.y - fy;
    for (std::size_t c = 0; c < 3; ++c) rgb[i * 3 + c] = 0.0f;
    for (int corner = 0; corner < 4; ++corner) {
      const int dx = corner & 1, dy = corner >> 1;
      const double weight = (dx ? wx : 1 - wx) * (dy ? wy : 1 - wy);
      if (weight == 0.0) continue;
      const long long x = ((static_cast<long long>(fx) + dx) % w + w) % w;
      const long long y = ((static_cast<long long>(fy) + dy) % h + h) % h;
      const std::size_t p = std::size_t(y * w + x);
      const float b = float(weight) * shading(p, q.light);
      float v[3] = {tile[p * 3], tile[p * 3 + 1], tile[p * 3 + 2]};
      if (relief_) detail::add_relief_slope_at((*relief_)[k], *relief_features_, lit, x, y, v);
      for (std::size_t c = 0; c < 3; ++c) rgb[i * 3 + c] += v[c] * b;
    }
    if (moments_) {  // the image's moments from the shaded tile's
      const float* have =
          &shaded_moments_[(k * frame_.lights.size() + image / frame_.views.size()) * 6];
      for (std::size_t c = 0; c < 3; ++c) {
        const float scale =
            have[3 + c] > 0.0f ? moments_->deviation[image * 3 + c] / have[3 + c] : 0.0f;
        rgb[i * 3 + c] = moments_->mean[image * 3 + c] + (rgb[i * 3 + c] - have[c]) * scale;
        if (frame_.format != SampleFormat::kHdr)
          rgb[i * 3 + c] = detail::within_levels(rgb[i * 3 + c]);
      }
    }
  }
}

Btf TextureModel::decode(const DirectionSet& lights, const DirectionSet& views, int width,
                         int height, double /*tolerance*/) const {
  detail::check_decode_request(lights, views, width, height);
  Btf out(lights, views, width, height, frame_.format);
  out.set_origin(frame_.origin);
  std::vector<const std::vector<float>*> synth(subspaces_.size(), nullptr);
  for (const Direction& l : lights)
    for (const Direction& v : views) {
      const std::size_t k = label_of(l, v);
      if (!synth[k]) synth[k] = &synthesised(k, width, height);
    }
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t li = 0; li < std::ptrdiff_t(lights.size()); ++li) {
    const Direction& light = lights[std::size_t(li)];
    const Lighting lighting = lighting_of(light);
    for (std::size_t vi = 0; vi < views.size(); ++vi) {
      const std::size_t k = label_of(light, views[vi]);
      float* img = out.image(std::size_t(li), vi);
      light_synthesis(k, lighting, *synth[k], width, height, img);
      if (moments_) {
        const std::size_t image = image_of(light, views[vi]);
        const std::size_t n = std::size_t(width) * std::size_t(height);
        detail::match_moments(img, n, &moments_->mean[image * 3], &moments_->deviation[image * 3]);
        if (frame_.format != SampleFormat::kHdr)
          for (std::size_t v = 0; v < n * 3; ++v) img[v] = detail::within_levels(img[v]);
      }
    }
  }
  return out;
}

const std::vector<float>& TextureModel::synthesised(std::size_t subspace, int width,
                                                    int height) const {
  std::lock_guard<std::mutex> lock(cache_lock_);
  if (cache_.width != width || cache_.height != height || cache_.seed != seed_ ||
      cache_.fields.size() != subspaces_.size())
    cache_ = {.width = width,
              .height = height,
              .seed = seed_,
              .fields = std::vector<std::vector<float>>(subspaces_.size())};
  std::vector<float>& f = cache_.fields[subspace];
  if (f.empty()) f = synthesise_subspace(subspace, width, height);
  return f;
}

std::vector<std::uint8_t> TextureModel::payload() const {
  detail::ByteWriter w;
  detail::put_frame(w, frame_);
  w.put<std::uint64_t>(seed_);
  w.put<std::uint8_t>(std::uint8_t(levels()));
  w.put<std::uint32_t>(std::uint32_t(subspaces_.size()));
  for (std::uint8_t l : labels_) w.put<std::uint8_t>(l);
  detail::put_factors(w, heights_, heights_.size(), range_encoding_);
  for (const Subspace& s : subspaces_) s->put(w);
  if (moments_) {
    detail::put_image_moments(w, *moments_, frame_.views.size());
    for (const std::vector<float>& z : moments_->marginals) detail::put_marginal(w, z);
  }
  if (relief_)
    for (const detail::ReliefStructure& r : *relief_) detail::put_relief_structure(w, r);
  return std::move(w.bytes);
}

int TextureModel::levels() const {
  return subspaces_.empty() ? 1 : subspaces_[0]->levels();
}

std::string TextureModel::pyramid_text() const {
  if (levels() == 1) return "1 (each subspace image modelled whole)";
  std::vector<std::string> sides;
  for (int k = 0; k < levels(); ++k)
    sides.push_back(fmt::format("{} x {}", detail::level_side(frame_.width, k),
                                detail::level_side(frame_.height, k)));
  return fmt::format("{} (Gaussian-Laplacian, a model each: {})", levels(), fmt::join(sides, ", "));
}

std::vector<std::pair<std::string, std::string>> TextureModel::details() const {
  std::uint64_t models = 0;
  for (const Subspace& s : subspaces_) models += s->parameter_count();
  const auto [lo, hi] = std::minmax_element(heights_.begin(), heights_.end());
  return {
      {"subspaces",
       fmt::format("{} (a label for each of the {} images)", subspaces_.size(), labels_.size())},
      {"pyramid levels", pyramid_text()},
      {"neighbourhood", subspaces_.empty() ? "" : subspaces_[0]->neighbourhood() + ", subspace 1"},
      {"values", fmt::format("{} labels + {} range map + {} model parameters{}{}", labels_.size(),
                             heights_.size(), models,
                             moments_ ? fmt::format(" + {} image moments + {} marginal quantiles",
                                                    labels_.size() * 6,
                                                    subspaces_.size() * 3 * detail::kQuantiles)
                                      : "",
                             relief_ ? fmt::format(" + {} relief gains",
                                                   relief_->size() * 3 * detail::kReliefFeatures)
                                     : "")},
      {"range map", fmt::format("{} x {}, heights {:.2f} to {:.2f} pixels ({})", frame_.width,
                                frame_.height, *lo, *hi, to_string(range_encoding_))},
      {"seed", std::to_string(seed_)},
      {"relief structure",
       relief_ ? fmt::format("{} gains a channel a subspace: the range map's shape (height, "
                             "squared slopes and their product, curvature) added to its "
                             "synthesis, its slope along each image's light to that image",
                             detail::kReliefFeatures)
               : "none (a file before format version 8)"},
      {"image moments",
       moments_ ? fmt::format("mean and deviation per channel of each image, steps {:.3g} and "
                              "{:.3g} (a byte each)",
                              moments_->mean_step, moments_->deviation_step)
                : "none (a file before format version 6: each image its subspace's colour)"},
  };
}

}  // namespace btfgmm
