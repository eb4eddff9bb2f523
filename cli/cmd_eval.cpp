// btfgmm eval: a model's RGB at one pixel, light and view.
#include <fmt/format.h>

#include <array>
#include <iostream>
#include <span>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "device_option.hpp"

namespace btfgmm::cli {
namespace {

struct EvalArguments {
  std::string model, light, view, device = "auto";
  double x = 0, y = 0;
  bool json = false;
};

void run_eval(const EvalArguments& o) {
  const auto model = btfgmm::load_representation(o.model);
  compute_on_device(*model, o.device, o.model);
  const btfgmm::Query q{.x = o.x,
                        .y = o.y,
                        .light = parse_direction(o.light, "--light"),
                        .view = parse_direction(o.view, "--view")};
  std::array<float, 3> rgb{};
  model->predict(std::span(&q, 1), rgb);
  const bool hdr = model->frame().format == btfgmm::SampleFormat::kHdr;
  if (o.json) {
    nlohmann::json j;
    j["x"] = o.x;
    j["y"] = o.y;
    j["light"] = {q.light.theta_deg, q.light.phi_deg};
    j["view"] = {q.view.theta_deg, q.view.phi_deg};
    j["rgb"] = {rgb[0], rgb[1], rgb[2]};
    j["units"] = hdr ? "linear" : "levels";  // linear: the data's units; levels: of 0-255
    std::cout << j.dump() << "\n";
  } else {
    fmt::print("R {:.4f}  G {:.4f}  B {:.4f}  ({})\n", rgb[0], rgb[1], rgb[2],
               hdr ? "linear values in the data's units" : "levels of 0-255");
  }
}

}  // namespace

void register_eval_command(CLI::App& app, Commands& commands) {
  auto ev = std::make_shared<EvalArguments>();
  auto* e = app.add_subcommand(
      "eval",
      "Evaluate a model at one pixel, light and view: its RGB, labelled, in levels of 0-255 "
      "(8- and 16-bit data) or in the data's linear units (OpenEXR data)");
  e->add_option("model", ev->model, "A .btfgmm model")->required();
  e->add_option("--x", ev->x,
                "Column in the model's tile, in pixels: integers are pixel centres, 0 the tile's "
                "first column (not the source image's); any real number, the tile repeats "
                "(x and x + W give the same value)")
      ->required();
  e->add_option("--y", ev->y,
                "Row in the model's tile, in pixels, as --x: 0 is the centre of the tile's first "
                "row")
      ->required();
  e->add_option("--light", ev->light, "Light THETA,PHI in degrees")->required();
  e->add_option("--view", ev->view, "View THETA,PHI in degrees")->required();
  add_device_option(e, ev->device);
  e->add_flag("--json", ev->json,
              "One JSON object for scripts: x, y, light, view and rgb (the same units)");

  commands.push_back({e, [ev] { run_eval(*ev); }});
}

}  // namespace btfgmm::cli
