// btfgmm fit, decode and eval.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "stop_signals.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

// ---- fit ---------------------------------------------------------------------------------

struct FitOptions {
  std::string input, out, tile, precision, method = "gm";
  std::size_t components = 0, clusters = 0, degree = 0;  // 0: the method's default
  int iterations = 0;                                    // 0: the method's default
  double epsilon = 0.0;
  std::uint64_t seed = 1;
  int threads = 0;
  bool overwrite = false, quiet = false;
  std::string checkpoint, resume;
  int checkpoint_every = 1;
};

btfgmm::Precision parse_precision(const std::string& text) {
  if (text == "f32") return btfgmm::Precision::kF32;
  if (text == "f16") return btfgmm::Precision::kF16;
  throw Error(Error::Kind::kArgument,
              fmt::format("--precision '{}': the Gaussian mixture stores f32 or f16", text));
}

// A new fit, as the options ask.
btfgmm::FitRequest new_fit_request(const FitOptions& o) {
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument,
                "fit needs an input BTF and -o MODEL (or --resume CHECKPOINT to continue an "
                "interrupted fit)");
  btfgmm::FitRequest r;
  r.input = o.input;
  r.output = o.out;
  r.config.components = o.components ? o.components : 600;
  r.config.seed = o.seed;
  r.config.em.max_iterations = o.iterations ? o.iterations : 40;
  r.config.em.epsilon = o.epsilon;
  r.precision = parse_precision(o.precision.empty() ? "f32" : o.precision);
  r.checkpoint = o.checkpoint;
  return r;
}

// A new fit or, with --resume, the interrupted one continued: everything (the output
// included) from its checkpoint, which keeps the state unless --checkpoint names another.
btfgmm::FitRequest fit_request(const FitOptions& o) {
  btfgmm::FitRequest r = o.resume.empty() ? new_fit_request(o) : btfgmm::resume_request(o.resume);
  if (r.resume && !o.checkpoint.empty()) r.checkpoint = o.checkpoint;
  r.checkpoint_every = o.checkpoint_every;
  r.config.em.threads = o.threads;
  r.config.em.stop = &g_stop;
  return r;
}

// --tile X,Y,W,H or auto:WxH: the data is opened here for the search, and the fit reads it.
void choose_fit_tile(btfgmm::FitRequest& r, const std::string& tile, bool quiet) {
  if (r.resume || tile.empty()) return;  // a resume fits the checkpoint's tile
  auto src = std::make_shared<const btfgmm::BtfSource>(btfgmm::BtfSource::open(r.input));
  r.tile = tile_option(*src, tile, quiet);
  r.source = std::move(src);
}

void print_loaded(const btfgmm::Btf& btf, double seconds) {
  const std::size_t n = btf.image_count() * std::size_t(btf.width()) * btf.height();
  fmt::print(stderr, "loaded {}x{} pixels at ({}, {}) x {} lights x {} views = {} samples in {}\n",
             btf.width(), btf.height(), btf.origin().x, btf.origin().y, btf.lights().size(),
             btf.views().size(), n, human_seconds(seconds));
}

// One EM iteration; the time left is estimated from the iterations since `first`.
void print_iteration(const btfgmm::EmProgress& p, int first) {
  const double per = p.seconds / std::max(1, p.iteration - first);
  fmt::print(stderr,
             "iteration {:>3}/{}  L = {:.6f}  gain {:+.2e}  components {} ({} dropped)  {}  "
             "ETA {}\n",
             p.iteration, p.max_iterations, p.log_likelihood, p.relative_gain, p.components,
             p.dropped, human_seconds(p.seconds),
             human_seconds(per * (p.max_iterations - p.iteration)));
}

void print_written(const std::string& out, const btfgmm::FitOutcome& fit) {
  const btfgmm::BtfModel& model = fit.model;
  fmt::print(stderr,
             "wrote {}: M = {} ({} dropped), L = {:.6f}, {} bytes, compression 1:{:.1f} "
             "(paper's count) / 1:{:.1f} (file), fit in {}\n",
             out, model.mixture.size(), model.settings.dropped, model.settings.log_likelihood,
             fit.file_bytes, model.compression_ratio_paper(),
             model.compression_ratio_file(fit.file_bytes), human_seconds(model.settings.seconds));
}

