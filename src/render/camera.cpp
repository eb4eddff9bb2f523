// The scene of a rendering: a camera on a sphere around the object, directional and point
// lights.
#include "btfgmm/render/camera.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "btfgmm/core/error.hpp"

#include "core/vec3_ops.hpp"

namespace btfgmm {
namespace {

constexpr double kPi = std::numbers::pi;

using detail::operator+;
using detail::operator*;

}  // namespace

Camera Camera::orbit(const Direction& d, double radius, const Vec3& target, double fov_deg) {
  if (!(radius > 0.0) || !(fov_deg > 0.0 && fov_deg < 180.0))
    throw Error(Error::Kind::kArgument,
                fmt::format("camera: radius {} and field of view {} degrees must be positive "
                            "(field of view below 180)",
                            radius, fov_deg));
  Camera c;
  const Vec3 dir = to_vector(d);
  // Far enough that the sphere of `radius` fits in the view with a small margin.
  const double distance = 1.08 * radius / std::sin(0.5 * fov_deg * kPi / 180.0);
  c.target = target;
  c.eye = target + dir * distance;
  c.fov_deg = fov_deg;
  const double p = d.phi_deg * kPi / 180.0;
  c.up = d.theta_deg < 1e-6           ? Vec3{-std::cos(p), -std::sin(p), 0.0}
         : d.theta_deg > 180.0 - 1e-6 ? Vec3{std::cos(p), std::sin(p), 0.0}
                                      : Vec3{0, 0, 1};
  return c;
}

Light Light::directional(const Direction& d, double intensity) {
  Light l;
  l.kind = Kind::kDirectional;
  l.direction = to_vector(d);
  l.intensity = intensity;
  return l;
}

Light Light::point(const Vec3& position, double intensity) {
  Light l;
  l.kind = Kind::kPoint;
  l.position = position;
  l.intensity = intensity;
  return l;
}

}  // namespace btfgmm
