// Interpolation weights over a measured direction set: barycentric coordinates in a Delaunay
// triangulation of the directions projected onto the unit disk (docs/ALGORITHM.md).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>

#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/error.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "core/barycentric.hpp"

namespace btfgmm {
namespace {

using Tri = std::array<std::uint32_t, 3>;

struct Pt {
  double x, y;
};

double orient(const Pt& a, const Pt& b, const Pt& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// > 0 when d lies inside the circumcircle of the counter-clockwise triangle (a, b, c).
double in_circle(const Pt& a, const Pt& b, const Pt& c, const Pt& d) {
  const double ax = a.x - d.x, ay = a.y - d.y, bx = b.x - d.x, by = b.y - d.y;
  const double cx = c.x - d.x, cy = c.y - d.y;
  const double a2 = ax * ax + ay * ay, b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
  return ax * (by * c2 - b2 * cy) - ay * (bx * c2 - b2 * cx) + a2 * (bx * cy - by * cx);
}

// A small deterministic offset per point: measured sets are full of co-circular points (every
// ring), for which the Delaunay test is undecided. Perturbing the points used for the
// triangulation (never for the weights) by ~1e-7 decides every such tie consistently.
Pt jitter(const Pt& p, std::uint32_t i) {
  std::uint64_t h = (std::uint64_t(i) + 1) * 0x9E3779B97F4A7C15ull;
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  const double u = double(h & 0xFFFFF) / double(0xFFFFF) - 0.5;
  const double v = double((h >> 20) & 0xFFFFF) / double(0xFFFFF) - 0.5;
  return {p.x + 2e-7 * u, p.y + 2e-7 * v};
}

// Bowyer-Watson insertion inside a large super-triangle; triangles touching the
// super-triangle are dropped at the end.
std::vector<Tri> delaunay(const std::vector<Pt>& pts, const std::vector<std::uint32_t>& use) {
  std::vector<Pt> p;
  p.reserve(use.size() + 3);
  for (std::uint32_t i : use) p.push_back(jitter(pts[i], i));
  const std::uint32_t s = std::uint32_t(p.size());
  p.push_back({-60.0, -40.0});
  p.push_back({60.0, -40.0});
  p.push_back({0.0, 70.0});
  std::vector<Tri> tris{{s, s + 1, s + 2}};
  for (std::uint32_t k = 0; k < s; ++k) {
    std::vector<Tri> keep;
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
    for (const Tri& t : tris) {
      if (in_circle(p[t[0]], p[t[1]], p[t[2]], p[k]) > 0.0) {
        for (int e = 0; e < 3; ++e) {
          std::uint32_t a = t[e], b = t[(e + 1) % 3];
          edges[{std::min(a, b), std::max(a, b)}]++;
        }
      } else {
        keep.push_back(t);
      }
    }
    // The cavity's boundary: edges of removed triangles that only one of them has.
    for (const Tri& t : tris) {
      if (!(in_circle(p[t[0]], p[t[1]], p[t[2]], p[k]) > 0.0)) continue;
      for (int e = 0; e < 3; ++e) {
        std::uint32_t a = t[e], b = t[(e + 1) % 3];
        if (edges[{std::min(a, b), std::max(a, b)}] == 1) {
          Tri n{a, b, k};
          if (orient(p[a], p[b], p[k]) < 0) std::swap(n[0], n[1]);
          keep.push_back(n);
        }
      }
    }
    tris.swap(keep);
  }
  std::vector<Tri> out;
  for (const Tri& t : tris) {
    if (t[0] >= s || t[1] >= s || t[2] >= s) continue;
    // Back to the caller's indices.
    Tri r{use[t[0]], use[t[1]], use[t[2]]};
    if (orient(pts[r[0]], pts[r[1]], pts[r[2]]) == 0.0) continue;  // a sliver of collinear
    out.push_back(r);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

DirectionInterpolator::DirectionInterpolator(const DirectionSet& set) {
  if (set.empty())
    throw Error(Error::Kind::kArgument, "cannot interpolate over an empty direction set");
  if (set.size() > std::size_t(std::numeric_limits<std::uint32_t>::max() / 2))
    throw Error(Error::Kind::kArgument, "direction set too large to interpolate over");
  for (const Direction& d : set) {
    const Vec3 v = to_vector(d);
    points_.push_back({v.x, v.y});
  }
  // Measured directions that project onto the same point (e.g. theta = 0 with two phis) are
  // one vertex: the first one.
  std::vector<std::uint32_t> use;
  for (std::uint32_t i = 0; i < points_.size(); ++i) {
    bool dup = false;
    for (std::uint32_t j : use)
      dup = dup || std::hypot(points_[i][0] - points_[j][0], points_[i][1] - points_[j][1]) < 1e-12;
    if (!dup) use.push_back(i);
  }
  std::vector<Pt> pts(points_.size());
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = {points_[i][0], points_[i][1]};
  if (use.size() >= 3) triangles_ = delaunay(pts, use);

  // Boundary of the triangulation: edges that one triangle only has.
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> count;
  for (const Tri& t : triangles_)
    for (int e = 0; e < 3; ++e)
      count[{std::min(t[e], t[(e + 1) % 3]), std::max(t[e], t[(e + 1) % 3])}]++;
  for (const auto& [edge, n] : count)
    if (n == 1) hull_edges_.push_back({edge.first, edge.second});
  // Without a triangle (fewer than three distinct or all collinear points), every pair of
  // distinct points is a segment to project onto.
  if (triangles_.empty())
    for (std::size_t a = 0; a < use.size(); ++a)
      for (std::size_t b = a + 1; b < use.size(); ++b) hull_edges_.push_back({use[a], use[b]});
  if (hull_edges_.empty()) hull_edges_.push_back({use[0], use[0]});
}

DirectionInterpolator::Weights DirectionInterpolator::weights(const Direction& d) const {
  return weights(to_vector(d));
}

DirectionInterpolator::Weights DirectionInterpolator::weights(const Vec3& v) const {
  // Below the horizon, use the horizon direction with the same azimuth.
  const double n = std::sqrt(v.x * v.x + v.y * v.y + std::max(v.z, 0.0) * std::max(v.z, 0.0));
  if (!(n > 0.0) || !std::isfinite(n)) return weights_at({0.0, 0.0});
  return weights_at({v.x / n, v.y / n});
}

DirectionInterpolator::Weights DirectionInterpolator::weights_at(P2 q) const {
  Weights best;
  double best_min = -std::numeric_limits<double>::infinity();
  for (const Tri& t : triangles_) {
    const auto w = detail::barycentric(points_[t[0]], points_[t[1]], points_[t[2]], q[0], q[1]);
    const double m = std::min({w[0], w[1], w[2]});
    if (m > best_min) {
      best_min = m;
      best.index = t;
      best.weight = w;
    }
  }
  if (best_min < -1e-12)
    detail::nearest_on_boundary(
        hull_edges_, [&](std::uint32_t i) -> const P2& { return points_[i]; }, q[0], q[1], best);
  detail::normalise_weights(best);
  return best;
}

}  // namespace btfgmm
