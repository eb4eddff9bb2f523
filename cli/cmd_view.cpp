// btfgmm view: the models in a WebGL2 page that opens from the file system.
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

// ---- view --------------------------------------------------------------------------------

struct ViewArguments {
  std::vector<std::string> models;
  std::string out;
  bool overwrite = false, quiet = false;
};

void run_view(const ViewArguments& o) {
  check_output_folder(o.out, o.overwrite);
  std::vector<std::unique_ptr<Representation>> loaded;
  std::vector<ViewerModel> models;
  for (const std::string& path : o.models) {
    loaded.push_back(load_representation(path));
    models.push_back({fs::path(path).filename().string(), loaded.back().get()});
  }
  const std::vector<ViewerFile> files = viewer_files(
      models,
      "btfgmm render MODEL --mesh {mesh} --light {light} --camera {camera} --repeat {repeat} "
      "--fov {fov} --exposure {exposure} --size {size} --tolerance 0 -o out.png");
  fs::create_directories(o.out);
  for (const ViewerFile& f : files) write_text(fs::path(o.out) / f.name, f.text, "viewer page");
  if (!o.quiet)
    fmt::print(stderr, "wrote {}: open it in a browser with WebGL2 (no server needed)\n",
               (fs::path(o.out) / "index.html").string());
}

}  // namespace

void register_view_command(CLI::App& app, Commands& commands) {
  auto vo = std::make_shared<ViewArguments>();
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
}

}  // namespace btfgmm::cli
