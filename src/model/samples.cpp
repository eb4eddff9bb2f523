// The mean BRDF, the residual sample set and the random initialisation (docs/ALGORITHM.md, "The
// mean BRDF and the sample set").
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/provenance.hpp"
#include "btfgmm/model/samples.hpp"
#include "core/random.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm {

double angular_sampling_step(const DirectionSet& set) {
  if (set.size() < 2) return 1.0;
  std::vector<double> nearest;
  for (std::size_t i = 0; i < set.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < set.size(); ++j)
      if (j != i) {
        const double d = angular_distance_deg(set[i], set[j]);
        if (d > 1e-9) best = std::min(best, d);
      }
    if (std::isfinite(best)) nearest.push_back(best);
  }
  if (nearest.empty()) return 1.0;
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  return nearest[nearest.size() / 2] * std::numbers::pi / 180.0;
}

std::array<double, kVariables> SampleSet::sample(std::size_t i) const {
  const std::size_t v = i % views, l = (i / views) % lights, p = i / (views * lights);
  return {double(p % std::size_t(width)),
          double(p / std::size_t(width)),
          light_ab[l][0],
          light_ab[l][1],
          view_ab[v][0],
          view_ab[v][1],
          residual_of(i, 0),
          residual_of(i, 1),
          residual_of(i, 2)};
}

void SampleSet::block_residuals(std::size_t p, std::size_t l, float* out) const {
  const std::size_t first = index(p, l, 0) * 3, n = views * 3;
  if (levels.empty()) {
    std::copy_n(&residual[first], n, out);
    return;
  }
  const float* mean = &mean_brdf[l * views * 3];
  const std::uint8_t* level = &levels[first];
  for (std::size_t k = 0; k < n; ++k) out[k] = (float(level[k]) - mean[k]) * inv_colour_unit;
}

namespace {

// The frame of a sample set: its size, and the units (docs/ALGORITHM.md): pixels; the angular
// sampling step of each direction set; 8-bit levels for LDR data, 1/255 of the data's range
// (lo .. hi) for HDR. The directions' onion-slice angles in those units.
SampleSet sample_frame(const DirectionSet& lights, const DirectionSet& views, int width, int height,
                       SampleFormat format, float lo, float hi) {
  SampleSet s;
  s.width = width;
  s.height = height;
  s.lights = lights.size();
  s.views = views.size();
  const double light_unit = angular_sampling_step(lights);
  const double view_unit = angular_sampling_step(views);
  double colour_unit = 1.0;
  if (format == SampleFormat::kHdr) colour_unit = hi > lo ? double(hi - lo) / 255.0 : 1.0;
  s.scaling.unit = {1.0,       1.0,         light_unit,  light_unit, view_unit,
                    view_unit, colour_unit, colour_unit, colour_unit};
  s.inv_colour_unit = float(1.0 / colour_unit);
  for (const Direction& d : lights) {
    const OnionSlice o = to_onion_slice(d);
    s.light_ab.push_back({o.alpha / light_unit, o.beta / light_unit});
  }
  for (const Direction& d : views) {
    const OnionSlice o = to_onion_slice(d);
    s.view_ab.push_back({o.alpha / view_unit, o.beta / view_unit});
  }
  return s;
}

// The sample set's data take `bytes` a sample beside the tile; refused beyond memory.
void check_sample_memory(const SampleSet& s, double bytes) {
  limits::check_memory(double(s.size()) * bytes,
                       fmt::format("fitting a {}x{} tile of {} lights x {} views", s.width,
                                   s.height, s.lights, s.views),
                       "fit a smaller tile (--tile)");
}

// 8-bit levels: whole numbers 0 .. 255 (the Btf's kLdr8 data).
bool whole_levels(std::span<const float> values) {
  return std::all_of(values.begin(), values.end(),
                     [](float v) { return v >= 0.0f && v <= 255.0f && v == std::floor(v); });
}

// One image's samples (pixel, RGB) into their places in the sample order, as levels.
void store_levels(SampleSet& s, std::size_t l, std::size_t v, std::span<const float> img) {
  for (std::size_t p = 0; p < s.pixels(); ++p)
    for (std::size_t c = 0; c < 3; ++c)
      s.levels[s.index(p, l, v) * 3 + c] = std::uint8_t(img[p * 3 + c]);
}

// The mean RGB of one image (the mean BRDF's entry), as mean_brdf computes it.
void image_mean(std::span<const float> img, std::size_t pixels, float* out) {
  double sum[3] = {0, 0, 0};
  for (std::size_t p = 0; p < pixels; ++p)
    for (int c = 0; c < 3; ++c) sum[c] += img[p * 3 + std::size_t(c)];
  for (int c = 0; c < 3; ++c) out[c] = float(sum[c] / double(pixels));
}

}  // namespace

