// FastDirectionInterpolator: DirectionInterpolator's barycentric weights through a grid over
// the disk of projected directions and a hint of the last triangle, instead of a scan over
// every triangle (docs/RENDERING.md).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "btfgmm/core/fast_interpolation.hpp"
#include "btfgmm/core/interpolation.hpp"

#include "core/barycentric.hpp"

namespace btfgmm {

FastDirectionInterpolator::FastDirectionInterpolator(const DirectionSet& set) : slow_(set) {
  for (const Direction& d : set) {
    const Vec3 v = to_vector(d);
    points_.push_back({v.x, v.y});
  }
  triangles_ = slow_.triangles();
  // The boundary edges, in DirectionInterpolator's order (so that ties resolve alike).
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> count;
  for (const auto& t : triangles_)
    for (int e = 0; e < 3; ++e)
      count[{std::min(t[std::size_t(e)], t[std::size_t(e + 1) % 3]),
             std::max(t[std::size_t(e)], t[std::size_t(e + 1) % 3])}]++;
  for (const auto& [edge, n] : count)
    if (n == 1) hull_edges_.push_back({edge.first, edge.second});
  if (triangles_.empty()) return;  // the slow path handles degenerate sets
  grid_ = std::clamp(int(std::sqrt(double(triangles_.size()))) * 2, 4, 256);
  const std::size_t cells = std::size_t(grid_) * std::size_t(grid_);
  std::vector<std::vector<std::uint32_t>> lists(cells);
  const double margin = 1e-9;
  for (std::uint32_t t = 0; t < triangles_.size(); ++t) {
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (std::uint32_t i : triangles_[t]) {
      x0 = std::min(x0, points_[i][0]);
      x1 = std::max(x1, points_[i][0]);
      y0 = std::min(y0, points_[i][1]);
      y1 = std::max(y1, points_[i][1]);
    }
    auto cell = [&](double v) {
      return std::clamp(int(std::floor((v + 1.0) * 0.5 * grid_)), 0, grid_ - 1);
    };
    for (int cy = cell(y0 - margin); cy <= cell(y1 + margin); ++cy)
      for (int cx = cell(x0 - margin); cx <= cell(x1 + margin); ++cx)
        lists[std::size_t(cy) * std::size_t(grid_) + std::size_t(cx)].push_back(t);
  }
  cell_start_.push_back(0);
  for (const auto& l : lists) {
    cell_triangles_.insert(cell_triangles_.end(), l.begin(), l.end());
    cell_start_.push_back(std::uint32_t(cell_triangles_.size()));
  }
}

DirectionInterpolator::Weights FastDirectionInterpolator::weights(const Vec3& v) const {
  std::uint32_t hint = std::numeric_limits<std::uint32_t>::max();
  return weights(v, hint);
}

DirectionInterpolator::Weights FastDirectionInterpolator::weights(const Vec3& v,
                                                                  std::uint32_t& hint) const {
  if (triangles_.empty()) return slow_.weights(v);
  // As DirectionInterpolator: below the horizon, the horizon direction with the same azimuth.
  const double n = std::sqrt(v.x * v.x + v.y * v.y + std::max(v.z, 0.0) * std::max(v.z, 0.0));
  if (!(n > 0.0) || !std::isfinite(n)) return weights_at(0.0, 0.0, &hint);
  return weights_at(v.x / n, v.y / n, &hint);
}

// The arithmetic of DirectionInterpolator::weights_at (core/barycentric.hpp: the same
// weights, bit for bit, as the test asserts) over the triangles near the query (every
// triangle that could contain it). A query well
// inside the hinted triangle (every barycentric weight above 1e-4) lies in no other
// triangle: that triangle is the one the scan would find.
DirectionInterpolator::Weights FastDirectionInterpolator::weights_at(double qx, double qy,
                                                                     std::uint32_t* hint) const {
  DirectionInterpolator::Weights best;
  double best_min = -std::numeric_limits<double>::infinity();
  std::uint32_t best_tri = std::numeric_limits<std::uint32_t>::max();
  const auto try_triangle = [&](std::uint32_t ti) {
    const auto& t = triangles_[ti];
    const auto w = detail::barycentric(points_[t[0]], points_[t[1]], points_[t[2]], qx, qy);
    const double m = std::min({w[0], w[1], w[2]});
    if (m > best_min) {
      best_min = m;
      best_tri = ti;
      best.index = t;
      best.weight = w;
    }
  };
  if (hint && *hint < triangles_.size()) try_triangle(*hint);
  if (!(best_min > 1e-4)) {
    best_min = -std::numeric_limits<double>::infinity();
    best_tri = std::numeric_limits<std::uint32_t>::max();
    const int cx = std::clamp(int(std::floor((qx + 1.0) * 0.5 * grid_)), 0, grid_ - 1);
    const int cy = std::clamp(int(std::floor((qy + 1.0) * 0.5 * grid_)), 0, grid_ - 1);
    const std::size_t cell = std::size_t(cy) * std::size_t(grid_) + std::size_t(cx);
    for (std::uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k)
      try_triangle(cell_triangles_[k]);
  }
  if (hint) *hint = best_tri;
  if (best_min < -1e-12) {
    if (hint) *hint = std::numeric_limits<std::uint32_t>::max();
    detail::nearest_on_boundary(
        hull_edges_, [&](std::uint32_t i) -> const std::array<double, 2>& { return points_[i]; },
        qx, qy, best);
  }
  detail::normalise_weights(best);
  return best;
}

}  // namespace btfgmm
