// btfgmm decode: a model of any method into images (UTIA layout).
#include <fmt/format.h>

#include <optional>
#include <string>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/model/predict.hpp"
#include "cli_util.hpp"
#include "commands.hpp"

namespace btfgmm::cli {
namespace {

struct DecodeArguments {
  std::string model, out, size;
  std::vector<std::string> lights, views;
  double tolerance = btfgmm::kDecodeTolerance;
  bool overwrite = false;
  std::optional<std::uint64_t> seed;
};

void run_decode(const DecodeArguments& o) {
  const auto model = btfgmm::load_representation(o.model);
  if (o.seed) model->set_synthesis_seed(*o.seed, "--seed");
  const btfgmm::ModelFrame& m = model->frame();
  check_output_folder(o.out, o.overwrite);
  auto directions = [](const std::vector<std::string>& given, const btfgmm::DirectionSet& all,
                       const char* option) {
    if (given.empty()) return all;
    std::vector<btfgmm::Direction> d;
    for (const auto& g : given) d.push_back(parse_direction(g, option));
    return btfgmm::DirectionSet(std::move(d));
  };
  const btfgmm::DirectionSet lights = directions(o.lights, m.lights, "--light");
  const btfgmm::DirectionSet views = directions(o.views, m.views, "--view");
  const auto [w, h] =
      o.size.empty() ? std::pair{m.width, m.height} : parse_size(o.size, option_name("size"));
  const auto t0 = Clock::now();
  // One light at a time: a large repeated size need not fit in memory at once.
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const btfgmm::Btf part =
        model->decode(btfgmm::DirectionSet({lights[l]}), views, w, h, o.tolerance);
    btfgmm::write_utia(part, o.out);
  }
  fmt::print(stderr, "wrote {} images of {}x{} pixels to {} in {}\n", lights.size() * views.size(),
             w, h, o.out, human_seconds(seconds_since(t0)));
}

}  // namespace

void register_decode_command(CLI::App& app, Commands& commands) {
  auto dec = std::make_shared<DecodeArguments>();
  auto* d = app.add_subcommand("decode", "Decode a model into images (UTIA layout)");
  d->add_option("model", dec->model, "A .btfgmm model")->required();
  d->add_option("-o,--output", dec->out, "Output folder")->required();
  d->add_option("--light", dec->lights,
                "Light THETA,PHI in degrees (repeatable; default: the "
                "measured set)");
  d->add_option("--view", dec->views,
                "View THETA,PHI in degrees (repeatable; default: the "
                "measured set)");
  d->add_option("--size", dec->size, "N or WxH pixels, the tile repeated (default: the tile)");
  d->add_option("--tolerance", dec->tolerance,
                "Largest change, in levels, that skipping negligible components may cause (0: "
                "evaluate every component)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  d->add_flag("--overwrite", dec->overwrite, "Replace images in a non-empty output folder");
  d->add_option("--seed", dec->seed,
                "Seed of the synthesis, for the texture models (3d-car, 2d-car, gmrf; default: "
                "the fit's)");

  commands.push_back({d, [dec] { run_decode(*dec); }});
}

}  // namespace btfgmm::cli
