// The sample set of the paper (docs/ALGORITHM.md): the mean BRDF, the residual colours on the
// (pixel, light, view) grid in model units, and the random initialisation of the mixture.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/communicator.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/model/mixture.hpp"

namespace btfgmm {

// The size of one unit of each of the nine variables, in the variable's natural measure:
// pixels for x, y; radians for the onion-slice angles; the colour scale of the data for r,
// g, b. A variable in model units is its natural value divided by its unit.
struct VariableScaling {
  std::array<double, kVariables> unit{1, 1, 1, 1, 1, 1, 1, 1, 1};
};

// The angular sampling step of a direction set: the median over its directions of the
// angle to the nearest other direction, in radians (1 for a single direction).
double angular_sampling_step(const DirectionSet& set);

// The mean BRDF (docs/ALGORITHM.md, "The mean BRDF and the sample set"): for each (light, view),
// the mean RGB over the tile's pixels, light-major, ni * nv * 3 values.
std::vector<float> mean_brdf(const Btf& btf);

// The residual sample set (docs/ALGORITHM.md, "The mean BRDF and the sample set") without N x 9
// numbers: the colour of every (pixel, light, view), ordered pixel-major, then light, then
// view; x, y and the angles are implied by the indices and tabulated once. 8-bit data is held
// as its levels (3 bytes a sample) and its residual, level - mean BRDF, computed where it is
// used; other data as residuals in model units (12 bytes a sample).
struct SampleSet {
  int width = 0, height = 0;
  std::size_t lights = 0, views = 0;
  // A fit over several processes (core/communicator.hpp): each holds the samples of its share
  // of the lights (light_share), first_light .. light_end() - 1, and combines with the others
  // what it computes of them. Null: this process holds every light (held 0: all).
  std::shared_ptr<Communicator> processes;
  std::size_t first_light = 0, held = 0;
  VariableScaling scaling;
  std::vector<float> mean_brdf;                 // ni * nv * 3, in the data's scale
  std::vector<std::uint8_t> levels;             // 8-bit data: N * 3 levels (else empty)
  std::vector<float> residual;                  // other data: N * 3, model units
  float inv_colour_unit = 1.0f;                 // 1 / the colour unit, for `levels`
  std::vector<std::array<double, 2>> light_ab;  // (alpha, beta) per light, model units
  std::vector<std::array<double, 2>> view_ab;   // (alpha, beta) per view, model units

  std::size_t held_lights() const { return held ? held : lights; }
  std::size_t light_end() const { return first_light + held_lights(); }
  std::size_t pixels() const { return std::size_t(width) * height; }
  // All samples, of every process.
  std::size_t size() const { return pixels() * lights * views; }
  // The samples this process holds.
  std::size_t held_size() const { return pixels() * held_lights() * views; }
  // Where (pixel, light, view) is held (light: one of this process's).
  std::size_t index(std::size_t pixel, std::size_t light, std::size_t view) const {
    return (pixel * held_lights() + (light - first_light)) * views + view;
  }
  // The residual colour (model units) of (pixel, light, view), channel c.
  float residual_of(std::size_t pixel, std::size_t light, std::size_t view, int c) const {
    const std::size_t i = index(pixel, light, view) * 3 + std::size_t(c);
    if (levels.empty()) return residual[i];
    return (float(levels[i]) - mean_brdf[(light * views + view) * 3 + std::size_t(c)]) *
           inv_colour_unit;
  }
  // The residual colours of the views of one (pixel, light) block, into out (nv * 3).
  void block_residuals(std::size_t pixel, std::size_t light, float* out) const;
  // The nine variables of sample i (ordered pixel-major, then light, then view, over every
  // light), in model units; its light must be one this process holds.
  std::array<double, kVariables> sample(std::size_t i) const;
  // The same with its residual colour given.
  std::array<double, kVariables> sample(std::size_t i, const std::array<float, 3>& rgb) const;
  // Bytes held per sample (3 for 8-bit data, 12 for other data).
  std::size_t bytes_per_sample() const { return levels.empty() ? 12 : 3; }
};

// Builds the sample set of a BTF: mean BRDF, scaling, residuals. Throws Error(kFormat) on a
// non-finite value.
SampleSet make_sample_set(const Btf& btf);

// The sample set of a tile of `source` read image by image, never holding the tile as floats
// (8-bit data: 3 bytes a sample at most, beside what does not grow with the tile), the same
// as make_sample_set(source.load(tile)). *content_hash receives tile_content_hash of that
// tile (provenance.hpp). Throws as BtfSource::load and make_sample_set.
// With `processes`, each reads the images of its share of the lights (light_share), and
// the mean BRDF and the hash are of the whole tile on every process.
SampleSet read_sample_set(const BtfSource& source, const Tile& tile, std::uint64_t* content_hash,
                          std::shared_ptr<Communicator> processes = nullptr);

// The lights process `rank` of `size` holds: [first, last) of `lights`, in process order.
std::pair<std::size_t, std::size_t> light_share(std::size_t lights, int rank, int size);

// The residual colours of the samples `indices` (as SampleSet::sample numbers them), from the
// processes that hold them, on every process.
std::vector<std::array<float, 3>> gather_colours(const SampleSet& samples,
                                                 std::span<const std::size_t> indices);

// The first `count` (1 .. held_lights()) of the lights `samples` holds, as a sample set of
// their own on this process alone (EM's timing probe, estimate_em_iteration_seconds).
SampleSet first_lights(const SampleSet& samples, std::size_t count);

// Throws Error(kArgument) for no components, more components than samples, and EM's memory
// for `components` on `samples` beyond what this machine allows (limits::check_memory).
void check_em_size(const SampleSet& samples, std::size_t components);

// Random initialisation (seeded): means at M distinct random samples, variances the
// variance of each variable over the sample set divided by M^(1/3), equal weights. The same
// on every process of a distributed set.
ProductMixture initial_mixture(const SampleSet& samples, std::size_t components,
                               std::uint64_t seed);

}  // namespace btfgmm
