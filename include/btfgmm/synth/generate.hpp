// A synthetic BTF: a procedural rough material rendered for any direction sets.
//
// A periodic height field (so the whole image repeats without seams) with a spatially
// varying albedo, a glossy microfacet reflectance, self-shadowing toward the light and
// masking/parallax toward the viewer computed by marching rays through the height field.
// Deterministic from the seed (no std:: random distributions), whatever the thread count.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
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
  // Called as the work advances, `fraction` from 0 to 1 (1 last), `stage` naming the step
  // ("shadows", "images"); from one thread at a time, never concurrently. Must not throw.
  std::function<void(double fraction, std::string_view stage)> progress;
};

// A material generate() knows: its name and what it looks like.
struct MaterialInfo {
  std::string_view name;         // "corduroy"
  std::string_view description;  // "parallel ridges (wales) with grooves, red-brown"
};

// Every material, in the order help texts list them. The one list of the materials.
std::span<const MaterialInfo> materials();
// Their names, in that order.
std::vector<std::string> material_names();

// Throws Error(kArgument) for an unknown material (naming the nearest), an image size or a
// supersampling out of range: what generate() checks before any work.
void check_generate_config(const GenerateConfig& config);

// Throws as check_generate_config.
Btf generate(const GenerateConfig& config);

// The material's height field at the pixel centres (x + 1/2, y + 1/2), size*size values in
// pixel units, row-major, about the mean height (the reference plane): the relief generate()
// renders (what a range map estimated from its images is tested against). Lights, views and
// supersampling play no part. Throws as check_generate_config.
std::vector<float> generate_heights(const GenerateConfig& config);

}  // namespace btfgmm
