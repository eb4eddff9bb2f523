// A fast look-up of DirectionInterpolator's barycentric weights, for the renderer's millions
// of queries (docs/RENDERING.md).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/interpolation.hpp"

namespace btfgmm {

// DirectionInterpolator's weights, the same numbers, found through a grid over the disk
// instead of a scan over every triangle (for millions of look-ups).
class FastDirectionInterpolator {
 public:
  explicit FastDirectionInterpolator(const DirectionSet& set);
  DirectionInterpolator::Weights weights(const Vec3& v) const;
  // The same, trying first the triangle `hint` (set to the triangle used, or to a value past
  // the triangles where none was): for coherent queries such as neighbouring pixels.
  DirectionInterpolator::Weights weights(const Vec3& v, std::uint32_t& hint) const;

 private:
  DirectionInterpolator::Weights weights_at(double qx, double qy, std::uint32_t* hint) const;

  DirectionInterpolator slow_;  // used where the set has no triangle
  std::vector<std::array<double, 2>> points_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
  std::vector<std::array<std::uint32_t, 2>> hull_edges_;
  int grid_ = 0;
  std::vector<std::uint32_t> cell_start_, cell_triangles_;
};

}  // namespace btfgmm
