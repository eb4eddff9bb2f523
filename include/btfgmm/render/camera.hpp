// The scene of a rendering: the camera, the light, and the render settings (image size, tile
// repeat, exposure, background, the model kernel's tolerance).
//
// Coordinates: the world is right-handed with z up. Directions given as (theta, phi) are
// world directions in the convention of directions.hpp: theta from +z, phi from +x toward +y.
#pragma once

#include <array>

#include "btfgmm/core/directions.hpp"

namespace btfgmm {

struct Camera {
  Vec3 eye{0, 0, 4}, target{0, 0, 0}, up{0, 0, 1};
  double fov_deg = 30.0;  // vertical field of view

  // On a sphere around `target`, in the world direction `d` (theta in [0, 180]: from below
  // too), far enough that a sphere of `radius` around the target fills the view. Up is +z
  // (straight above or below, the limit of the neighbouring directions of the same phi).
  static Camera orbit(const Direction& d, double radius, const Vec3& target = {},
                      double fov_deg = 30.0);
};

struct Light {
  enum class Kind { kDirectional, kPoint };
  Kind kind = Kind::kDirectional;
  Vec3 direction{0, 0, 1};  // directional: the world direction toward the light
  Vec3 position{0, 0, 4};   // point: the light's position
  // Scale of the BTF values: directional, the irradiance (1 = as measured); point, the
  // irradiance at distance 1 (it falls off with the squared distance).
  double intensity = 1.0;

  static Light directional(const Direction& d, double intensity = 1.0);
  static Light point(const Vec3& position, double intensity);
};

struct RenderSettings {
  int width = 800, height = 800;
  double repeat = 4.0;    // tiles per unit of u (and of v, at the tile's width)
  double exposure = 0.0;  // stops: values are scaled by 2^exposure
  std::array<float, 3> background{40, 40, 40};  // 0-255 levels
  // ModelEvaluator: the largest colour error, in levels, that skipping components may cause
  // (0: evaluate every component at every point).
  double tolerance = 0.1;
};

}  // namespace btfgmm
