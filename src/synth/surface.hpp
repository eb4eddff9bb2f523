// The surface of the synthetic BTF (internal): a material evaluated on a periodic grid finer
// than the pixels, with the maps derived from it (normals, ambient accessibility), and the
// bilinear sampling of those grids with wrap (steps 1 and 2 of the pipeline in generate.cpp).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "synth/materials.hpp"
#include "synth/noise.hpp"

namespace btfgmm::detail::synth {

// A bilinear sampling position on a periodic grid of n x n points, grid point (i, j) at
// pixel coordinates (i / f, j / f).
struct Lerp {
  std::uint32_t i00, i10, i01, i11;
  float wx, wy;
  template <class T>
  float operator()(const T* g) const {
    const float a = float(g[i00]) + (float(g[i10]) - float(g[i00])) * wx;
    const float b = float(g[i01]) + (float(g[i11]) - float(g[i01])) * wx;
    return a + (b - a) * wy;
  }
  // The same for a grid of interleaved triples (normals, albedo).
  std::array<float, 3> rgb(const float* g) const {
    std::array<float, 3> out{};
    for (std::size_t c = 0; c < 3; ++c) {
      const float a = g[3 * i00 + c] + (g[3 * i10 + c] - g[3 * i00 + c]) * wx;
      const float b = g[3 * i01 + c] + (g[3 * i11 + c] - g[3 * i01 + c]) * wx;
      out[c] = a + (b - a) * wy;
    }
    return out;
  }
};

// Where (x, y), in pixels, falls on the periodic grid of n x n points, f per pixel side.
inline Lerp locate(double x, double y, int n, double f) {
  const double gx = x * f, gy = y * f;
  const double fx = std::floor(gx), fy = std::floor(gy);
  const int x0 = wrap_index(std::int64_t(fx), n), y0 = wrap_index(std::int64_t(fy), n);
  const int x1 = x0 + 1 == n ? 0 : x0 + 1, y1 = y0 + 1 == n ? 0 : y0 + 1;
  const auto un = std::uint32_t(n);
  return {std::uint32_t(y0) * un + std::uint32_t(x0),
          std::uint32_t(y0) * un + std::uint32_t(x1),
          std::uint32_t(y1) * un + std::uint32_t(x0),
          std::uint32_t(y1) * un + std::uint32_t(x1),
          float(gx - fx),
          float(gy - fy)};
}

// The material evaluated on the fine periodic grid, with its derived maps.
struct Surface {
  int size = 0;  // image side, pixels
  int f = 1;     // grid points per pixel side
  int n = 0;     // grid points per side (f * size)
  std::vector<float> height, albedo, gloss, normal, access;
  float h_min = 0.0f, h_max = 0.0f;
  double roughness = 0.5;
  Rgb f0;

  float h(double x, double y) const { return locate(x, y, n, f)(height.data()); }
};

// Evaluates the material on a grid of f x f points per pixel (f = 4 up to 256 pixels, 2 up
// to 512, else 1) and derives the normals and the ambient accessibility.
Surface build_surface(const MaterialModel& m, int size);

}  // namespace btfgmm::detail::synth