std::vector<float> mean_brdf(const Btf& btf) {
  const std::size_t pixels = std::size_t(btf.width()) * btf.height();
  std::vector<float> out(btf.image_count() * 3);
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < btf.image_count(); ++i) {
    image_mean({btf.data().data() + i * btf.image_floats(), btf.image_floats()}, pixels,
               &out[i * 3]);
  }
  return out;
}

SampleSet make_sample_set(const Btf& btf) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (float v : btf.data()) {
    if (!std::isfinite(v))
      throw Error(Error::Kind::kFormat,
                  "the BTF holds a non-finite value (NaN or infinity); replace it before "
                  "fitting");
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  SampleSet s =
      sample_frame(btf.lights(), btf.views(), btf.width(), btf.height(), btf.format(), lo, hi);
  const std::size_t pixels = s.pixels();
  s.mean_brdf = mean_brdf(btf);
  const bool bytes = btf.format() == SampleFormat::kLdr8 && whole_levels(btf.data());
  check_sample_memory(s, bytes ? 4.0 : 13.0);
  if (bytes) {
    s.levels.resize(s.size() * 3);
#pragma omp parallel for schedule(static)
    for (std::size_t l = 0; l < s.lights; ++l)
      for (std::size_t v = 0; v < s.views; ++v)
        store_levels(s, l, v, {btf.image(l, v), btf.image_floats()});
    return s;
  }
  s.residual.resize(s.size() * 3);
  const float inv_unit = s.inv_colour_unit;
#pragma omp parallel for schedule(static)
  for (std::size_t l = 0; l < s.lights; ++l)
    for (std::size_t v = 0; v < s.views; ++v) {
      const float* img = btf.image(l, v);
      const float* mean = &s.mean_brdf[btf.image_index(l, v) * 3];
      for (std::size_t p = 0; p < pixels; ++p)
        for (int c = 0; c < 3; ++c)
          s.residual[s.index(p, l, v) * 3 + c] = (img[p * 3 + c] - mean[c]) * inv_unit;
    }
  return s;
}

namespace {

// tile_content_hash (provenance.hpp) of the tile a sample set of levels holds: its images in
// order, each gathered from the sample order one light at a time.
std::uint64_t levels_content_hash(const SampleSet& s) {
  const std::size_t pixels = s.pixels(), nv = s.views;
  std::vector<std::uint8_t> light(nv * pixels * 3);
  std::vector<float> values(pixels * 3);
  std::uint64_t h = kContentHashBasis;
  for (std::size_t l = 0; l < s.lights; ++l) {
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < pixels; ++p)
      for (std::size_t v = 0; v < nv; ++v)
        for (std::size_t c = 0; c < 3; ++c)
          light[(v * pixels + p) * 3 + c] = s.levels[s.index(p, l, v) * 3 + c];
    for (std::size_t v = 0; v < nv; ++v) {
      const std::uint8_t* img = &light[v * pixels * 3];
      for (std::size_t k = 0; k < pixels * 3; ++k) values[k] = float(img[k]);
      h = content_hash_add(h, values);
    }
  }
  return h;
}

}  // namespace

