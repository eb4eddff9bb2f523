// What the shader generators share (render/shader.hpp): the parameter texture as it is
// filled, GLSL constants, and the tables of the measured directions and the mean BRDF.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <string_view>

#include "btfgmm/core/directions.hpp"
#include "btfgmm/methods/representation.hpp"
#include "btfgmm/render/shader.hpp"

namespace btfgmm::detail {

// Texels a row of the parameter texture (WebGL2 guarantees 2048).
constexpr int kShaderTextureWidth = 1024;

// The parameter texture as it is filled, and the GLSL constants that say where its tables
// begin.
class ShaderBuilder {
 public:
  explicit ShaderBuilder(std::string method);
  // Appends a texel; returns its index.
  std::size_t texel(float a, float b = 0.0f, float c = 0.0f, float d = 0.0f);
  std::size_t size() const { return texels_.size() / 4; }
  // Pads the texture to a multiple of n texels (n divides kShaderTextureWidth: a record of n
  // texels from there lies in one row); returns the size.
  std::size_t align(std::size_t n);
  // `const int NAME = value;`, `const vecN NAME = vecN(...)`, a comment line.
  void constant(std::string_view name, std::size_t value);
  void constant(std::string_view name, std::array<double, 2> value);
  void constant(std::string_view name, std::array<double, 3> value);
  void constant(std::string_view name, std::array<double, 4> value);
  void float_constant(std::string_view name, double value);
  void comment(std::string_view text);
  // The GLSL of the resource glsl/`file` after the constants.
  void include(std::string_view file);
  // The finished shader: the texture padded to whole rows, its width defined first.
  ShaderExport finish(bool has_mean_brdf);

 private:
  std::string method_, constants_, code_;
  std::vector<float> texels_;
};

// A float as a GLSL literal that reads back to the same float ("1.0", "-2.5e-07").
std::string glsl_float(double v);

// The common part of every shader: the tile's size (BTF_TILE) and the helpers of
// glsl/common.glsl.
void add_common(ShaderBuilder& b, const ModelFrame& frame);

// The triangulation of a measured direction set (core/interpolation.hpp) as the tables
// glsl/common.glsl's btf_direction_weights() reads: BTF_<PREFIX>_TRIANGLES,
// BTF_<PREFIX>_TRIANGLE_COUNT, BTF_<PREFIX>_EDGES, BTF_<PREFIX>_EDGE_COUNT.
void add_direction_tables(ShaderBuilder& b, const DirectionSet& set, std::string_view prefix);

// The mean BRDF (ni * nv * 3 values, light major) and both direction sets' tables, with
// glsl/mean_brdf.glsl: btf_mean_brdf().
void add_mean_brdf(ShaderBuilder& b, const ModelFrame& frame, std::span<const float> mean_brdf);

// What the methods that store images of the measured pairs share: both direction sets'
// tables, BTF_LIGHTS and BTF_VIEWS, and glsl/measured_images.glsl (bilinear in space, over the
// measured directions: methods/measured_images.hpp).
void add_measured_images(ShaderBuilder& b, const ModelFrame& frame);
// `count` images of `pixels` RGB pixels each (`rgb`: count x pixels x 3), then zero images up to
// `padded` in all, a texel a pixel; returns where the first begins.
std::size_t add_images(ShaderBuilder& b, std::span<const float> rgb, std::size_t count,
                       std::size_t pixels, std::size_t padded);

// The generators (one file each), for the table in shader_export.cpp.
ShaderExport mixture_shader(const Representation& model);  // shader_mixture.cpp
ShaderExport pca_btf_shader(const Representation& model);  // shader_pca_btf.cpp
ShaderExport pca_rf_shader(const Representation& model);   // shader_pca_rf.cpp
ShaderExport ptm_rf_shader(const Representation& model);   // shader_ptm_rf.cpp
ShaderExport lpca_shader(const Representation& model);     // shader_lpca.cpp
ShaderExport plm_rf_shader(const Representation& model);   // shader_plm_rf.cpp
ShaderExport neural_shader(const Representation& model);   // shader_neural.cpp

}  // namespace btfgmm::detail