// ---- fit --method: any other method ------------------------------------------------------

// Options of the mixture's EM that another method cannot use are errors, never ignored.
void check_method_options(const FitOptions& o) {
  auto refuse = [&](bool given, const char* option) {
    if (given)
      throw Error(Error::Kind::kArgument,
                  fmt::format("{} applies to the Gaussian mixture's EM (--method gm) only, not to "
                              "--method {}; leave it out",
                              option, o.method));
  };
  refuse(o.epsilon != 0.0, "--epsilon");
  refuse(!o.checkpoint.empty(), "--checkpoint");
  refuse(o.checkpoint_every != 1, "--checkpoint-every");
  refuse(!o.resume.empty(), "--resume");
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument, "fit needs an input BTF and -o MODEL");
}

void run_method_fit(const FitOptions& o) {
  check_method_options(o);
  const btfgmm::MethodInfo& method = btfgmm::find_method(o.method);
  btfgmm::MethodSettings s;
  s.components = o.components;
  s.clusters = o.clusters;
  s.degree = o.degree;
  s.iterations = o.iterations;
  s.seed = o.seed;
  s.threads = o.threads;
  // 8 bits a factor by default: at most 0.1 dB below f32 on generated tiles (docs/METHODS.md).
  s.encoding = o.precision.empty() ? method.fit_encoding
                                   : btfgmm::parse_factor_encoding(o.precision, "--precision");
  check_output_file(o.out, o.overwrite);
  const auto t0 = Clock::now();
  const btfgmm::BtfSource src = btfgmm::BtfSource::open(o.input);
  const btfgmm::Tile tile = o.tile.empty() ? btfgmm::Tile{0, 0, src.info().width, src.info().height}
                                           : tile_option(src, o.tile, o.quiet);
  const btfgmm::Btf btf = src.load(tile);
  if (!o.quiet) print_loaded(btf, seconds_since(t0));
  if (!o.quiet)
    s.progress = [&](double fraction, std::string_view stage) {
      fmt::print(stderr, "{} {:>5.1f}%  {}\n", o.method, 100.0 * fraction, stage);
    };
  const auto t1 = Clock::now();
  const std::unique_ptr<btfgmm::Representation> r = method.fit(btf, s);
  const double fit_seconds = seconds_since(t1);
  const std::uint64_t bytes = btfgmm::save_representation(*r, o.out);
  fmt::print(stderr,
             "wrote {}: {} {}, {} values, {} bytes, compression 1:{:.1f} (paper's count) / "
             "1:{:.1f} (file), fit in {}\n",
             o.out, o.method, r->size_text(), r->parameter_count(), bytes, r->paper_ratio(),
             r->file_ratio(bytes), human_seconds(fit_seconds));
}

void run_fit(const FitOptions& o) {
  if (o.method != btfgmm::kMixtureMethod) return run_method_fit(o);
  if (o.clusters != 0 || o.degree != 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} applies to {} only, not to the Gaussian mixture; leave it out",
                            o.clusters ? "--clusters" : "--degree",
                            o.clusters ? "--method lpca" : "--method plm-rf"));
  btfgmm::FitRequest r = fit_request(o);
  check_output_file(r.output, o.overwrite || r.resume);
  if (!r.checkpoint.empty()) check_output_file(r.checkpoint, true);
  const auto t0 = Clock::now();
  choose_fit_tile(r, o.tile, o.quiet);
  const int first = r.resume ? r.resume->checkpoint.state.result.iterations : 0;
  std::optional<StopOnSignals> stop_on_signals;
  btfgmm::FitObserver observer;
  observer.started = [&](const btfgmm::Btf& btf) {
    if (!o.quiet) print_loaded(btf, seconds_since(t0));
    if (r.resume && !o.quiet)
      fmt::print(stderr, "resuming from {} after iteration {}\n", r.resume->path, first);
    stop_on_signals.emplace();
  };
  observer.iteration = [&](const btfgmm::EmProgress& p) {
    if (!o.quiet) print_iteration(p, first);
  };
  const btfgmm::FitOutcome fit = btfgmm::run_fit(r, observer);
  stop_on_signals.reset();
  if (fit.interrupted) {
    fmt::print(stderr,
               "interrupted after iteration {} of {}; nothing is lost: the fit's state is in "
               "{}\ncontinue with: btfgmm fit --resume {}\n",
               fit.iterations, r.config.em.max_iterations, fit.checkpoint, fit.checkpoint);
    std::exit(130);
  }
  print_written(r.output, fit);
}

