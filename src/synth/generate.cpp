// A synthetic BTF: a procedural rough material rendered for any light and view direction sets
// (include/btfgmm/synth/generate.hpp). It is the built-in example and the test data of the project,
// so it reproduces what a measured BTF (Dana et al. 1999; Bonn UBO2003, UTIA) shows: images
// that change with light and view through shadows, highlights, masking and parallax.
//
// The pipeline, step by step:
//  1. A periodic height field h(x, y) in pixel units (the whole image repeats seamlessly), a
//     spatially varying albedo and a specular weight, evaluated procedurally on a grid finer
//     than the pixels (f grid points per pixel side) and sampled bilinearly with wrap.
//  2. Normals from the height-field gradient (central differences) and an ambient
//     accessibility term from horizon angles (horizon-based ambient occlusion; Max 1988,
//     "Horizon mapping"; Bavoil et al. 2008).
//  3. Self-shadowing: for every light, a visibility map made by marching from the surface
//     toward the light through the height field (Max 1988; the soft-shadow variant takes the
//     smallest clearance angle along the ray, approximating an area light of a few degrees).
//  4. Masking and parallax: every camera ray p(t) = (x, y, 0) + t v through a pixel of the
//     reference plane z = 0 (a rectified BTF image) is marched from the top of the height
//     field down to its bottom; the first point below the surface, refined by bisection, is
//     the point seen (relief mapping, Policarpo et al. 2005).
//  5. Reflectance: Lambert diffuse plus a GGX microfacet lobe (Walter et al. 2007) with the
//     Smith-Schlick masking term and Schlick's Fresnel, times the clamped cosine n.l
//     (foreshortening of the incident light) and the visibility; a small ambient term lets
//     shadowed parts stay slightly visible.
//  6. Supersampling: config.supersample^2 stratified rays per pixel, averaged in linear
//     radiance; then an sRGB encode to 8-bit levels (LDR), or the linear radiance (HDR).
//
// Coordinates: x is the image column, y the image row, z points out of the surface toward the
// viewer; a direction's azimuth phi is measured from +x toward +y (to_vector()), so a light at
// phi = 0 shines from the right-hand side (larger x) of the image.
//
// Determinism: every random number comes from splitmix64 (Steele, Lea & Flood 2014) seeded by
// config.seed, and every output value is computed by one thread from inputs that do not depend
// on the schedule, so the result is the same for any number of OpenMP threads.
//
// Where the steps live: the materials (step 1) in materials.cpp, the surface grid, normals and
// accessibility (steps 1 and 2) in surface.cpp, shadows, camera rays and reflectance (steps 3
// to 5) in shading.cpp; the supersampling and the quantisation (step 6) here.
#include "btfgmm/synth/generate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/error.hpp"
#include "synth/materials.hpp"
#include "synth/shading.hpp"
#include "synth/surface.hpp"

namespace btfgmm {
namespace {

namespace synth = detail::synth;

// The unit vectors of a direction set.
std::vector<Vec3> direction_vectors(const DirectionSet& dirs) {
  std::vector<Vec3> out(dirs.size());
  for (std::size_t i = 0; i < dirs.size(); ++i) out[i] = to_vector(dirs[i]);
  return out;
}

// Linear -> 8-bit sRGB levels (IEC 61966-2-1), rounded: level k is the number of decision
// thresholds (the linear values of the level midpoints) at or below x. A table over 4096 bins
// of [0, 1] gives the lowest level of a bin; at most a few thresholds lie inside one bin.
class SrgbEncoder {
 public:
  SrgbEncoder() {
    for (int k = 0; k < 255; ++k) {
      const double e = (k + 0.5) / 255.0;
      const double lin = e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
      thresholds_[std::size_t(k)] = float(lin);
    }
    thresholds_[255] = std::numeric_limits<float>::infinity();
    for (std::size_t b = 0; b < kBins; ++b) {
      const float lo = float(b) / float(kBins);
      start_[b] = std::uint8_t(std::upper_bound(thresholds_.begin(), thresholds_.end() - 1, lo) -
                               thresholds_.begin());
    }
  }
  float operator()(float x) const {
    if (!(x > 0.0f)) return 0.0f;
    if (x >= 1.0f) return 255.0f;
    std::size_t bin = std::min(std::size_t(x * float(kBins)), kBins - 1);
    // The bin's lower edge is <= x; guard the float rounding of x * kBins.
    while (bin > 0 && float(bin) / float(kBins) > x) --bin;
    unsigned level = start_[bin];
    while (thresholds_[level] <= x) ++level;
    return float(level);
  }

