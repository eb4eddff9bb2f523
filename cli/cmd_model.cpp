// btfgmm fit, decode and eval.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include <unistd.h>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "budget_fit.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "mpi_processes.hpp"
#include "provenance_text.hpp"
#include "stop_signals.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {
namespace {

// ---- fit ---------------------------------------------------------------------------------

struct FitOptions {
  std::string input, out, tile, precision, method = "gm", objective;
  std::size_t components = 0, clusters = 0, degree = 0;  // 0: the method's default
  int iterations = 0;                                    // 0: the method's default
  int levels = 0;                                        // 0: the method's default
  int refine_steps = 0;                                  // 0: until converged
  double refine_seconds = 0.0;                           // 0: the default bound
  double epsilon = 0.0;
  std::uint64_t seed = 1;
  int threads = 0;
  bool overwrite = false, quiet = false;
  std::string checkpoint, resume, continue_from, log;
  int checkpoint_every = 1;
  std::uint64_t budget = 0;  // --budget BYTES (0: none)
  double ratio = 0.0;        // --ratio R (0: none)
  // The options given on the command line, by long name ("--components"), each with the
  // names it goes by ("-M/--components") for messages.
  std::map<std::string, std::string> given;
};

// The options given to `app`.
std::map<std::string, std::string> given_options(const CLI::App& app) {
  std::map<std::string, std::string> given;
  for (const CLI::Option* opt : app.get_options())
    if (opt->count() > 0) {
      std::string names = opt->get_name(false, true);
      std::replace(names.begin(), names.end(), ',', '/');
      given[opt->get_name()] = names;
    }
  return given;
}

// Options that cannot apply to what the fit does are errors, never ignored: those of
// `options` given are named, with `why`.
void refuse_options(const FitOptions& o, std::initializer_list<const char*> options,
                    const std::string& why) {
  std::string named;
  int count = 0;
  for (const char* opt : options)
    if (const auto it = o.given.find(opt); it != o.given.end()) {
      named += (named.empty() ? "" : ", ") + it->second;
      ++count;
    }
  if (count > 0)
    throw Error(Error::Kind::kArgument, fmt::format("{} cannot apply {}; leave {} out", named, why,
                                                    count == 1 ? "it" : "them"));
}

// The settings of the fit as the library takes them (btfgmm/methods/fit_options.hpp).
btfgmm::FitOptions library_options(const FitOptions& o) {
  btfgmm::FitOptions f;
  f.method = o.method;
  f.components = o.components;
  f.clusters = o.clusters;
  f.degree = o.degree;
  f.iterations = o.iterations;
  f.levels = o.levels;
  if (o.given.count("--epsilon")) f.epsilon = o.epsilon;
  f.seed = o.seed;
  f.threads = o.threads;
  f.precision = o.precision;
  f.objective = o.objective;
  f.refine_steps = o.refine_steps;
  f.refine_seconds = o.refine_seconds;
  return f;
}

// A new fit, as the options ask.
btfgmm::FitRequest new_fit_request(const FitOptions& o) {
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument,
                "fit needs an input BTF and -o MODEL (or --resume CHECKPOINT to continue an "
                "interrupted fit, or --continue MODEL --iterations N -o MODEL to go on with a "
                "finished one)");
  btfgmm::FitRequest r = btfgmm::mixture_fit_request(library_options(o), o.input, o.out);
  r.checkpoint = o.checkpoint;
  return r;
}

// With --resume, the interrupted fit continued: everything (the output included) from its
// checkpoint, which keeps the state unless --checkpoint names another.
btfgmm::FitRequest resume_fit_request(const FitOptions& o) {
  refuse_options(o,
                 {"--output", "--tile", "--components", "--seed", "--precision", "--overwrite",
                  "--continue", "--levels"},
                 fmt::format("with --resume: the fit goes on with the input, tile, components, "
                             "seed, precision and output its checkpoint '{}' holds",
                             o.resume));
  btfgmm::FitRequest r = btfgmm::resume_request(o.resume);
  if (!o.checkpoint.empty()) r.checkpoint = o.checkpoint;
  // A checkpoint holds EM's state, before any refinement: the objective is the command's.
  r.config.objective =
      btfgmm::parse_objective(o.objective.empty() ? "prediction" : o.objective, "--objective");
  return r;
}

