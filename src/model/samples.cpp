// The mean BRDF, the residual sample set and the random initialisation (docs/ALGORITHM.md, "The
// mean BRDF and the sample set").
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
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

std::array<double, kVariables> SampleSet::sample(std::size_t i,
                                                 const std::array<float, 3>& rgb) const {
  const std::size_t v = i % views, l = (i / views) % lights, p = i / (views * lights);
  return {double(p % std::size_t(width)),
          double(p / std::size_t(width)),
          light_ab[l][0],
          light_ab[l][1],
          view_ab[v][0],
          view_ab[v][1],
          rgb[0],
          rgb[1],
          rgb[2]};
}

std::array<double, kVariables> SampleSet::sample(std::size_t i) const {
  const std::size_t v = i % views, l = (i / views) % lights, p = i / (views * lights);
  return sample(i, {residual_of(p, l, v, 0), residual_of(p, l, v, 1), residual_of(p, l, v, 2)});
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
  limits::check_memory(double(s.held_size()) * bytes,
                       fmt::format("fitting a {}x{} tile of {} lights x {} views", s.width,
                                   s.height, s.lights, s.views),
                       "fit a smaller tile (`tile`)");
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

// tile_content_hash (provenance.hpp) from `h` on, over the images of this process's lights
// in a sample set of levels, each gathered from the sample order one light at a time.
std::uint64_t levels_content_hash(const SampleSet& s, std::uint64_t h) {
  const std::size_t pixels = s.pixels(), nv = s.views;
  std::vector<std::uint8_t> light(nv * pixels * 3);
  std::vector<float> values(pixels * 3);
  for (std::size_t l = s.first_light; l < s.light_end(); ++l) {
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

// The content hash of the whole tile: each process's images (mine(h), from h on) in process
// order, which is the images' order.
std::uint64_t chained_hash(const SampleSet& s,
                           const std::function<std::uint64_t(std::uint64_t)>& mine) {
  if (!s.processes) return mine(kContentHashBasis);
  std::uint64_t h = kContentHashBasis;
  for (int r = 0; r < s.processes->size(); ++r) {
    std::vector<std::uint64_t> out;
    if (r == s.processes->rank()) out.push_back(mine(h));
    h = all_gather_values<std::uint64_t>(*s.processes, out)[std::size_t(r)].at(0);
  }
  return h;
}

// Every process's rows of the mean BRDF (its lights'), on every process.
void share_mean_brdf(SampleSet& s) {
  if (!s.processes) return;
  const std::size_t row = s.views * 3;
  const std::span<const float> mine(&s.mean_brdf[s.first_light * row], s.held_lights() * row);
  std::size_t at = 0;
  for (const std::vector<float>& r : all_gather_values<float>(*s.processes, mine)) {
    std::copy(r.begin(), r.end(), s.mean_brdf.begin() + std::ptrdiff_t(at));
    at += r.size();
  }
}

// The range lo .. hi of every process's values.
void range_of_all(const SampleSet& s, float& lo, float& hi) {
  if (!s.processes) return;
  const float mine[2] = {lo, hi};
  for (const std::vector<float>& r : all_gather_values<float>(*s.processes, mine)) {
    lo = std::min(lo, r.at(0));
    hi = std::max(hi, r.at(1));
  }
}

// Data other than 8 bits: this process's images as read (`staged`, image order) become
// residuals in the units of the whole tile's range.
void stage_residuals(SampleSet& s, const BtfInfo& info, const std::vector<float>& staged) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (float v : staged) {
    if (!std::isfinite(v))
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} holds a non-finite value (NaN or infinity); replace it before "
                              "fitting",
                              info.path.string()));
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  range_of_all(s, lo, hi);
  const SampleSet units =
      sample_frame(info.lights, info.views, s.width, s.height, info.format, lo, hi);
  s.scaling = units.scaling;
  s.inv_colour_unit = units.inv_colour_unit;
  const std::size_t pixels = s.pixels(), nv = s.views;
  s.residual.resize(s.held_size() * 3);
#pragma omp parallel for schedule(static)
  for (std::size_t l = s.first_light; l < s.light_end(); ++l)
    for (std::size_t v = 0; v < nv; ++v) {
      const float* img = &staged[((l - s.first_light) * nv + v) * pixels * 3];
      const float* mean = &s.mean_brdf[(l * nv + v) * 3];
      for (std::size_t p = 0; p < pixels; ++p)
        for (std::size_t c = 0; c < 3; ++c)
          s.residual[s.index(p, l, v) * 3 + c] = (img[p * 3 + c] - mean[c]) * s.inv_colour_unit;
    }
}

