// btfgmm fit, decode and eval.
#include <fmt/format.h>

#include <atomic>
#include <csignal>
#include <optional>

#include <filesystem>
#include <iostream>
#include <memory>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

namespace fs = std::filesystem;

// ---- fit ---------------------------------------------------------------------------------

struct FitOptions {
  std::string input, out, tile, precision = "f32";
  std::size_t components = 600;
  int iterations = 40;
  double epsilon = 0.0;
  std::uint64_t seed = 1;
  int threads = 0;
  bool overwrite = false, quiet = false;
  std::string checkpoint, resume;
  int checkpoint_every = 1;
};

// Set by SIGINT / SIGTERM: the fit stops after the iteration under way and saves its state.
std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) {
  g_stop.store(true);
}

void run_fit(FitOptions o) {
  std::optional<btfgmm::FitCheckpoint> resumed;
  btfgmm::Tile tile;
  if (!o.resume.empty()) {
    // Everything comes from the checkpoint; the output it names is this fit's own.
    resumed = btfgmm::load_checkpoint(o.resume);
    o.input = resumed->input;
    o.out = resumed->output;
    o.components = resumed->components;
    o.seed = resumed->seed;
    o.iterations = resumed->max_iterations;
    o.epsilon = resumed->epsilon;
    o.precision = resumed->precision == btfgmm::Precision::kF16 ? "f16" : "f32";
    o.overwrite = true;
    if (o.checkpoint.empty()) o.checkpoint = o.resume;
  } else if (o.input.empty() || o.out.empty()) {
    throw Error(Error::Kind::kArgument,
                "fit needs an input BTF and -o MODEL (or --resume CHECKPOINT to continue an "
                "interrupted fit)");
  }
  if (o.precision != "f32" && o.precision != "f16")
    throw Error(Error::Kind::kArgument,
                fmt::format("--precision '{}': give f32 or f16", o.precision));
  check_output_file(o.out, o.overwrite);
  if (!o.checkpoint.empty()) check_output_file(o.checkpoint, true);
  const auto t0 = Clock::now();
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(o.input);
  tile = resumed ? resumed->tile : tile_option(src, o.tile, o.quiet);  // X,Y,W,H or auto:WxH
  const btfgmm::Btf btf = src.load(tile);
  const std::uint64_t fingerprint = btfgmm::btf_fingerprint(btf);
  if (resumed && resumed->data_fingerprint != fingerprint)
    throw Error(Error::Kind::kArgument,
                fmt::format("the data in '{}' is not what checkpoint '{}' was fitted to (it "
                            "changed since); resume with the original data or fit again",
                            o.input, o.resume));
  const std::size_t n = btf.image_count() * std::size_t(btf.width()) * btf.height();
  if (!o.quiet)
    fmt::print(stderr,
               "loaded {}x{} pixels at ({}, {}) x {} lights x {} views = {} samples in {}\n",
               btf.width(), btf.height(), btf.origin().x, btf.origin().y, btf.lights().size(),
               btf.views().size(), n, human_seconds(seconds_since(t0)));
  btfgmm::FitConfig c;
  c.components = o.components;
  c.seed = o.seed;
  c.em.max_iterations = o.iterations;
  c.em.epsilon = o.epsilon;
  c.em.threads = o.threads;
  c.em.stop = &g_stop;
  const int first = resumed ? resumed->state.result.iterations : 0;
  if (resumed && !o.quiet)
    fmt::print(stderr, "resuming from {} after iteration {}\n", o.resume, first);
  auto progress = [&](const btfgmm::EmProgress& p) {
    if (o.quiet) return;
    const double per = p.seconds / std::max(1, p.iteration - first);
    fmt::print(stderr,
               "iteration {:>3}/{}  L = {:.6f}  gain {:+.2e}  components {} ({} dropped)  {}  "
               "ETA {}\n",
               p.iteration, p.max_iterations, p.log_likelihood, p.relative_gain, p.components,
               p.dropped, human_seconds(p.seconds),
               human_seconds(per * (p.max_iterations - p.iteration)));
  };
  auto checkpoint_of = [&](const btfgmm::ProductMixture& mix, const btfgmm::EmResult& r) {
    btfgmm::FitCheckpoint k;
    k.input = o.input;
    k.output = o.out;
    k.tile = btf.origin();
    k.components = o.components;
    k.seed = o.seed;
    k.max_iterations = o.iterations;
    k.epsilon = o.epsilon;
    k.precision = o.precision == "f16" ? btfgmm::Precision::kF16 : btfgmm::Precision::kF32;
    k.data_fingerprint = fingerprint;
    k.state = {mix, r};
    return k;
  };
  auto after_iteration = [&](const btfgmm::ProductMixture& mix, const btfgmm::EmResult& r) {
    if (!o.checkpoint.empty() && r.iterations % std::max(1, o.checkpoint_every) == 0)
      btfgmm::save_checkpoint(checkpoint_of(mix, r), o.checkpoint);
  };
  g_stop.store(false);
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  btfgmm::FitState state;
  btfgmm::BtfModel model = btfgmm::fit_model(btf, c, progress, resumed ? &resumed->state : nullptr,
                                             after_iteration, &state);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (state.result.interrupted) {
    const std::string path = o.checkpoint.empty() ? o.out + ".ckpt" : o.checkpoint;
    btfgmm::save_checkpoint(checkpoint_of(state.mixture, state.result), path);
    fmt::print(stderr,
               "interrupted after iteration {} of {}; nothing is lost: the fit's state is in "
               "{}\ncontinue with: btfgmm fit --resume {}\n",
               state.result.iterations, o.iterations, path, path);
    std::exit(130);
  }
  model.precision = o.precision == "f16" ? btfgmm::Precision::kF16 : btfgmm::Precision::kF32;
  btfgmm::save_model(model, o.out);
  if (!o.checkpoint.empty()) {
    std::error_code ec;
    fs::remove(o.checkpoint, ec);  // the fit is complete: the model holds its result
  }
  const std::uint64_t bytes = fs::file_size(o.out);
  fmt::print(stderr,
             "wrote {}: M = {} ({} dropped), L = {:.6f}, {} bytes, compression 1:{:.1f} "
             "(paper's count) / 1:{:.1f} (file), fit in {}\n",
             o.out, model.mixture.size(), model.settings.dropped, model.settings.log_likelihood,
             bytes, model.compression_ratio_paper(), model.compression_ratio_file(bytes),
             human_seconds(model.settings.seconds));
}