// With --continue, the finished mixture's EM goes on to --iterations in all, from its stored
// parameters, on its data (the input, or the source its provenance records).
btfgmm::FitRequest continue_fit_request(const FitOptions& o) {
  refuse_options(o, {"--tile", "--components", "--seed", "--precision", "--objective", "--levels"},
                 fmt::format("with --continue: the fit goes on with the tile, components, seed, "
                             "precision and objective of the model '{}'",
                             o.continue_from));
  if (!o.given.count("--iterations") || o.out.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("--continue {} needs --iterations N (the total number of EM "
                            "iterations, more than the model has run) and -o MODEL",
                            o.continue_from));
  btfgmm::FitRequest r = btfgmm::continue_request(o.continue_from, o.input, o.iterations, o.out);
  r.checkpoint = o.checkpoint;
  return r;
}

// A new fit, the interrupted one resumed (--resume), or a finished one continued
// (--continue); --iterations and --epsilon apply to each.
btfgmm::FitRequest fit_request(const FitOptions& o) {
  btfgmm::FitRequest r = !o.resume.empty()          ? resume_fit_request(o)
                         : !o.continue_from.empty() ? continue_fit_request(o)
                                                    : new_fit_request(o);
  if (r.resume && o.given.count("--iterations")) r.config.em.max_iterations = o.iterations;
  if (r.resume && o.given.count("--epsilon")) r.config.em.epsilon = o.epsilon;
  // Resumed or continued: checked against the objective (a continuation's is its model's).
  if (o.given.count("--refine-steps")) btfgmm::set_refine_steps(r.config, o.refine_steps);
  if (o.refine_seconds > 0) r.config.refinement_seconds = o.refine_seconds;
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

void print_loaded(const btfgmm::FitTile& t, double seconds) {
  fmt::print(stderr, "loaded {}x{} pixels at ({}, {}) x {} lights x {} views = {} samples in {}\n",
             t.origin.width, t.origin.height, t.origin.x, t.origin.y, t.lights.size(),
             t.views.size(), t.samples(), human_seconds(seconds));
}

// Where this run of a fit starts: after `iteration` iterations (0, or those of the fit it
// resumes or continues) that took `seconds`.
struct RunStart {
  int iteration = 0;
  double seconds = 0.0;
};

// The memory this process holds now (its resident set, /proc/self/statm), 0 where unknown.
double memory_in_use() {
  std::ifstream statm("/proc/self/statm");
  double pages = 0, resident = 0;
  if (!(statm >> pages >> resident)) return 0.0;
  return resident * double(sysconf(_SC_PAGESIZE));
}

// The refinement for the prediction after a validation, the first and then one every 5
// seconds at most: the validation RMSE (held-out samples) of the parameters reached and the
// lowest met, the training RMSE beside it.
void print_refinement(const btfgmm::GradientProgress& p, double& printed_at) {
  const bool last = p.fraction >= 1.0;
  if (p.step > 1 && !last && p.elapsed < printed_at + 5.0) return;
  printed_at = p.elapsed;
  const std::string bound =
      p.steps > 0 ? fmt::format("step {}/{}", p.step, p.steps) : fmt::format("step {}", p.step);
  fmt::print(stderr,
             "refining for the prediction: epoch {:>3} {:<12} validation RMSE {:.3f} levels "
             "(lowest {:.3f})  training RMSE {:.3f}  {} of at most {}\n",
             p.epoch, bound, p.validation_rmse, p.best_validation_rmse, p.training_rmse,
             human_seconds(p.elapsed), human_seconds(p.seconds));
}

// One EM iteration; the time left is estimated from this run's iterations. The first
// iteration of a fit has no gain.
void print_iteration(const btfgmm::EmProgress& p, const RunStart& start) {
  const double per = (p.seconds - start.seconds) / std::max(1, p.iteration - start.iteration);
  const std::string gain =
      std::isnan(p.relative_gain) ? std::string() : fmt::format("gain {:+.2e}", p.relative_gain);
  fmt::print(stderr,
             "iteration {:>3}/{}  L = {:.6f}  {:<14}  components {} ({} dropped)  {}  ETA {}  "
             "memory {}\n",
             p.iteration, p.max_iterations, p.log_likelihood, gain, p.components, p.dropped,
             human_seconds(p.seconds), human_seconds(per * (p.max_iterations - p.iteration)),
             human_bytes(memory_in_use()));
}

// The model written. Its L is of the parameters written, after the last M-step; each
// iteration's line shows L of the parameters it started from (docs/ALGORITHM.md).
void print_written(const std::string& out, const btfgmm::FitOutcome& fit, const RunStart& start) {
  const btfgmm::BtfModel& model = fit.model;
  const btfgmm::FitLog& log = model.provenance.fit;
  const std::string last =
      log.iterations.empty()
          ? std::string()
          : fmt::format(" (iteration {} showed L = {:.6f}, before its M-step)",
                        log.iterations.size(), log.iterations.back().log_likelihood);
  const std::string time =
      start.iteration > 0 ? fmt::format("{} in all, {} in this run from iteration {} on",
                                        human_seconds(log.seconds),
                                        human_seconds(model.settings.seconds), start.iteration + 1)
                          : human_seconds(log.seconds);
  fmt::print(stderr,
             "wrote {}: M = {} ({} dropped), L = {:.6f} after the last M-step{}, {} bytes, "
             "compression 1:{:.1f} (paper's count) / 1:{:.1f} (file), fit in {}\n",
             out, model.mixture.size(), model.settings.dropped, model.settings.log_likelihood, last,
             fit.file_bytes, model.compression_ratio_paper(),
             model.compression_ratio_file(fit.file_bytes), time);
  if (const auto& r = fit.refinement) {
    fmt::print(stderr,
               "refined for the prediction in {} Adam steps ({} epochs{}, {}): validation RMSE "
               "{:.3f} levels after EM, {:.3f} after the colour refit, {:.3f} in the model (on "
               "{} held-out samples); training RMSE {:.3f}\n",
               r->steps, r->epochs,
               r->timed_out ? ", the time bound"
               : r->stopped ? ", stopped"
                            : "",
               human_seconds(r->seconds), btfgmm::prediction_rmse(r->error_em, r->samples),
               btfgmm::prediction_rmse(r->error_colour, r->samples),
               btfgmm::prediction_rmse(r->error_final, r->samples), r->samples, r->training_rmse);
  }
}

// ---- fit --method: any other method ------------------------------------------------------

// Options of the mixture's EM that another method cannot use are errors, never ignored.
void check_method_options(const FitOptions& o) {
  refuse_options(o,
                 {"--epsilon", "--checkpoint", "--checkpoint-every", "--resume", "--continue",
                  "--log", "--objective", "--refine-steps", "--refine-seconds"},
                 fmt::format("to --method {}: they belong to the Gaussian mixture's fit "
                             "(--method gm) only",
                             o.method));
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument, "fit needs an input BTF and -o MODEL");
}