// The frame of the sample set that process `processes` reads of `tile`: its share of the
// lights.
SampleSet shared_frame(const BtfInfo& info, const Tile& t,
                       const std::shared_ptr<Communicator>& processes) {
  const int rank = processes ? processes->rank() : 0, size = processes ? processes->size() : 1;
  if (std::size_t(size) > info.lights.size())
    throw Error(Error::Kind::kArgument,
                fmt::format("{} processes for the {} lights of {}: each process holds whole "
                            "lights; start at most {} processes",
                            size, info.lights.size(), info.path.string(), info.lights.size()));
  SampleSet s = sample_frame(info.lights, info.views, t.width, t.height, info.format, 0, 0);
  const auto [first, last] = light_share(s.lights, rank, size);
  s.processes = processes;
  s.first_light = first;
  s.held = last - first;
  return s;
}

}  // namespace

SampleSet read_sample_set(const BtfSource& source, const Tile& tile, std::uint64_t* content_hash,
                          std::shared_ptr<Communicator> processes) {
  const BtfInfo& info = source.info();
  const Tile t = tile.or_whole(info.width, info.height);
  SampleSet s = shared_frame(info, t, processes);
  const bool bytes = info.format == SampleFormat::kLdr8;
  check_sample_memory(s, bytes ? 4.0 : 25.0);
  const std::size_t nv = s.views, floats = s.pixels() * 3;
  std::vector<float> staged;  // other data: this process's images as read
  (bytes ? s.levels.resize(s.held_size() * 3) : staged.resize(s.held_size() * 3));
  s.mean_brdf.resize(s.lights * nv * 3);
  source.read_tiles(
      t, s.first_light * nv, s.light_end() * nv, [&](std::size_t i, std::span<const float> img) {
        image_mean(img, s.pixels(), &s.mean_brdf[i * 3]);
        if (!bytes) {
          std::copy(img.begin(), img.end(),
                    staged.begin() + std::ptrdiff_t((i - s.first_light * nv) * floats));
          return;
        }
        if (!whole_levels(img))
          throw Error(Error::Kind::kFormat,
                      fmt::format("image '{}' of {} holds a value that is not an "
                                  "8-bit level",
                                  source.image_name(i / nv, i % nv), info.path.string()));
        store_levels(s, i / nv, i % nv, img);
      });
  share_mean_brdf(s);
  const std::uint64_t hash = chained_hash(s, [&](std::uint64_t h) {
    return bytes ? levels_content_hash(s, h) : content_hash_add(h, staged);
  });
  if (content_hash) *content_hash = hash;
  if (!bytes) stage_residuals(s, info, staged);
  return s;
}

SampleSet first_lights(const SampleSet& s, std::size_t count) {
  SampleSet p;
  p.width = s.width;
  p.height = s.height;
  p.lights = s.lights;
  p.views = s.views;
  p.first_light = s.first_light;
  p.held = count;
  p.scaling = s.scaling;
  p.mean_brdf = s.mean_brdf;
  p.inv_colour_unit = s.inv_colour_unit;
  p.light_ab = s.light_ab;
  p.view_ab = s.view_ab;
  const auto copy = [&](const auto& from, auto& to) {
    if (from.empty()) return;
    const std::size_t block = count * s.views * 3, stride = s.held_lights() * s.views * 3;
    to.reserve(block * s.pixels());
    for (std::size_t px = 0; px < s.pixels(); ++px)
      to.insert(to.end(), from.begin() + std::ptrdiff_t(px * stride),
                from.begin() + std::ptrdiff_t(px * stride + block));
  };
  copy(s.levels, p.levels);
  copy(s.residual, p.residual);
  return p;
}

