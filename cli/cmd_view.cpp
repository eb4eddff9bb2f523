// btfgmm view (the models in a WebGL2 page that opens from the file system) and btfgmm
// export-shader (a model as a GLSL function and its parameter file).
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

void write_text(const fs::path& path, const std::string& text, const char* what) {
  write_file_atomically(
      path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), what);
}

// ---- view --------------------------------------------------------------------------------

struct ViewOptions {
  std::vector<std::string> models;
  std::string out;
  bool overwrite = false, quiet = false;
};

void run_view(const ViewOptions& o) {
  check_output_folder(o.out, o.overwrite);
  std::vector<std::unique_ptr<Representation>> loaded;
  std::vector<ViewerModel> models;
  for (const std::string& path : o.models) {
    loaded.push_back(load_representation(path));
    models.push_back({fs::path(path).filename().string(), loaded.back().get()});
  }
  const std::vector<ViewerFile> files = viewer_files(models);
  fs::create_directories(o.out);
  for (const ViewerFile& f : files) write_text(fs::path(o.out) / f.name, f.text, "viewer page");
  if (!o.quiet)
    fmt::print(stderr, "wrote {}: open it in a browser with WebGL2 (no server needed)\n",
               (fs::path(o.out) / "index.html").string());
}

// ---- export-shader -----------------------------------------------------------------------

struct ExportOptions {
  std::string model, out;
  bool glsl = false, overwrite = false, quiet = false;
};

// The parameter file beside `out`: its name with the extension .bin.
fs::path parameter_path(const fs::path& out) {
  fs::path p = out;
  return p.replace_extension(".bin");
}

void run_export_shader(const ExportOptions& o) {
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

void register_view_commands(CLI::App& app, Commands& commands) {
  auto vo = std::make_shared<ViewOptions>();
  auto* v = app.add_subcommand(
      "view",
      "Write a folder whose index.html shows the models in real time (WebGL2, no server, no "
      "network): meshes, light and view under the mouse, the model beside its mean BRDF");
  v->add_option("models", vo->models, "One or more .btfgmm models")->required();
  v->add_option("-o,--output", vo->out, "The folder to write (index.html and its scripts)")
      ->required();
  v->add_flag("--overwrite", vo->overwrite, "Write into a folder that is not empty");
  v->add_flag("-q,--quiet", vo->quiet, "No summary on stderr");
  commands.push_back({v, [vo] { run_view(*vo); }});

  auto eo = std::make_shared<ExportOptions>();
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