// ---- decode ------------------------------------------------------------------------------

struct DecodeOptions {
  std::string model, out, size;
  std::vector<std::string> lights, views;
  double tolerance = btfgmm::kDecodeTolerance;
  bool overwrite = false;
};

void run_decode(const DecodeOptions& o) {
  const auto model = btfgmm::load_representation(o.model);
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
  const auto [w, h] = o.size.empty() ? std::pair{m.width, m.height} : parse_size(o.size);
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

// ---- eval --------------------------------------------------------------------------------

struct EvalOptions {
  std::string model, light, view;
  double x = 0, y = 0;
  bool json = false;
};

void run_eval(const EvalOptions& o) {
  const auto model = btfgmm::load_representation(o.model);
  const btfgmm::Query q{o.x, o.y, parse_direction(o.light, "--light"),
                        parse_direction(o.view, "--view")};
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

// ---- the subcommands ---------------------------------------------------------------------

// --method's help: every method with its paper.
std::string method_help() {
  std::string h = "The representation to fit:";
  for (const btfgmm::MethodInfo& m : btfgmm::all_methods())
    h += fmt::format("\n  {:<8} {} ({})", m.name, m.title, m.citation);
  return h;
}

void register_fit(CLI::App& app, Commands& commands) {
  auto fit = std::make_shared<FitOptions>();
  auto* f = app.add_subcommand(
      "fit", "Fit a model to a BTF tile: the Gaussian mixture (default) or another method");
  f->add_option("input", fit->input, "A BTF folder or Bonn .zip");
  f->add_option("--tile", fit->tile,
                "X,Y,W,H of the tile to fit, or auto:WxH for the most seamless tile of that size "
                "(default: the whole image)");
  f->add_option("--method", fit->method, method_help())->capture_default_str();
  f->add_option("--components,-M", fit->components,
                "The model's size: mixture components M (gm, default 600), eigen-images c "
                "(pca-btf, pca-rf) or components per cluster (lpca); default: the method's")
      ->check(CLI::Range(std::size_t(1), std::size_t(100000)));
  f->add_option("--clusters", fit->clusters, "lpca: the number of clusters k")
      ->check(CLI::Range(std::size_t(1), std::size_t(100000)));
  f->add_option("--degree", fit->degree, "plm-rf: the degree of the per-image polynomial")
      ->check(CLI::Range(std::size_t(0), std::size_t(64)));
  f->add_option("--iterations", fit->iterations,
                "Maximum EM iterations (gm, default 40), re-assignment rounds (lpca) or "
                "Levenberg-Marquardt steps (plm-rf)")
      ->check(CLI::Range(1, 100000));
  f->add_option("--epsilon", fit->epsilon, "Stop when the relative gain of L is below this")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  f->add_option("--seed", fit->seed, "Seed of the random initialisation")->capture_default_str();
  f->add_option("--threads", fit->threads,
                "Threads (0: all cores; the model does not depend "
                "on it)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  f->add_option("--precision", fit->precision,
                "Parameters stored as f32 or f16 (gm, default f32), or f32, f16 or q8 (8 bits "
                "with an offset and scale per component; other methods, default q8)");
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
}

void register_decode(CLI::App& app, Commands& commands) {
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
}

void register_eval(CLI::App& app, Commands& commands) {
  auto ev = std::make_shared<EvalOptions>();
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
  e->add_flag("--json", ev->json,
              "One JSON object for scripts: x, y, light, view and rgb (the same units)");

  commands.push_back({e, [ev] { run_eval(*ev); }});
}

}  // namespace

void register_model_commands(CLI::App& app, Commands& commands) {
  register_fit(app, commands);
  register_decode(app, commands);
  register_eval(app, commands);
}

}  // namespace btfgmm::cli