void check_em_size(const SampleSet& s, std::size_t components) {
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
                           double(s.held_size()) * double(s.bytes_per_sample() + 1),
                       fmt::format("fitting M = {} components to a {}x{} tile of {} lights x {} "
                                   "views",
                                   components, s.width, s.height, s.lights, s.views),
                       "give fewer components (`components`) or a smaller tile (`tile`)");
}

ProductMixture initial_mixture(const SampleSet& s, std::size_t components, std::uint64_t seed) {
  check_em_size(s, components);
  const std::size_t n = s.size();
  // The samples the initialisation reads: every stride-th (at most ~1e6) for the variances,
  // then M distinct random ones for the means; their colours from the processes that hold
  // them.
  const std::size_t stride = std::max<std::size_t>(1, n / 1000000);
  std::vector<std::size_t> wanted;
  for (std::size_t i = 0; i < n; i += stride) wanted.push_back(i);
  const std::size_t spread = wanted.size();
  detail::SplitMix64 random(seed);
  for (std::size_t m = 0; m < components; ++m) {
    std::size_t i = 0;
    do i = std::size_t(random.next() % n);
    while (components * 4 <= n &&
           std::find(wanted.begin() + std::ptrdiff_t(spread), wanted.end(), i) != wanted.end());
    wanted.push_back(i);
  }
  const std::vector<std::array<float, 3>> colour = gather_colours(s, wanted);
  // The variance of each variable over the sample set (shifted by the first sample).
  std::array<double, kVariables> s1{}, s2{};
  const auto ref = s.sample(0, colour[0]);
  double count = 0;
  for (std::size_t k = 0; k < spread; ++k, ++count) {
    const auto x = s.sample(wanted[k], colour[k]);
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
  for (std::size_t m = 0; m < components; ++m) {
    mix.weight[m] = 1.0 / double(components);
    mix.mean[m] = s.sample(wanted[spread + m], colour[spread + m]);
    mix.var[m] = var;
  }
  return mix;
}

std::pair<std::size_t, std::size_t> light_share(std::size_t lights, int rank, int size) {
  return {lights * std::size_t(rank) / std::size_t(size),
          lights * std::size_t(rank + 1) / std::size_t(size)};
}

std::vector<std::array<float, 3>> gather_colours(const SampleSet& s,
                                                 std::span<const std::size_t> indices) {
  auto where = [&](std::size_t i) {
    return std::array<std::size_t, 3>{i / (s.views * s.lights), (i / s.views) % s.lights,
                                      i % s.views};
  };
  auto colour_of = [&](std::size_t i) {
    const auto [p, l, v] = where(i);
    return std::array<float, 3>{s.residual_of(p, l, v, 0), s.residual_of(p, l, v, 1),
                                s.residual_of(p, l, v, 2)};
  };
  std::vector<std::array<float, 3>> out;
  if (!s.processes) {
    for (std::size_t i : indices) out.push_back(colour_of(i));
    return out;
  }
  std::vector<float> mine;
  for (std::size_t i : indices) {
    const std::size_t l = where(i)[1];
    if (l < s.first_light || l >= s.light_end()) continue;
    const auto c = colour_of(i);
    mine.insert(mine.end(), c.begin(), c.end());
  }
  const auto all = all_gather_values<float>(*s.processes, std::span<const float>(mine));
  // Each light's process, and where each process's list has been read up to.
  std::vector<std::size_t> owner(s.lights), next(all.size(), 0);
  for (int r = 0; r < int(all.size()); ++r) {
    const auto [first, last] = light_share(s.lights, r, int(all.size()));
    for (std::size_t l = first; l < last; ++l) owner[l] = std::size_t(r);
  }
  for (std::size_t i : indices) {
    const std::size_t r = owner[where(i)[1]];
    const float* c = &all[r].at(next[r]);
    out.push_back({c[0], c[1], c[2]});
    next[r] += 3;
  }
  return out;
}

}  // namespace btfgmm
