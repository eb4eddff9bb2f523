// btfgmm export-shader: a model as a GLSL function and its parameter texture.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/render/shader.hpp"
#include "btfgmm/render/viewer.hpp"
#include "cli_util.hpp"
#include "commands.hpp"

namespace btfgmm::cli {
namespace {

namespace fs = std::filesystem;

struct ExportArguments {
  std::string model, out;
  bool glsl = false, overwrite = false, quiet = false;
};

// The parameter file beside `out`: its name with the extension .bin.
fs::path parameter_path(const fs::path& out) {
  fs::path p = out;
  return p.replace_extension(".bin");
}

void run_export_shader(const ExportArguments& o) {
  const fs::path out = o.out, params = parameter_path(out);
  if (params == out)
    throw Error(Error::Kind::kArgument,
                fmt::format("-o '{}': the parameters are written beside the shader as '{}'; "
                            "give the shader another extension, e.g. .glsl",
                            o.out, params.string()));
  check_output_file(out, o.overwrite);
  check_output_file(params, o.overwrite);
  const auto model = load_representation(o.model);
  const ShaderExport shader = export_shader(*model);
  write_file_atomically(params, shader_parameter_file(shader), "shader parameters");
  write_text(out, shader.glsl, "shader");
  if (!o.quiet)
    fmt::print(stderr,
               "wrote {} (vec3 btf(vec2 uv, vec3 light, vec3 view)) and {} ({} x {} RGBA32F "
               "texels for its sampler btf_params); docs/RENDERING.md shows how to use them\n",
               out.string(), params.string(), shader.width, shader.height);
}

}  // namespace

void register_export_shader_command(CLI::App& app, Commands& commands) {
  auto eo = std::make_shared<ExportArguments>();
  auto* e = app.add_subcommand(
      "export-shader",
      "Write a model as a GLSL function vec3 btf(vec2 uv, vec3 light, vec3 view) and its "
      "parameter texture (OUT with the extension .bin) for a renderer of your own");
  e->add_option("model", eo->model, "A .btfgmm model")->required();
  e->add_flag("--glsl", eo->glsl, "GLSL ES 3.00 / GLSL 3.30 (the language written; the default)");
  e->add_option("-o,--output", eo->out, "The shader to write, e.g. material.glsl")->required();
  e->add_flag("--overwrite", eo->overwrite, "Replace existing files");
  e->add_flag("-q,--quiet", eo->quiet, "No summary on stderr");
  commands.push_back({e, [eo] { run_export_shader(*eo); }});
}

}  // namespace btfgmm::cli
