// The arithmetic of interpolation over measured directions (docs/ALGORITHM.md, "Interpolating
// over measured directions"), shared by DirectionInterpolator (the scan over every triangle)
// and FastDirectionInterpolator (the triangles near the query), which give the same weights
// bit for bit (tests/test_render.cpp asserts it).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "btfgmm/core/interpolation.hpp"

namespace btfgmm::detail {

// p q - r s with one rounding of p q (a fused multiply-add): written out, so that the result
// does not depend on where the compiler chooses to contract products into FMAs (which it did
// differently in the two interpolators' loops).
inline double cross_difference(double p, double q, double r, double s) {
  return std::fma(p, q, -(r * s));
}

// Barycentric coordinates of q = (qx, qy) in the triangle (a, b, c), each point an (x, y).
inline std::array<double, 3> barycentric(const std::array<double, 2>& a,
                                         const std::array<double, 2>& b,
                                         const std::array<double, 2>& c, double qx, double qy) {
  const double area = cross_difference(b[0] - a[0], c[1] - a[1], b[1] - a[1], c[0] - a[0]);
  const double wa = cross_difference(b[0] - qx, c[1] - qy, b[1] - qy, c[0] - qx) / area;
  const double wb = cross_difference(c[0] - qx, a[1] - qy, c[1] - qy, a[0] - qx) / area;
  return {wa, wb, 1.0 - wa - wb};
}

// Outside the triangulation: the weights of the nearest point on its boundary edges (two
// weights along the edge). `point(i)` gives point i as an (x, y).
template <class PointOf>
inline void nearest_on_boundary(const std::vector<std::array<std::uint32_t, 2>>& edges,
                                const PointOf& point, double qx, double qy,
                                DirectionInterpolator::Weights& best) {
  double best_d = std::numeric_limits<double>::infinity();
  for (const auto& e : edges) {
    const auto &a = point(e[0]), &b = point(e[1]);
    const double dx = b[0] - a[0], dy = b[1] - a[1], len2 = dx * dx + dy * dy;
    double s = len2 > 0.0 ? ((qx - a[0]) * dx + (qy - a[1]) * dy) / len2 : 0.0;
    s = std::clamp(s, 0.0, 1.0);
    const double px = a[0] + s * dx - qx, py = a[1] + s * dy - qy;
    const double d2 = px * px + py * py;
    if (d2 < best_d) {
      best_d = d2;
      best.index = {e[0], e[1], e[0]};
      best.weight = {1.0 - s, s, 0.0};
    }
  }
}

// Non-negative, summing to one; a measured direction gets exactly weight 1 on itself.
inline void normalise_weights(DirectionInterpolator::Weights& best) {
  double sum = 0.0;
  for (double& w : best.weight) sum += (w = std::max(w, 0.0));
  for (double& w : best.weight) w /= sum;
  for (std::size_t i = 0; i < 3; ++i)
    if (best.weight[i] > 1.0 - 1e-12) {
      best.weight = {0.0, 0.0, 0.0};
      best.weight[i] = 1.0;
    }
}

}  // namespace btfgmm::detail