void run_method_fit(const FitOptions& o) {
  check_method_options(o);
  const btfgmm::FitOptions options = library_options(o);
  btfgmm::method_settings(options, btfgmm::find_method(o.method));  // checked before any work
  check_output_file(o.out, o.overwrite);
  const auto t0 = Clock::now();
  auto src = std::make_shared<const btfgmm::BtfSource>(btfgmm::BtfSource::open(o.input));
  const btfgmm::Tile tile = o.tile.empty() ? btfgmm::Tile{} : tile_option(*src, o.tile, o.quiet);
  btfgmm::FitProgress progress;
  if (!o.quiet) {
    progress.started = [&](const btfgmm::FitTile& t) { print_loaded(t, seconds_since(t0)); };
    progress.progress = [&](double fraction, std::string_view stage) {
      fmt::print(stderr, "{} {:>5.1f}%  {}\n", o.method, 100.0 * fraction, stage);
    };
  }
  const std::unique_ptr<btfgmm::Representation> r =
      btfgmm::fit_representation(options, o.input, std::move(src), tile, progress);
  const double fit_seconds = r->provenance().fit.seconds;
  const std::uint64_t bytes = btfgmm::save_representation(*r, o.out);
  if (o.quiet) return;
  fmt::print(stderr,
             "wrote {}: {} {}, {} values, {} bytes, compression 1:{:.1f} (paper's count) / "
             "1:{:.1f} (file), fit in {}\n",
             o.out, o.method, r->size_text(), r->parameter_count(), bytes, r->paper_ratio(),
             r->file_ratio(bytes), human_seconds(fit_seconds));
}

