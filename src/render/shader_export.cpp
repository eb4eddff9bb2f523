// A representation as a GLSL function and its parameter texture (render/shader.hpp): the
// table of generators, what they share (shader_tables.hpp), and the parameter file.
#include "btfgmm/render/shader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "render/resources.hpp"
#include "render/shader_tables.hpp"

namespace btfgmm {

std::span<const ShaderGenerator> shader_generators() {
  static const ShaderGenerator generators[] = {
      {"gm", detail::mixture_shader},    {"pca-btf", detail::pca_btf_shader},
      {"pca-rf", detail::pca_rf_shader}, {"lpca", detail::lpca_shader},
      {"ptm-rf", detail::ptm_rf_shader}, {"plm-rf", detail::plm_rf_shader},
      {"neural", detail::neural_shader},
  };
  return generators;
}

ShaderExport export_shader(const Representation& model) {
  std::string names;
  for (const ShaderGenerator& g : shader_generators()) {
    if (g.method == model.method()) return g.generate(model);
    names += fmt::format("{}{}", names.empty() ? "" : ", ", g.method);
  }
  throw Error(Error::Kind::kArgument,
              fmt::format("a {} model has no shader yet; the methods with one: {} (render it on "
                          "the CPU instead)",
                          model.method(), names));
}

namespace {

constexpr char kParameterMagic[8] = {'B', 'T', 'F', 'P', 'A', 'R', 'A', 'M'};
constexpr std::size_t kParameterHeader = 16;

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(std::uint8_t(v >> (8 * k)));
}
std::uint32_t get_u32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
         std::uint32_t(p[3]) << 24;
}

}  // namespace

std::vector<std::uint8_t> shader_parameter_file(const ShaderExport& shader) {
  std::vector<std::uint8_t> out(kParameterMagic, kParameterMagic + 8);
  put_u32(out, std::uint32_t(shader.width));
  put_u32(out, std::uint32_t(shader.height));
  for (const float f : shader.texels) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &f, 4);
    put_u32(out, bits);
  }
  return out;
}

ShaderExport read_shader_parameter_file(std::span<const std::uint8_t> bytes,
                                        const std::string& name) {
  if (bytes.size() < kParameterHeader || std::memcmp(bytes.data(), kParameterMagic, 8) != 0)
    throw Error(Error::Kind::kFormat,
                fmt::format("'{}' is not a shader parameter file (it does not begin with "
                            "BTFPARAM); export the model's shader to write one",
                            name));
  ShaderExport s;
  const std::uint32_t w = get_u32(bytes.data() + 8), h = get_u32(bytes.data() + 12);
  const std::uint64_t floats = std::uint64_t(w) * h * 4;
  if (w == 0 || h == 0 || bytes.size() - kParameterHeader != floats * 4)
    throw Error(Error::Kind::kFormat,
                fmt::format("'{}' holds {} bytes of parameters where its header ({} x {} "
                            "texels) says {}: the file is truncated or corrupted; export it again",
                            name, bytes.size() - kParameterHeader, w, h, floats * 4));
  s.width = int(w);
  s.height = int(h);
  s.texels.resize(std::size_t(floats));
  for (std::size_t i = 0; i < s.texels.size(); ++i) {
    const std::uint32_t bits = get_u32(bytes.data() + kParameterHeader + 4 * i);
    std::memcpy(&s.texels[i], &bits, 4);
  }
  return s;
}

