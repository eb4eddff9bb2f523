// A synthetic BTF: a procedural rough material rendered for any direction sets.
//
// A periodic height field (so the whole image repeats without seams) with a spatially
// varying albedo, a glossy microfacet reflectance, self-shadowing toward the light and
// masking/parallax toward the viewer computed by marching rays through the height field.
// Deterministic from the seed (no std:: random distributions), whatever the thread count.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"

namespace btfgmm {

struct GenerateConfig {
  std::string material = "corduroy";  // one of material_names()
  int size = 32;                      // width = height, pixels
  std::uint64_t seed = 1;
  DirectionSet lights = DirectionSet::ubo81();
  DirectionSet views = DirectionSet::ubo81();
  bool hdr = false;     // float output (for EXR) instead of 8-bit levels
  int supersample = 2;  // rays per pixel side
};

// The materials generate() knows, e.g. "corduroy", "knit", "bumps".
std::vector<std::string> material_names();

// Throws Error(kArgument) for an unknown material or a nonsense size.
Btf generate(const GenerateConfig& config);

}  // namespace btfgmm