 private:
  static constexpr std::size_t kBins = 4096;
  std::array<float, 256> thresholds_{};
  std::array<std::uint8_t, kBins> start_{};
};

// 6. The average of each pixel's rays in linear radiance, times the exposure: the linear
// radiance (HDR) or its sRGB levels (LDR), for `pixels` pixels from `out` on.
void average_pixels(const synth::ViewRays& rays, std::size_t pixels, std::size_t rays_per_pixel,
                    bool hdr, const SrgbEncoder& encode, float* out) {
  const float norm = synth::kExposure / float(rays_per_pixel);
  for (std::size_t p = 0; p < pixels; ++p) {
    float acc_r = 0.0f, acc_g = 0.0f, acc_b = 0.0f;
    for (std::size_t q = p * rays_per_pixel; q < (p + 1) * rays_per_pixel; ++q) {
      acc_r += rays.red[q];
      acc_g += rays.green[q];
      acc_b += rays.blue[q];
    }
    const float rgb[3] = {acc_r * norm, acc_g * norm, acc_b * norm};
    for (std::size_t c = 0; c < 3; ++c) out[3 * p + c] = hdr ? rgb[c] : encode(rgb[c]);
  }
}

}  // namespace

void check_generate_config(const GenerateConfig& config) {
  synth::check_material(config.material);
  if (config.size < 4 || config.size > 8192)
    throw Error(Error::Kind::kArgument,
                fmt::format("generated image size {} is out of range; give a size from 4 to "
                            "8192 pixels",
                            config.size));
  if (config.supersample < 1 || config.supersample > 8)
    throw Error(Error::Kind::kArgument,
                fmt::format("supersample {} is out of range; give 1 to 8 rays per pixel side",
                            config.supersample));
}

Btf generate(const GenerateConfig& config) {
  check_generate_config(config);
  const int size = config.size;
  Btf btf(config.lights, config.views, size, size,
          config.hdr ? SampleFormat::kHdr : SampleFormat::kLdr8);
  btf.set_origin({.x = 0, .y = 0, .width = size, .height = size});

  // Steps 1 and 2: the material on its grid, with normals and accessibility.
  const synth::MaterialModel model = synth::material_model(config.material, size, config.seed);
  const synth::Surface surf = synth::build_surface(model, size);

  // Per-light visibility maps (step 3), at up to 2 points per pixel side.
  const int fs = std::min(surf.f, 2);
  const std::vector<Vec3> lvec = direction_vectors(btf.lights());
  const std::vector<Vec3> vvec = direction_vectors(btf.views());
  const std::vector<std::vector<float>> shadows = synth::visibility_maps(surf, lvec, fs);
  const synth::Reflectance refl = synth::reflectance(surf);

  const int ss = config.supersample;
  const std::size_t rays_per_pixel = std::size_t(ss) * std::size_t(ss);
  const SrgbEncoder encode;

  // Work in tasks of (view, band of rows): a band's rays are traced once and serve every
  // light; bands keep the memory bounded for large images.
  const int band_rows = std::clamp(int(65536 / (std::size_t(size) * rays_per_pixel)), 1, size);
  const int bands = (size + band_rows - 1) / band_rows;
  const std::size_t nl = lvec.size(), nv = vvec.size();
  const std::size_t tasks = nv * std::size_t(bands);
  std::size_t done = 0;

#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t task = 0; task < std::ptrdiff_t(tasks); ++task) {
    const auto vi = std::size_t(task / bands);
    const int y0 = int(task % bands) * band_rows, y1 = std::min(size, y0 + band_rows);
    const Vec3 v = vvec[vi];
    const std::size_t pixels = std::size_t(y1 - y0) * std::size_t(size);
    // Steps 4 and 6: trace the band's rays once; the hits serve every light.
    synth::ViewRays rays(pixels * rays_per_pixel);
    synth::trace_band(surf, refl, v, y0, y1, ss, fs, rays);
    for (std::size_t li = 0; li < nl; ++li) {
      // Step 5 for every ray, then step 6 for every pixel.
      synth::shade_rays(refl, lvec[li], v, shadows[li].data(), pixels * rays_per_pixel, rays);
      average_pixels(rays, pixels, rays_per_pixel, config.hdr, encode,
                     btf.image(li, vi) + std::size_t(y0) * std::size_t(size) * 3);
    }
    if (config.progress) {
#pragma omp critical(btfgmm_generate_progress)
      config.progress(double(++done) / double(tasks), "images");
    }
  }
  return btf;
}

std::vector<float> generate_heights(const GenerateConfig& config) {
  check_generate_config(config);
  const int size = config.size;
  const synth::MaterialModel model = synth::material_model(config.material, size, config.seed);
  const synth::Surface surf = synth::build_surface(model, size);
  std::vector<float> out(std::size_t(size) * std::size_t(size));
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      out[std::size_t(y) * std::size_t(size) + std::size_t(x)] = surf.h(x + 0.5, y + 0.5);
  return out;
}

}  // namespace btfgmm
