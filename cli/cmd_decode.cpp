// btfgmm decode: a model of any method into images (UTIA layout).
#include <fmt/format.h>

#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/model/predict.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "device_option.hpp"
#include "stop_signals.hpp"

namespace btfgmm::cli {
namespace {

struct DecodeArguments {
  std::string model, out, size, device = "auto";
  std::vector<std::string> lights, views;
  double tolerance = btfgmm::kDecodeTolerance;
  bool overwrite = false, yes = false, quiet = false;
  std::optional<std::uint64_t> seed;
};

// What decode writes without --yes: 1 GiB of 8-bit RGB (a whole 81 x 81 tile of 64 x 64 pixels
// is 77 MiB; every image of a texture model at 512 x 512 would be 4.8 GiB).
constexpr double kDecodeBytesWithoutYes = 1024.0 * 1024.0 * 1024.0;

// Says what the decoding will write before it starts, and refuses more than
// kDecodeBytesWithoutYes unless --yes.
void check_decode_size(const DecodeArguments& o, std::size_t images, int w, int h,
                       const std::string& where) {
  const double bytes = double(images) * double(w) * double(h) * 3.0;
  if (bytes > kDecodeBytesWithoutYes && !o.yes)
    throw btfgmm::Error(
        btfgmm::Error::Kind::kArgument,
        fmt::format("decode would write {} images of {}x{} pixels, {} of 8-bit RGB (PNG files "
                    "take up to that), more than the {} it writes without asking; give --yes to "
                    "write them, or fewer images (--light, --view) or a smaller --size",
                    images, w, h, human_bytes(bytes), human_bytes(kDecodeBytesWithoutYes)));
  if (!o.quiet)
    fmt::print(stderr, "decoding {} images of {}x{} pixels to {} (up to {} as 8-bit RGB) on {}\n",
               images, w, h, o.out, human_bytes(bytes), where);
}

void run_decode(const DecodeArguments& o) {
  const auto model = btfgmm::load_representation(o.model);
  if (o.seed) model->set_synthesis_seed(*o.seed, "--seed");
  const btfgmm::ModelFrame& m = model->frame();
  check_output_folder(o.out, o.overwrite);
  const std::string where = compute_on_device(*model, o.device, o.model);
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
  check_decode_size(o, lights.size() * views.size(), w, h, where);
  const auto t0 = Clock::now();
  double printed_at = 0.0;
  // One light at a time: a large repeated size need not fit in memory at once. Ctrl-C ends it
  // after the light under way, its images whole.
  const StopOnSignals stop_on_signals;
  for (std::size_t l = 0; l < lights.size(); ++l) {
    if (g_stop.load()) {
      fmt::print(stderr, "interrupted after {} of {} lights: the {} images in {} are whole\n", l,
                 lights.size(), l * views.size(), o.out);
      std::exit(130);
    }
    const btfgmm::Btf part =
        model->decode(btfgmm::DirectionSet({lights[l]}), views, w, h, o.tolerance);
    btfgmm::write_utia(part, o.out);
    const double seconds = seconds_since(t0);
    if (!o.quiet && l + 1 < lights.size() && seconds >= printed_at + 2.0) {
      printed_at = seconds;
      fmt::print(stderr, "decoded {} of {} lights ({} images), {} so far, about {} left\n", l + 1,
                 lights.size(), (l + 1) * views.size(), human_seconds(seconds),
                 human_seconds(seconds / double(l + 1) * double(lights.size() - l - 1)));
    }
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
                "evaluate every component; the GPU evaluates every component)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  add_device_option(d, dec->device);
  d->add_flag("--overwrite", dec->overwrite, "Replace images in a non-empty output folder");
  d->add_flag("--yes", dec->yes,
              "Write more than 1 GiB of images (images x width x height x 3 bytes), which is "
              "refused without it");
  d->add_flag("-q,--quiet", dec->quiet, "Print nothing before or during the decoding");
  d->add_option("--seed", dec->seed,
                "Seed of the synthesis, for the texture models (3d-car, 2d-car, gmrf; default: "
                "the fit's)");

  commands.push_back({d, [dec] { run_decode(*dec); }});
}

}  // namespace btfgmm::cli