// `fit --log FILE`: opened once the fit starts, with the iterations of the fit it resumes or
// continues first.
std::optional<IterationLog> open_iteration_log(const FitOptions& o, const btfgmm::FitRequest& r) {
  if (o.log.empty()) return std::nullopt;
  IterationLog log(o.log, r.config.components);
  if (r.resume) {
    const btfgmm::EmResult& e = r.resume->checkpoint.state.result;
    for (std::size_t i = 0; i < e.log_likelihood.size(); ++i)
      log.add({e.log_likelihood[i], i < e.seconds.size() ? e.seconds[i] : 0.0,
               i < e.components.size() ? e.components[i] : 0u});
  }
  return log;
}

// The mixture's fit, in this process alone or as one of `processes` (only process 0 prints
// and writes files).
void run_mixture_fit(const FitOptions& options,
                     const std::shared_ptr<btfgmm::Communicator>& processes) {
  FitOptions o = options;
  if (processes && processes->rank() != 0) {
    o.quiet = true;
    o.log.clear();  // process 0 writes the iteration log
  }
  btfgmm::FitRequest r = fit_request(o);
  r.processes = processes;
  const bool resumed = r.resume && !r.resume->finished_model;
  check_output_file(r.output, o.overwrite || resumed);
  if (!r.checkpoint.empty()) check_output_file(r.checkpoint, true);
  if (!o.log.empty()) check_output_file(o.log, o.overwrite || resumed);
  const auto t0 = Clock::now();
  choose_fit_tile(r, o.tile, o.quiet);
  RunStart start;
  if (r.resume) {
    const btfgmm::EmResult& e = r.resume->checkpoint.state.result;
    start = {e.iterations, e.seconds.empty() ? 0.0 : e.seconds.back()};
  }
  std::optional<StopOnSignals> stop_on_signals;
  std::optional<IterationLog> log;
  btfgmm::FitObserver observer;
  observer.started = [&](const btfgmm::FitTile& tile) {
    if (!o.quiet) print_loaded(tile, seconds_since(t0));
    if (r.resume && !o.quiet)
      fmt::print(stderr, "{} {} after iteration {}\n", resumed ? "resuming from" : "continuing",
                 r.resume->path, start.iteration);
    log = open_iteration_log(o, r);
    stop_on_signals.emplace();
  };
  observer.iteration = [&](const btfgmm::EmProgress& p) {
    if (!o.quiet) print_iteration(p, start);
    if (log) log->add({p.log_likelihood, p.seconds, std::uint32_t(p.components)});
  };
  double printed_at = 0.0;
  observer.refinement = [&](const btfgmm::GradientProgress& p) {
    if (!o.quiet) print_refinement(p, printed_at);
  };
  const btfgmm::FitOutcome fit = btfgmm::run_fit(r, observer);
  stop_on_signals.reset();
  if (fit.interrupted) {
    // Not an error, but the fit is not done: said even with --quiet.
    fmt::print(stderr,
               "interrupted after iteration {} of {}; nothing is lost: the fit's state is in "
               "{}\ncontinue with: btfgmm fit --resume {}\n",
               fit.iterations, r.config.em.max_iterations, fit.checkpoint, fit.checkpoint);
    std::exit(130);
  }
  if (!o.quiet) print_written(r.output, fit, start);
  if (fit.refinement && fit.refinement->stopped) {
    // The model is written, but with fewer steps than the fit affords: said even with --quiet.
    fmt::print(stderr,
               "interrupted during the refinement for the prediction after step {}: {} holds "
               "the lowest validation error met so far, and is complete{}\n",
               fit.refinement->steps, r.output,
               fit.checkpoint.empty()
                   ? std::string("; fit again for the whole refinement")
                   : fmt::format("; EM's state is in {}\nrefine again without EM with: btfgmm fit "
                                 "--resume {}",
                                 fit.checkpoint, fit.checkpoint));
    std::exit(130);
  }
}

