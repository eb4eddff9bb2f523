// Random numbers and periodic noise for the procedural materials of the synthetic BTF
// (internal). Every random number comes from splitmix64 (Steele, Lea & Flood 2014) seeded by
// the user's seed; the lattice values are stateless hashes, independent of evaluation order,
// so the generator gives the same result for any number of threads.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include "core/random.hpp"

namespace btfgmm::detail::synth {

inline constexpr double kPi = std::numbers::pi;

using detail::mix64;
// splitmix64: sequential random numbers (bump placement, per-wale jitter, phases).
using Rng = detail::SplitMix64;

// A stateless hash of integer lattice coordinates to [0, 1): the random values of the noise
// lattices and of per-cell jitter, independent of evaluation order.
inline double hash01(std::uint64_t key, std::int64_t i, std::int64_t j, std::uint64_t salt = 0) {
  std::uint64_t z = mix64(key ^ (std::uint64_t(i) * 0x9E3779B97F4A7C15ULL));
  z = mix64(z ^ (std::uint64_t(j) * 0xC2B2AE3D27D4EB4FULL) ^ salt);
  return double(z >> 11) * 0x1.0p-53;
}

// The key of one noise field or jitter table of a material: derived from the user's seed.
inline std::uint64_t sub_key(std::uint64_t seed, std::uint64_t what) {
  return mix64(mix64(seed + 0x632BE59BD9B4E019ULL) ^ mix64(what));
}

// i modulo n in [0, n): the index of a periodic lattice or grid.
inline int wrap_index(std::int64_t i, int n) {
  const auto r = int(i % n);
  return r < 0 ? r + n : r;
}

// How many repeats of a pattern with the target period fit across `size` pixels: the period
// actually used is size / repeats, so the pattern tiles the image exactly.
inline int repeats(int size, double target_period) {
  return std::max(1, int(std::lround(double(size) / target_period)));
}

inline double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

// Periodic value noise (Perlin 1985 style lattice noise, quintic fade): a lattice of
// cells_x x cells_y random values in [-1, 1] spread over size x size pixels with wrap, so the
// noise tiles the image.
class TileNoise {
 public:
  TileNoise(std::uint64_t key, int size, int cells_x, int cells_y)
      : key_(key),
        cx_(std::max(1, cells_x)),
        cy_(std::max(1, cells_y)),
        sx_(double(cx_) / size),
        sy_(double(cy_) / size) {}

  double operator()(double x, double y) const {
    const double gx = x * sx_, gy = y * sy_;
    const double fx0 = std::floor(gx), fy0 = std::floor(gy);
    const double tx = fade(gx - fx0), ty = fade(gy - fy0);
    const auto ix = std::int64_t(fx0), iy = std::int64_t(fy0);
    const int x0 = wrap_index(ix, cx_), x1 = wrap_index(ix + 1, cx_);
    const int y0 = wrap_index(iy, cy_), y1 = wrap_index(iy + 1, cy_);
    const double v00 = value(x0, y0), v10 = value(x1, y0);
    const double v01 = value(x0, y1), v11 = value(x1, y1);
    const double a = v00 + (v10 - v00) * tx, b = v01 + (v11 - v01) * tx;
    return a + (b - a) * ty;
  }

 private:
  static double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
  double value(int i, int j) const { return 2.0 * hash01(key_, i, j) - 1.0; }

  std::uint64_t key_;
  int cx_, cy_;
  double sx_, sy_;
};

}  // namespace btfgmm::detail::synth
