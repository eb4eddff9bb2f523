// The real-time viewer's folder (render/viewer.hpp): the page and its script as kept in
// src/render/web, the built-in meshes and the models' shaders as data scripts.
#include "btfgmm/render/viewer.hpp"

#include <fmt/format.h>

#include <array>
#include <cstring>

#include "btfgmm/core/error.hpp"
#include "btfgmm/render/mesh.hpp"
#include "render/resources.hpp"

namespace btfgmm {

std::string base64(const void* bytes, std::size_t size) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const std::uint8_t*>(bytes);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (std::size_t i = 0; i < size; i += 3) {
    const std::uint32_t n = std::uint32_t(p[i]) << 16 |
                            (i + 1 < size ? std::uint32_t(p[i + 1]) << 8 : 0u) |
                            (i + 2 < size ? std::uint32_t(p[i + 2]) : 0u);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < size ? kAlphabet[(n >> 6) & 63] : '=';
    out += i + 2 < size ? kAlphabet[n & 63] : '=';
  }
  return out;
}

namespace {

// A JavaScript string literal of `text`.
std::string js_string(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        break;
      case '\t':
        out += "  ";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
          out += fmt::format("\\u{:04x}", int(c));
        else
          out += c;
    }
  }
  return out + "\"";
}

std::string resource(std::string_view name) {
  const std::string_view text = detail::render_resource(name);
  if (text.empty()) throw std::logic_error(std::string("render resource missing: ") += name);
  return std::string(text);
}

// One mesh as meshes.js holds it: per vertex position, normal, tangent, bitangent (x, y, z
// each) and u, v as float32; the triangles' vertex indices as uint32; the bounding sphere
// Camera::orbit frames.
std::string mesh_script(const std::string& name) {
  Mesh mesh = make_mesh(name);
  if (mesh.tangent.size() != mesh.position.size() ||
      mesh.bitangent.size() != mesh.position.size() || mesh.normal.size() != mesh.position.size())
    compute_tangent_frames(mesh);
  std::vector<float> attr;
  attr.reserve(mesh.position.size() * 14);
  for (std::size_t i = 0; i < mesh.position.size(); ++i) {
    for (const Vec3* v : {&mesh.position[i], &mesh.normal[i], &mesh.tangent[i], &mesh.bitangent[i]})
      attr.insert(attr.end(), {float(v->x), float(v->y), float(v->z)});
    attr.insert(attr.end(), {float(mesh.uv[i][0]), float(mesh.uv[i][1])});
  }
  std::vector<std::uint32_t> tri;
  tri.reserve(mesh.triangles.size() * 3);
  for (const auto& t : mesh.triangles) tri.insert(tri.end(), t.begin(), t.end());
  const Vec3 c = mesh.center();
  return fmt::format(
      "BTFGMM_MESHES.push({{name: {}, vertices: {}, radius: {}, center: [{}, {}, {}],\n"
      "  attributes: \"{}\",\n  triangles: \"{}\"}});\n",
      js_string(name), mesh.position.size(), mesh.radius(), c.x, c.y, c.z,
      base64(attr.data(), attr.size() * 4), base64(tri.data(), tri.size() * 4));
}

}  // namespace

std::string viewer_model_script(const std::string& name, const std::string& size_text,
                                const ModelFrame& frame, const ShaderExport& shader) {
  return fmt::format(
      "var BTFGMM_MODELS = window.BTFGMM_MODELS || [];\n"
      "BTFGMM_MODELS.push({{name: {}, method: {}, size: {}, tile: [{}, {}], hdr: {},\n"
      "  mean_brdf: {}, glsl: {},\n  params: {{width: {}, height: {}, data: \"{}\"}}}});\n",
      js_string(name), js_string(shader.method), js_string(size_text), frame.width, frame.height,
      frame.format == SampleFormat::kHdr ? "true" : "false",
      shader.has_mean_brdf ? "true" : "false", js_string(shader.glsl), shader.width, shader.height,
      base64(shader.texels.data(), shader.texels.size() * 4));
}

std::string viewer_model_script(const std::string& name, const Representation& model,
                                const ShaderExport& shader) {
  return viewer_model_script(name, model.size_text(), model.frame(), shader);
}

std::vector<ViewerFile> viewer_files(const std::vector<ViewerModel>& models,
                                     const std::string& cpu_command) {
  if (models.empty())
    throw Error(Error::Kind::kArgument, "the viewer needs at least one model; give a .btfgmm");
  std::string models_js = "var BTFGMM_CPU_COMMAND = " + js_string(cpu_command) + ";\n";
  for (const ViewerModel& m : models)
    models_js += viewer_model_script(m.name, *m.model, export_shader(*m.model));
  std::string meshes_js = "var BTFGMM_MESHES = window.BTFGMM_MESHES || [];\n";
  for (const char* name : {"sphere", "cloth", "plane", "cylinder"}) meshes_js += mesh_script(name);
  return {{"index.html", resource("web/index.html")},
          {"viewer.js", resource("web/viewer.js")},
          {"meshes.js", std::move(meshes_js)},
          {"models.js", std::move(models_js)}};
}

}  // namespace btfgmm