namespace detail {

ShaderBuilder::ShaderBuilder(std::string method) : method_(std::move(method)) {}

std::size_t ShaderBuilder::texel(float a, float b, float c, float d) {
  texels_.insert(texels_.end(), {a, b, c, d});
  return texels_.size() / 4 - 1;
}

std::size_t ShaderBuilder::align(std::size_t n) {
  while (size() % n != 0) texel(0.0f);
  return size();
}

std::string glsl_float(double v) {
  const float f = float(v);
  std::string s = fmt::format("{}", f);  // the shortest text that reads back to f
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  if (s.find_first_of("eE") != std::string::npos && s.find('.') == std::string::npos)
    s.insert(s.find_first_of("eE"), ".0");
  return s;
}

void ShaderBuilder::constant(std::string_view name, std::size_t value) {
  constants_ += fmt::format("const int {} = {};\n", name, value);
}
void ShaderBuilder::constant(std::string_view name, std::array<double, 2> v) {
  constants_ +=
      fmt::format("const vec2 {} = vec2({}, {});\n", name, glsl_float(v[0]), glsl_float(v[1]));
}
void ShaderBuilder::constant(std::string_view name, std::array<double, 3> v) {
  constants_ += fmt::format("const vec3 {} = vec3({}, {}, {});\n", name, glsl_float(v[0]),
                            glsl_float(v[1]), glsl_float(v[2]));
}
void ShaderBuilder::constant(std::string_view name, std::array<double, 4> v) {
  constants_ += fmt::format("const vec4 {} = vec4({}, {}, {}, {});\n", name, glsl_float(v[0]),
                            glsl_float(v[1]), glsl_float(v[2]), glsl_float(v[3]));
}
void ShaderBuilder::float_constant(std::string_view name, double value) {
  constants_ += fmt::format("const float {} = {};\n", name, glsl_float(value));
}
void ShaderBuilder::comment(std::string_view text) {
  constants_ += fmt::format("// {}\n", text);
}

void ShaderBuilder::include(std::string_view file) {
  const std::string name = fmt::format("glsl/{}", file);
  const std::string_view text = render_resource(name);
  if (text.empty()) throw std::logic_error("render resource " + name + " is not built in");
  code_ += "\n";
  code_ += text;
}

ShaderExport ShaderBuilder::finish(bool has_mean_brdf) {
  ShaderExport s;
  s.method = method_;
  s.has_mean_brdf = has_mean_brdf;
  s.width = kShaderTextureWidth;
  s.height = int(std::max<std::size_t>(
      1, (size() + kShaderTextureWidth - 1) / std::size_t(kShaderTextureWidth)));
  s.texels = texels_;
  s.texels.resize(std::size_t(s.width) * std::size_t(s.height) * 4, 0.0f);
  s.glsl = fmt::format(
      "// Written by btfgmm's shader export (docs/RENDERING.md): a {} model as the GLSL function\n"
      "//   vec3 btf(vec2 uv, vec3 light, vec3 view)\n"
      "// GLSL ES 3.00 / GLSL 3.30. Bind its parameter file ({} x {} RGBA32F texels) to the\n"
      "// sampler btf_params, nearest filtering.\n"
      "#define BTF_PARAMS_WIDTH {}\n{}{}",
      method_, s.width, s.height, s.width, constants_, code_);
  return s;
}

void add_common(ShaderBuilder& b, const ModelFrame& frame) {
  b.constant("BTF_TILE", std::array<double, 2>{double(frame.width), double(frame.height)});
  b.include("common.glsl");
}

void add_direction_tables(ShaderBuilder& b, const DirectionSet& set, std::string_view prefix) {
  const DirectionInterpolator interp(set);
  const auto& p = interp.points();
  const auto& tris = interp.triangles();
  const auto& edges = interp.hull_edges();
  const std::size_t t0 = b.align(4);
  for (const auto& t : tris) {
    b.texel(float(p[t[0]][0]), float(p[t[0]][1]), float(p[t[1]][0]), float(p[t[1]][1]));
    const auto &a = p[t[0]], &bb = p[t[1]], &c = p[t[2]];
    const double area = (bb[0] - a[0]) * (c[1] - a[1]) - (bb[1] - a[1]) * (c[0] - a[0]);
    b.texel(float(c[0]), float(c[1]), float(1.0 / area));
    b.texel(float(t[0]), float(t[1]), float(t[2]));
    b.texel(0.0f);
  }
  const std::size_t e0 = b.align(2);
  for (const auto& e : edges) {
    b.texel(float(p[e[0]][0]), float(p[e[0]][1]), float(p[e[1]][0]), float(p[e[1]][1]));
    b.texel(float(e[0]), float(e[1]));
  }
  b.constant(fmt::format("BTF_{}_TRIANGLES", prefix), t0);
  b.constant(fmt::format("BTF_{}_TRIANGLE_COUNT", prefix), tris.size());
  b.constant(fmt::format("BTF_{}_EDGES", prefix), e0);
  b.constant(fmt::format("BTF_{}_EDGE_COUNT", prefix), edges.size());
}

void add_mean_brdf(ShaderBuilder& b, const ModelFrame& frame, std::span<const float> mean_brdf) {
  add_direction_tables(b, frame.lights, "LIGHT");
  add_direction_tables(b, frame.views, "VIEW");
  const std::size_t m0 = b.size();
  for (std::size_t i = 0; i + 2 < mean_brdf.size(); i += 3)
    b.texel(mean_brdf[i], mean_brdf[i + 1], mean_brdf[i + 2]);
  b.constant("BTF_VIEWS", frame.views.size());
  b.constant("BTF_MEAN_BRDF", m0);
  b.include("mean_brdf.glsl");
}

void add_measured_images(ShaderBuilder& b, const ModelFrame& frame) {
  add_direction_tables(b, frame.lights, "LIGHT");
  add_direction_tables(b, frame.views, "VIEW");
  b.constant("BTF_LIGHTS", frame.lights.size());
  b.constant("BTF_VIEWS", frame.views.size());
  b.include("measured_images.glsl");
}

std::size_t add_images(ShaderBuilder& b, std::span<const float> rgb, std::size_t count,
                       std::size_t pixels, std::size_t padded) {
  const std::size_t first = b.size();
  for (std::size_t i = 0; i < count * pixels; ++i)
    b.texel(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
  for (std::size_t i = count * pixels; i < padded * pixels; ++i) b.texel(0.0f);
  return first;
}

}  // namespace detail
}  // namespace btfgmm
