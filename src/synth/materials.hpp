// The procedural materials of the synthetic BTF (internal): what a material gives at every
// point of the surface (height, albedo, gloss) and its reflectance constants.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace btfgmm::detail::synth {

struct Rgb {
  double r = 0.0, g = 0.0, b = 0.0;
};

// What a material's procedural description gives at one point.
struct Point {
  double height = 0.0;  // pixels
  Rgb albedo;           // linear diffuse reflectance
  double gloss = 1.0;   // weight of the specular lobe (1 = the material's full f0)
};

// A material: its procedural point function and its reflectance constants.
struct MaterialModel {
  std::function<Point(double x, double y)> at;  // x, y in pixels; periodic in size
  double roughness = 0.5;                       // GGX alpha
  Rgb f0{0.04, 0.04, 0.04};                     // specular reflectance at normal incidence
  double height_range = 0.0;  // > 0: rescale the height field to this peak-to-peak range
};

// Error(kArgument) unless `name` is one of btfgmm::materials(), naming the nearest.
void check_material(const std::string& name);

// The material called `name` (checked as check_material) for a size x size image.
MaterialModel material_model(const std::string& name, int size, std::uint64_t seed);

}  // namespace btfgmm::detail::synth
