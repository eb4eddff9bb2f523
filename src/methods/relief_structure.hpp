// The part of a subspace image that the tile's relief explains, kept as it is rather than
// synthesised (internal; docs/METHODS.md, "The relief's structure"). A Gaussian field, CAR or
// GMRF, draws the phases of its frequencies at random, so a regular texture's motif (knit's
// V-shaped stitches, corduroy's wales) cannot survive its synthesis; the range map holds that
// motif, deterministic and tiling. Each channel of a subspace's representative image is fitted
// by least squares to features of the range map at each pixel: the relief's shape (height,
// squared slopes and their product, curvature), the same under any light, and its slope
// along the light (-(hx lx + hy ly): the first-order change of n.l, which turns with the
// light's azimuth). This is Haindl & Filip's range map as a bump filter with its gains
// learnt. The texture model learns what is left; a synthesis adds the shape back, and each
// image the slope along its own light, the range map repeating.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "btfgmm/core/directions.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

// Gains a channel: 1, h, hx^2, hy^2, hx hy, the Laplacian of h (the shape), then the slope
// along the light (central differences on the torus).
constexpr int kReliefShapeFeatures = 6;
constexpr int kReliefFeatures = kReliefShapeFeatures + 1;

// A subspace's gains, channel-major: gain[c * kReliefFeatures + j] of feature j in channel c.
struct ReliefStructure {
  std::array<float, 3 * kReliefFeatures> gain{};
};

// A w x h range map's features at each pixel: the shape's, then hx and hy.
struct ReliefFeatures {
  static constexpr int kPerPixel = kReliefShapeFeatures + 2;
  int width = 0, height = 0;
  std::vector<double> values;  // pixel-major, kPerPixel each
};
ReliefFeatures relief_features(std::span<const float> heights, int w, int h);

// The least-squares gains of `rgb` (pixels RGB values, the features' size) lit from `light`.
ReliefStructure fit_relief_structure(const ReliefFeatures& f, const Vec3& light, const double* rgb);

// Adds `sign` times the relief's shape to a width x height RGB field, the features repeating.
void add_relief_shape(const ReliefStructure& s, const ReliefFeatures& f, double* rgb, int width,
                      int height, double sign = 1.0);
// Adds `sign` times the slope along `light` to a width x height RGB field, likewise.
template <typename T>
void add_relief_slope(const ReliefStructure& s, const ReliefFeatures& f, const Vec3& light, T* rgb,
                      int width, int height, double sign = 1.0);

// The same at one pixel (x, y) of any size, its RGB at `rgb`.
void add_relief_slope_at(const ReliefStructure& s, const ReliefFeatures& f, const Vec3& light,
                         long long x, long long y, float* rgb);

// f32 gains; get: r.fail() on a value that is not finite.
void put_relief_structure(ByteWriter& w, const ReliefStructure& s);
ReliefStructure get_relief_structure(ByteReader& r);

}  // namespace btfgmm::detail