// ---- decode ------------------------------------------------------------------------------

struct DecodeOptions {
  std::string model, out, size;
  std::vector<std::string> lights, views;
  double tolerance = btfgmm::kDecodeTolerance;
  bool overwrite = false;
};

void run_decode(const DecodeOptions& o) {
  const btfgmm::BtfModel m = btfgmm::load_model(o.model);
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
  const auto [w, h] = o.size.empty() ? std::pair{m.width, m.height} : parse_size(o.size);
  const auto t0 = Clock::now();
  // One light at a time: a large repeated size need not fit in memory at once.
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const btfgmm::Btf part =
        btfgmm::decode(m, btfgmm::DirectionSet({lights[l]}), views, w, h, o.tolerance);
    btfgmm::write_utia(part, o.out);
  }
  fmt::print(stderr, "wrote {} images of {}x{} pixels to {} in {}\n", lights.size() * views.size(),
             w, h, o.out, human_seconds(seconds_since(t0)));
}

// ---- eval --------------------------------------------------------------------------------

struct EvalOptions {
  std::string model, light, view;
  double x = 0, y = 0;
  bool json = false;
};

void run_eval(const EvalOptions& o) {
  const btfgmm::BtfModel m = btfgmm::load_model(o.model);
  const btfgmm::Query q{o.x, o.y, parse_direction(o.light, "--light"),
                        parse_direction(o.view, "--view")};
  const auto rgb = btfgmm::predict(m, q);
  if (o.json) {
    nlohmann::json j;
    j["x"] = o.x;
    j["y"] = o.y;
    j["light"] = {q.light.theta_deg, q.light.phi_deg};
    j["view"] = {q.view.theta_deg, q.view.phi_deg};
    j["rgb"] = {rgb[0], rgb[1], rgb[2]};
    std::cout << j.dump() << "\n";
  } else {
    fmt::print("{:.4f} {:.4f} {:.4f}\n", rgb[0], rgb[1], rgb[2]);
  }
}

}  // namespace

void register_model_commands(CLI::App& app, Commands& commands) {
  auto fit = std::make_shared<FitOptions>();
  auto* f = app.add_subcommand("fit", "Fit the Gaussian mixture model to a BTF tile");
  f->add_option("input", fit->input, "A BTF folder or Bonn .zip");
  f->add_option("--tile", fit->tile,
                "X,Y,W,H of the tile to fit, or auto:WxH for the most seamless tile of that size "
                "(default: the whole image)");
  f->add_option("--components,-M", fit->components, "Number of mixture components M")
      ->check(CLI::Range(std::size_t(1), std::size_t(100000)))
      ->capture_default_str();
  f->add_option("--iterations", fit->iterations, "Maximum EM iterations")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  f->add_option("--epsilon", fit->epsilon, "Stop when the relative gain of L is below this")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  f->add_option("--seed", fit->seed, "Seed of the random initialisation")->capture_default_str();
  f->add_option("--threads", fit->threads,
                "Threads (0: all cores; the model does not depend "
                "on it)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  f->add_option("--precision", fit->precision, "Parameters stored as f32 or f16")
      ->capture_default_str();
  f->add_option("-o,--output", fit->out, "The model file to write (.btfgmm)");
  f->add_option("--checkpoint", fit->checkpoint,
                "Save the fit's state here (atomically) every --checkpoint-every iterations and "
                "on SIGINT/SIGTERM; removed when the model is written");
  f->add_option("--checkpoint-every", fit->checkpoint_every, "Iterations between checkpoints")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  f->add_option("--resume", fit->resume,
                "Continue an interrupted fit from its checkpoint (input, tile, settings and "
                "output come from it); the model equals an uninterrupted fit's, bit for bit")
      ->excludes(f->get_option("input"));
  f->add_flag("--overwrite", fit->overwrite, "Replace an existing model file");
  f->add_flag("-q,--quiet", fit->quiet, "No progress on stderr");

  commands.push_back({f, [fit] { run_fit(*fit); }});

  auto dec = std::make_shared<DecodeOptions>();
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

  commands.push_back({d, [dec] { run_decode(*dec); }});

  auto ev = std::make_shared<EvalOptions>();
  auto* e = app.add_subcommand("eval", "Evaluate a model at one pixel, light and view");
  e->add_option("model", ev->model, "A .btfgmm model")->required();
  e->add_option("--x", ev->x, "Pixel x (any real number; the tile repeats)")->required();
  e->add_option("--y", ev->y, "Pixel y (any real number; the tile repeats)")->required();
  e->add_option("--light", ev->light, "Light THETA,PHI in degrees")->required();
  e->add_option("--view", ev->view, "View THETA,PHI in degrees")->required();
  e->add_flag("--json", ev->json, "One JSON object for scripts");

  commands.push_back({e, [ev] { run_eval(*ev); }});
}

}  // namespace btfgmm::cli
