// Directions over the upper hemisphere and their parameterisations (interpolation over a
// measured set: interpolation.hpp).
//
// A direction is given in spherical angles in degrees: elevation theta in [0, 90] from the
// surface normal (z), azimuth phi in [0, 360) from the x axis toward y. The model works in
// Havran et al. 2010's signed onion-slice angles (alpha, beta), see docs/ALGORITHM.md and
// to_onion_slice().
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace btfgmm {

struct Direction {
  double theta_deg = 0.0;  // elevation from the normal, [0, 90]
  double phi_deg = 0.0;    // azimuth, [0, 360)
};

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

// Onion-slice coordinates in radians: beta = asin(sin theta cos phi) in [-pi/2, pi/2],
// alpha = atan2(sin theta sin phi, cos theta) in (-pi, pi] (signed: docs/ALGORITHM.md).
struct OnionSlice {
  double alpha = 0.0;
  double beta = 0.0;
};

// Unit vector (sin t cos p, sin t sin p, cos t).
Vec3 to_vector(const Direction& d);
// Spherical angles of a (not necessarily unit) vector; phi is wrapped into [0, 360).
// At the pole (x = y = 0) phi is 0.
Direction to_direction(const Vec3& v);

// The signed onion-slice form (docs/ALGORITHM.md, the paper's xi_3..xi_6 with the sign of
// sin(phi) kept): beta = asin(x), alpha = atan2(y, z).
OnionSlice to_onion_slice(const Vec3& v);
OnionSlice to_onion_slice(const Direction& d);
// Inverse: (x, y, z) = (sin beta, sin alpha cos beta, cos alpha cos beta).
Vec3 from_onion_slice(const OnionSlice& o);

// Angle between two directions, in degrees.
double angular_distance_deg(const Direction& a, const Direction& b);

// An ordered set of measured directions (lights or views). Any size; light and view sets of
// one BTF may differ.
class DirectionSet {
 public:
  DirectionSet() = default;
  explicit DirectionSet(std::vector<Direction> directions) : dirs_(std::move(directions)) {}

  // The 81 directions of Bonn UBO2003 and UTIA: rings theta = 0, 15, ..., 75 degrees holding
  // 1, 6, 12, 18, 20, 24 directions, phi from 0 in steps of 360/n, in that order.
  static DirectionSet ubo81();
  // Rings of (theta, count): phi = k * 360 / count, k = 0 .. count-1, in the order given.
  static DirectionSet rings(const std::vector<std::pair<double, int>>& rings);
  // n directions spread evenly over the hemisphere up to theta_max (a Fibonacci spiral),
  // angles rounded to 0.1 degree so they survive file names such as tl023.5.
  static DirectionSet spiral(int n, double theta_max_deg = 80.0);
  // "ubo81", "spiral:N", or "rings:THETA/COUNT,THETA/COUNT,...". Throws Error(kArgument).
  static DirectionSet parse(const std::string& spec);

  std::size_t size() const { return dirs_.size(); }
  bool empty() const { return dirs_.empty(); }
  const Direction& operator[](std::size_t i) const { return dirs_[i]; }
  const std::vector<Direction>& directions() const { return dirs_; }
  auto begin() const { return dirs_.begin(); }
  auto end() const { return dirs_.end(); }

  // Index of the direction within tol_deg (angular distance) of d, if any.
  std::optional<std::size_t> find(const Direction& d, double tol_deg = 1e-6) const;

  bool operator==(const DirectionSet& other) const;

 private:
  std::vector<Direction> dirs_;
};

}  // namespace btfgmm
