// The per-pixel set-up of the geometry pass (docs/RENDERING.md, "The geometry pass"): from a
// covered pixel's triangle and perspective-correct barycentric coordinates to its surface
// point, local frame, texture coordinate, and the light and view directions in that frame
// (internal: rasterize.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace btfgmm::detail {

// A direction or a point in float.
struct Float3 {
  float x = 0, y = 0, z = 0;
};

// The vertex attributes of the set-up, one float array each.
enum Attribute { kPx, kPy, kPz, kNx, kNy, kNz, kTx, kTy, kTz, kBx, kBy, kBz, kU, kV, kAttributes };

// The light: directional or a point.
struct SetUpLight {
  bool point = false;
  Float3 direction;  // toward a directional light
  Float3 position;   // a point light's position
  float intensity = 0;
};

// What the per-pixel set-up needs of the scene: the vertex attributes, each triangle's
// vertices and (unnormalised) face normal, the light, the eye and the tile.
struct SetUpScene {
  std::array<const float*, kAttributes> attr{};
  const std::uint32_t* corner = nullptr;  // 3 a triangle
  const float* face = nullptr;            // 3 a triangle
  SetUpLight light;
  Float3 eye;
  float texel = 0;       // tile pixels per unit of u and v
  float tw = 0, th = 0;  // the tile
};

// The set-up's results, a float array each: x, y, light (3), view (3), irradiance.
enum SetUpResult {
  kResX,
  kResY,
  kResL0,
  kResL1,
  kResL2,
  kResV0,
  kResV1,
  kResV2,
  kResIrr,
  kResults
};

// Sets up n covered pixels, given the triangle and the first two perspective-correct
// barycentric coordinates of each: the surface point, its frame, the texture coordinate, and
// the light and view directions in the frame (`res`); status `st` 1 in the dark, 2 lit. One
// loop over the pixels without calls or branches, vectorised (the vertex attributes gathered
// per lane).
void set_up_pixels(const SetUpScene& s, const std::int32_t* __restrict tri,
                   const float* __restrict b0, const float* __restrict b1, std::size_t n,
                   std::array<std::vector<float>, kResults>& res, std::uint8_t* __restrict st);

}  // namespace btfgmm::detail