SampleSet read_sample_set(const BtfSource& source, const Tile& tile, std::uint64_t* content_hash) {
  const BtfInfo& info = source.info();
  if (info.format != SampleFormat::kLdr8) {
    const Btf btf = source.load(tile);
    if (content_hash) *content_hash = tile_content_hash(btf);
    return make_sample_set(btf);
  }
  const Tile t = tile.empty() ? Tile{0, 0, info.width, info.height} : tile;
  SampleSet s = sample_frame(info.lights, info.views, t.width, t.height, info.format, 0, 0);
  check_sample_memory(s, 4.0);
  s.levels.resize(s.size() * 3);
  s.mean_brdf.resize(s.lights * s.views * 3);
  const std::size_t nv = s.views;
  source.read_tiles(t, 0, s.lights * nv, [&](std::size_t i, std::span<const float> img) {
    if (!whole_levels(img))
      throw Error(Error::Kind::kFormat,
                  fmt::format("image '{}' of {} holds a value that is not an 8-bit level",
                              source.image_name(i / nv, i % nv), info.path.string()));
    image_mean(img, s.pixels(), &s.mean_brdf[i * 3]);
    store_levels(s, i / nv, i % nv, img);
  });
  if (content_hash) *content_hash = levels_content_hash(s);
  return s;
}

ProductMixture initial_mixture(const SampleSet& s, std::size_t components, std::uint64_t seed) {
  const std::size_t n = s.size();
  if (components < 1)
    throw Error(Error::Kind::kArgument, "components = 0: give at least one component");
  if (components > n)
    throw Error(Error::Kind::kArgument,
                fmt::format("components = {} is more than the {} samples of the tile; give "
                            "fewer components or a larger tile",
                            components, n));
  // EM's tables (docs/ALGORITHM.md): per pixel and component a float table and a double
  // accumulator, per light and view and component the 17 chunks' double accumulators.
  const double padded = double((components + 15) / 16 * 16);
  limits::check_memory(double(s.pixels()) * padded * 12.0 +
                           17.0 * double(s.lights + s.views + 6) * padded * 8.0 +
                           double(s.size()) * double(s.bytes_per_sample() + 1),
                       fmt::format("fitting M = {} components to a {}x{} tile of {} lights x {} "
                                   "views",
                                   components, s.width, s.height, s.lights, s.views),
                       "give fewer components (--components) or a smaller tile (--tile)");
  // The variance of each variable over the sample set (shifted by the first sample).
  std::array<double, kVariables> s1{}, s2{};
  const auto ref = s.sample(0);
  const std::size_t stride = std::max<std::size_t>(1, n / 1000000);  // at most ~1e6 samples
  double count = 0;
  for (std::size_t i = 0; i < n; i += stride, ++count) {
    const auto x = s.sample(i);
    for (int v = 0; v < kVariables; ++v) {
      s1[v] += x[v] - ref[v];
      s2[v] += (x[v] - ref[v]) * (x[v] - ref[v]);
    }
  }
  // Each component starts as wide as one of M equal cells of the six inputs would be: the
  // variance over the sample set divided by M^(1/3) (sigma by M^(1/6)). Starting every
  // component as wide as the whole set (the textbook choice) gave a worse predictor for the
  // same likelihood on generated tiles (RMSE 19.1 against 17.5 levels, 16 x 16 corduroy,
  // M = 100, 8 iterations).
  // x and y within the ceiling of their wrapped Gaussians (mixture_internal.hpp).
  const double shrink = std::cbrt(double(components));
  const detail::Periods periods = detail::variable_periods({double(s.width), double(s.height)});
  std::array<double, kVariables> var{};
  for (int v = 0; v < kVariables; ++v)
    var[v] = detail::bounded_variance((s2[v] / count - (s1[v] / count) * (s1[v] / count)) / shrink,
                                      kVarianceFloor, periods[std::size_t(v)]);

  ProductMixture mix;
  mix.resize(components);
  detail::SplitMix64 random(seed);
  std::vector<std::size_t> chosen;
  for (std::size_t m = 0; m < components; ++m) {
    std::size_t i = 0;
    do i = std::size_t(random.next() % n);
    while (components * 4 <= n && std::find(chosen.begin(), chosen.end(), i) != chosen.end());
    chosen.push_back(i);
    mix.weight[m] = 1.0 / double(components);
    mix.mean[m] = s.sample(i);
    mix.var[m] = var;
  }
  return mix;
}

}  // namespace btfgmm
