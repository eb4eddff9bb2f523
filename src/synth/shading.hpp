// Light transport of the synthetic BTF (internal): self-shadowing and masking by marching
// rays through the height field, and the microfacet reflectance of the points the camera rays
// see (steps 3 to 5 of the pipeline in generate.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "btfgmm/core/directions.hpp"
#include "synth/surface.hpp"

namespace btfgmm::detail::synth {

// The incident light has irradiance pi at normal incidence, so a white Lambertian surface
// lit and seen frontally has radiance 1.
inline constexpr float kAmbient = 0.08f;   // ambient light relative to the direct light
inline constexpr float kExposure = 1.25f;  // frontal images mid-bright, highlights may clip

// The reflectance constants of the surface (step 5): GGX roughness alpha^2, the Smith-Schlick
// k and the specular reflectance at normal incidence.
struct Reflectance {
  float alpha2 = 0.0f;
  float k_smith = 0.0f;  // Smith-Schlick G1 with k = alpha / 2 (Karis 2013)
  std::array<float, 3> f0{};
};

Reflectance reflectance(const Surface& s);

// 3. The visibility map of every light: fs * size values per side, row-major.
std::vector<std::vector<float>> visibility_maps(const Surface& s, const std::vector<Vec3>& lights,
                                                int fs);

// What the camera rays of one view see, kept for all lights (structure of arrays, so that the
// per-light shading loop vectorises).
struct ViewRays {
  explicit ViewRays(std::size_t n)
      : nx(n),
        ny(n),
        nz(n),
        r(n),
        g(n),
        b(n),
        ambient(n),
        spec_view(n),
        wx(n),
        wy(n),
        i00(n),
        i10(n),
        i01(n),
        i11(n),
        red(n),
        green(n),
        blue(n) {}
  std::vector<float> nx, ny, nz;  // shading normal
  std::vector<float> r, g, b;     // albedo
  std::vector<float> ambient;     // ambient weight (accessibility * ambient light)
  std::vector<float> spec_view;   // gloss * G1(v) / (4 n.v): the view-only part of the lobe
  std::vector<float> wx, wy;      // where to read a light's visibility map (bilinear)
  std::vector<std::uint32_t> i00, i10, i01, i11;
  std::vector<float> red, green, blue;  // radiance of each ray for the current light
};

// Steps 4 and 6: traces the rays of view v through the pixels of rows [y0, y1), ss x ss
// stratified rays per pixel (pixel-major, then row and column of the ray), and keeps what
// each ray sees; fs is the visibility maps' points per pixel side.
void trace_band(const Surface& s, const Reflectance& refl, const Vec3& v, int y0, int y1, int ss,
                int fs, ViewRays& rays);

// Step 5: the radiance of the first `count` rays of view v for light l, whose visibility map
// is vis_map, into rays.red, rays.green and rays.blue.
void shade_rays(const Reflectance& refl, const Vec3& l, const Vec3& v, const float* vis_map,
                std::size_t count, ViewRays& rays);

}  // namespace btfgmm::detail::synth
