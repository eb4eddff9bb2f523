// A fitted representation as a GLSL function for the GPU (docs/RENDERING.md, "Shader export"):
//   vec3 btf(vec2 uv, vec3 light, vec3 view)
// the BTF at the tile position uv (in tiles, the tile repeated) for unit light and view
// directions in the surface's local frame, in the data's units, evaluated as the CPU does (for
// the Gaussian mixture: Eq. 8-11 in the log domain, the tile's wrap, the mean BRDF
// interpolated over the measured directions), and its parameters as one RGBA32F texture
// `btf_params`. Each method has its own generator (src/render/shader_*.cpp) in one table;
// `btfgmm export-shader` writes them, `btfgmm view` builds its WebGL2 page on them.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/methods/representation.hpp"

namespace btfgmm {

struct ShaderExport {
  std::string method;  // the method's name ("gm")
  // GLSL ES 3.00 (also GLSL 3.30) without a #version line: constants, the sampler uniform
  // btf_params, the helpers, and btf(); with a mean BRDF, also
  // vec3 btf_mean_brdf(vec3 light, vec3 view).
  std::string glsl;
  bool has_mean_brdf = false;
  // The parameter texture: width x height RGBA32F texels, row-major (texel i at
  // (i % width, i / width)), 4 floats a texel.
  int width = 0, height = 0;
  std::vector<float> texels;
};

// The generator of one method's shader.
struct ShaderGenerator {
  std::string_view method;
  std::function<ShaderExport(const Representation&)> generate;
};

// Every method with a shader generator.
std::span<const ShaderGenerator> shader_generators();

// The shader of any representation. Throws Error(kArgument) naming the method and those that
// have a shader when its method has none.
ShaderExport export_shader(const Representation& model);

// The parameter file written beside an exported shader (docs/RENDERING.md): the 8 bytes
// "BTFPARAM", the width and height (uint32, little-endian), then width * height * 4 float32
// (little-endian), row-major.
std::vector<std::uint8_t> shader_parameter_file(const ShaderExport& shader);
// Reads it back; Error(kFormat) naming `name` for a file that is not one.
ShaderExport read_shader_parameter_file(std::span<const std::uint8_t> bytes,
                                        const std::string& name);

}  // namespace btfgmm