// With --budget or --ratio, the method and size are chosen (cmd_budget.cpp): the options that
// set them, or belong to one method's fit, are errors.
void run_fit_within_budget(const FitOptions& o) {
  const char* budget = o.given.count("--budget") ? "--budget" : "--ratio";
  if (o.given.count("--budget") && o.given.count("--ratio"))
    throw Error(Error::Kind::kArgument,
                "--budget and --ratio both set the budget; give one of them");
  refuse_options(o,
                 {"--method", "--components", "--clusters", "--degree", "--precision",
                  "--objective", "--refine-steps", "--refine-seconds", "--epsilon", "--levels",
                  "--checkpoint", "--checkpoint-every", "--resume", "--continue", "--log"},
                 fmt::format("with {}: it chooses the method and size itself (each method's "
                             "ladder of sizes, stored as sweep stores them)",
                             budget));
  if (const auto processes = job_processes(); processes && processes->size() > 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("fit {} runs in one process; start it without mpirun", budget));
  run_budget_fit({o.input, o.out, o.tile, o.budget, o.ratio, o.seed, o.threads, o.iterations,
                  o.overwrite, o.quiet});
}

// An MPI job (mpirun) fits the mixture over its processes; an error in one ends them all.
void run_fit(const FitOptions& o) {
  if (o.given.count("--budget") || o.given.count("--ratio")) return run_fit_within_budget(o);
  const std::shared_ptr<btfgmm::Communicator> processes = job_processes();
  if (o.method != btfgmm::kMixtureMethod) {
    if (processes && processes->size() > 1)
      throw Error(Error::Kind::kArgument,
                  fmt::format("--method {} runs in one process; start it without mpirun (only "
                              "the Gaussian mixture's EM is split over processes)",
                              o.method));
    return run_method_fit(o);
  }
  if (!processes || processes->size() == 1) return run_mixture_fit(o, processes);
  try {
    run_mixture_fit(o, processes);
  } catch (const std::exception& e) {
    fmt::print(stderr,
               "btfgmm: error: process {} of {}: {}\nbtfgmm: ending every process of "
               "the job; a checkpoint already written is whole (continue with fit --resume)\n",
               processes->rank(), processes->size(), e.what());
    end_job_on_error(1);
    throw;
  }
}

// ---- decode ------------------------------------------------------------------------------

struct DecodeOptions {
  std::string model, out, size;
  std::vector<std::string> lights, views;
  double tolerance = btfgmm::kDecodeTolerance;
  bool overwrite = false;
  std::optional<std::uint64_t> seed;
};

