// Interpolation over a measured direction set: barycentric weights of any direction.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "btfgmm/core/directions.hpp"

namespace btfgmm {

// Interpolation weights of an arbitrary direction over a measured set: barycentric
// coordinates in a Delaunay triangulation of the directions projected onto the unit disk
// (x, y) = sin(theta) (cos phi, sin phi). A direction outside the convex hull of the
// projection (e.g. theta beyond the last measured ring) gets the weights of the nearest point
// on the hull. Weights are non-negative, sum to 1, and a measured direction gets weight 1 on
// itself.
class DirectionInterpolator {
 public:
  struct Weights {
    std::array<std::uint32_t, 3> index{};
    std::array<double, 3> weight{};
  };

  // Requires at least one direction; with fewer than three non-collinear directions it falls
  // back to the nearest measured direction (or the nearest segment).
  explicit DirectionInterpolator(const DirectionSet& set);

  Weights weights(const Direction& d) const;
  Weights weights(const Vec3& v) const;

  // Triangles of the triangulation (indices into the set), for inspection and tests.
  const std::vector<std::array<std::uint32_t, 3>>& triangles() const { return triangles_; }
  // The directions projected onto the disk, (x, y) per direction of the set, and the edges
  // whose nearest point serves a direction outside the triangulation: what a GPU evaluation
  // of weights() needs (render/shader.hpp).
  const std::vector<std::array<double, 2>>& points() const { return points_; }
  const std::vector<std::array<std::uint32_t, 2>>& hull_edges() const { return hull_edges_; }

 private:
  using P2 = std::array<double, 2>;  // a direction projected onto the unit disk: (x, y)
  Weights weights_at(P2 p) const;

  std::vector<P2> points_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
  std::vector<std::array<std::uint32_t, 2>> hull_edges_;
};

}  // namespace btfgmm