void run_decode(const DecodeOptions& o) {
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
                "Maximum EM iterations (gm, default 40; with --resume or --continue, the total "
                "to go on to), re-assignment rounds (lpca) or Levenberg-Marquardt steps (plm-rf)")
      ->check(CLI::Range(1, 100000));
  f->add_option("--levels", fit->levels,
                "3d-car, 2d-car, gmrf: levels K of each subspace image's Gaussian-Laplacian "
                "pyramid, a model each (default 3, or as many as the tile holds with the "
                "coarsest level at least 8 x 8 pixels)")
      ->check(CLI::Range(1, 16));
  f->add_option("--epsilon", fit->epsilon, "Stop when the relative gain of L is below this")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  f->add_option("--seed", fit->seed, "Seed of the random initialisation")->capture_default_str();
  f->add_option("--objective", fit->objective,
                "gm: prediction (default: EM, then the mixture refined for the prediction's "
                "error, Eq. 8-11: the colour means by least squares, gradient steps on every "
                "parameter, the colour means again) or likelihood (the paper's EM alone, "
                "exactly)");
  f->add_option("--refine-steps", fit->refine_steps,
                "gm, --objective prediction: exactly this many Adam steps of the refinement "
                "(default: until the error on the held-out samples stops falling, "
                "docs/ALGORITHM.md)")
      ->check(CLI::Range(1, btfgmm::kMaxRefineSteps));
  f->add_option("--refine-seconds", fit->refine_seconds,
                fmt::format("gm, --objective prediction: the most seconds the refinement takes "
                            "(default M / {:g}: {:g} at M = 600); the lowest held-out error met "
                            "is kept",
                            1.0 / btfgmm::kDefaultRefineSecondsPerComponent,
                            btfgmm::default_refine_seconds(600)))
      ->check(CLI::Range(1.0, btfgmm::kMaxRefineSeconds));
  f->add_option("--threads", fit->threads,
                "Threads (0: all cores; the model does not depend "
                "on it)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  f->add_option("--precision", fit->precision,
                "gm: compact (default: each parameter quantised with a stated step, zstd; "
                "docs/FORMAT.md), f32 (exact, for --continue to match one longer fit) or f16; "
                "other methods: f32, f16 or q8 (8 bits with an offset and scale per component, "
                "default); 3d-car, 2d-car, gmrf: the range map's (f16 default; their few model "
                "parameters are always f32)");
  f->add_option("--budget", fit->budget,
                "Choose the method and size that decode the tile best (PSNR) within this many "
                "bytes of model file; prints the candidates tried")
      ->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 50));
  f->add_option("--ratio", fit->ratio,
                "As --budget, with the budget the tile's data bytes (a byte a value) over R")
      ->check(CLI::Range(1.0, 1e9));
  f->add_option("-o,--output", fit->out, "The model file to write (.btfgmm)");
  f->add_option("--checkpoint", fit->checkpoint,
                "Save the fit's state here (atomically) every --checkpoint-every iterations and "
                "on SIGINT/SIGTERM; removed when the model is written");
  f->add_option("--checkpoint-every", fit->checkpoint_every, "Iterations between checkpoints")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  f->add_option("--resume", fit->resume,
                "Continue an interrupted fit from its checkpoint (input, tile, settings and "
                "output come from it; --iterations N goes on to N in all); the model equals an "
                "uninterrupted fit's, bit for bit")
      ->excludes(f->get_option("input"));
  f->add_option("--continue", fit->continue_from,
                "Continue a finished Gaussian mixture (a .btfgmm) to --iterations N in all, "
                "from its stored parameters, on the data its provenance names (or the input); "
                "equals one longer fit within the rounding of the stored parameters");
  f->add_option("--log", fit->log,
                "Write every EM iteration to this file as it goes: a JSON object a line "
                "(iteration, log_likelihood, relative_gain, components, dropped, seconds), or "
                "CSV for a name ending in .csv");
  f->add_flag("--overwrite", fit->overwrite, "Replace an existing model file (and --log file)");
  f->add_flag("-q,--quiet", fit->quiet,
              "Nothing on stderr but errors (and the notice of an interrupted fit)");

  commands.push_back({f, [fit, f] {
                        fit->given = given_options(*f);
                        run_fit(*fit);
                      }});
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
  d->add_option("--seed", dec->seed,
                "Seed of the synthesis, for the texture models (3d-car, 2d-car, gmrf; default: "
                "the fit's)");

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
