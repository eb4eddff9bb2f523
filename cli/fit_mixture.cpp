// btfgmm fit, the Gaussian mixture: a new fit, the interrupted one resumed (--resume) or a
// finished one continued (--continue), in one process or over the processes of an MPI job,
// with its progress, iteration log and signals.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <optional>
#include <string>

#include <unistd.h>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "cli_util.hpp"
#include "fit_command.hpp"
#include "provenance_text.hpp"
#include "stop_signals.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {

void print_loaded(const btfgmm::FitTile& t, double seconds) {
  fmt::print(stderr, "loaded {}x{} pixels at ({}, {}) x {} lights x {} views = {} samples in {}\n",
             t.origin.width, t.origin.height, t.origin.x, t.origin.y, t.lights.size(),
             t.views.size(), t.samples(), human_seconds(seconds));
}

namespace {

// A new fit, as the options ask.
btfgmm::FitRequest new_fit_request(const FitArguments& o) {
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument,
                "fit needs an input BTF and -o MODEL (or --resume CHECKPOINT to continue an "
                "interrupted fit, or --continue MODEL --iterations N -o MODEL to go on with a "
                "finished one)");
  check_fit_arguments(o, btfgmm::FitRoute::kNew);
  btfgmm::FitRequest r = btfgmm::mixture_fit_request(o.options, o.input, o.out);
  r.checkpoint = o.checkpoint;
  return r;
}

// With --resume, the interrupted fit continued: everything (the output included) from its
// checkpoint, which keeps the state unless --checkpoint names another.
btfgmm::FitRequest resume_fit_request(const FitArguments& o) {
  check_fit_arguments(o, btfgmm::FitRoute::kResume, o.resume);
  btfgmm::FitRequest r = btfgmm::resume_request(o.resume);
  if (!o.checkpoint.empty()) r.checkpoint = o.checkpoint;
  // A checkpoint holds EM's state, before any refinement: the objective is the command's.
  r.config.objective = btfgmm::parse_objective(
      o.options.objective.empty() ? "prediction" : o.options.objective, "--objective");
  return r;
}

// With --continue, the finished mixture's EM goes on to --iterations in all, from its stored
// parameters, on its data (the input, or the source its provenance records).
btfgmm::FitRequest continue_fit_request(const FitArguments& o) {
  check_fit_arguments(o, btfgmm::FitRoute::kContinue, o.continue_from);
  if (!o.has("iterations") || o.out.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("--continue {} needs --iterations N (the total number of EM "
                            "iterations, more than the model has run) and -o MODEL",
                            o.continue_from));
  btfgmm::FitRequest r =
      btfgmm::continue_request(o.continue_from, o.input, o.options.iterations, o.out);
  r.checkpoint = o.checkpoint;
  return r;
}

// A new fit, the interrupted one resumed (--resume), or a finished one continued
// (--continue); --iterations and --epsilon apply to each.
btfgmm::FitRequest fit_request(const FitArguments& o) {
  btfgmm::FitRequest r = !o.resume.empty()          ? resume_fit_request(o)
                         : !o.continue_from.empty() ? continue_fit_request(o)
                                                    : new_fit_request(o);
  if (r.resume && o.has("iterations")) r.config.em.max_iterations = o.options.iterations;
  if (r.resume && o.has("epsilon")) r.config.em.epsilon = *o.options.epsilon;
  // Resumed or continued: checked against the objective (a continuation's is its model's).
  if (r.resume) btfgmm::set_refinement_options(r.config, o.options);
  r.checkpoint_every = o.checkpoint_every;
  r.config.em.threads = o.options.threads;
  r.config.device = btfgmm::fit_device(o.options);
  r.config.em.stop = &g_stop;
  if (!r.made_tile.empty())  // resumed or continued: the made tile made again
    r.source = std::make_shared<const btfgmm::BtfSource>(
        btfgmm::made_tile_source(btfgmm::BtfSource::open(r.input), r.made_tile));
  return r;
}

// --tile X,Y,W,H or auto:WxH: the data is opened here for the search, and the fit reads it.
void choose_fit_tile(btfgmm::FitRequest& r, const std::string& tile, bool quiet) {
  if (r.resume || tile.empty()) return;  // a resume fits the checkpoint's tile
  btfgmm::BtfSource src = btfgmm::BtfSource::open(r.input);
  r.tile = tile_option(src, tile, quiet);
  r.source = std::make_shared<const btfgmm::BtfSource>(std::move(src));
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
  const int of = p.steps > 0 ? p.steps : p.max_steps;
  const std::string step =
      of > 0 ? fmt::format("step {}/{}", p.step, of) : fmt::format("step {}", p.step);
  // The time left, from the share done so far (the stopping rule may end the steps sooner).
  const std::string left = p.step > 0 && !last && p.fraction > 0.0
                               ? fmt::format(", at most about {} left",
                                             human_seconds(p.elapsed * (1.0 / p.fraction - 1.0)))
                               : std::string();
  fmt::print(stderr,
             "refining for the prediction: epoch {:>3} {:<12} held-out RMSE {:.3f} levels (lowest "
             "{:.3f}), "
             "training RMSE {}  {}{}\n",
             p.epoch, step, p.validation_rmse, p.best_validation_rmse,
             p.step > 0 ? fmt::format("{:.3f}", p.training_rmse) : std::string("(no step yet)"),
             human_seconds(p.elapsed), left);
}

// A colour refit under way, once it has taken 5 seconds and then every 5 seconds (a small
// one says nothing): its share done and the time left at its pace.
void print_colour_refit(const btfgmm::GradientProgress& p, double& printed_at) {
  if (p.elapsed < printed_at) printed_at = 0.0;  // the next refit
  if (p.elapsed < printed_at + 5.0 || p.fraction >= 1.0) return;
  printed_at = p.elapsed;
  fmt::print(stderr, "refining for the prediction: colour refit {:.0f} %, {}, about {} left\n",
             100.0 * p.fraction, human_seconds(p.elapsed),
             human_seconds(p.elapsed * (1.0 / std::max(p.fraction, 1e-9) - 1.0)));
}

// Where EM runs: "on the CPU" or "on the GPU NAME (Vulkan, DRIVER)".
std::string device_words(const btfgmm::FitPlan& p) {
  return p.device == "cpu" ? "on the CPU" : "on the GPU " + p.device;
}

// The refinement's bounds in words: "at most 2400 Adam steps (about 10 epochs of 237)".
std::string refinement_bounds(const btfgmm::FitPlan& p) {
  const std::size_t per_epoch = std::max<std::size_t>(p.refinement.steps_per_epoch, 1);
  std::string b;
  if (p.refinement_steps > 0)
    b = fmt::format("{} Adam steps (--refine-steps)", p.refinement_steps);
  else if (p.refinement_max_steps > 0)  // or the epochs' bound, where it ends them first
    b = fmt::format("at most {} Adam steps (about {:.{}f} epochs of {} steps)", p.refinement.steps,
                    double(p.refinement.steps) / double(per_epoch),
                    p.refinement.steps < 10 * std::int64_t(per_epoch) ? 1 : 0, per_epoch);
  else if (p.refinement_epochs > 0)
    b = fmt::format("at most {} epochs of {} Adam steps (--refine-epochs)", p.refinement_epochs,
                    per_epoch);
  if (p.refinement_seconds > 0)
    b += fmt::format(
        "{}at most {} (--refine-seconds: the model then depends on the machine and "
        "its load)",
        b.empty() ? "" : ", ", human_seconds(p.refinement_seconds));
  return b;
}

// What the refinement will take, timed on the mixture it starts from.
std::string refinement_time(const btfgmm::RefinementEstimate& e) {
  return fmt::format("about {} (a step {}, the colour refits {})", human_seconds(e.seconds),
                     human_seconds(e.step_seconds), human_seconds(e.colour_refit_seconds));
}

// What the fit will take, said before EM: where EM runs, its iterations at the time one
// takes (timed on a few lights from EM's start), then the refinement's bounds and time.
void print_plan(const btfgmm::FitPlan& p) {
  const double em = p.em_seconds;
  std::string refinement;
  if (p.refines) {
    refinement = fmt::format("; then the refinement for the prediction{}, {}, {}",
                             p.device == "cpu" ? ""
                                               : " (its steps and the colour refits' sums on "
                                                 "the GPU)",
                             refinement_bounds(p), refinement_time(p.refinement));
    if (p.refinement.colour_refit_seconds > std::max(em, 10.0))
      refinement += fmt::format(
          "; at M = {} the colour refits (their normal equations grow as M^2) take more than EM: "
          "fewer components (-M) cost far less",
          p.components);
  }
  fmt::print(stderr,
             "plan: EM {}, at most {} iterations of M = {}, the first about {} (timed on a few "
             "lights), later ones less: about {}{}; in all about {}\n",
             device_words(p), p.iterations, p.components, human_seconds(p.em_iteration_seconds),
             human_seconds(em), refinement,
             human_seconds(em + (p.refines ? p.refinement.seconds : 0.0)));
}

// Before the refinement: its time, timed again on EM's mixture.
void print_refinement_plan(const btfgmm::RefinementEstimate& e) {
  fmt::print(stderr,
             "refining for the prediction: at most {} Adam steps, {}; first the colour refit\n",
             e.steps, refinement_time(e));
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
  // The refinement for the prediction moves the parameters off EM's maximum: L falls.
  const char* after = fit.refinement ? "of the parameters written, after the refinement for the "
                                       "prediction, which trades L for the prediction's error"
                                     : "after the last M-step";
  fmt::print(stderr,
             "wrote {}: M = {} ({} dropped), L = {:.6f} {}{}, {} bytes, "
             "compression 1:{:.1f} (paper's count) / 1:{:.1f} (file), fit in {}\n",
             out, model.mixture.size(), model.settings.dropped, model.settings.log_likelihood,
             after, last, fit.file_bytes, model.compression_ratio_paper(),
             model.compression_ratio_file(fit.file_bytes), time);
  if (const auto& r = fit.refinement) {
    fmt::print(stderr,
               "refined for the prediction in {} Adam steps ({} epochs{}, {}): validation RMSE "
               "{:.3f} levels after EM, {:.3f} after the colour refit, {:.3f} in the model (on "
               "{} held-out samples); training RMSE {:.3f}\n",
               r->steps, r->epochs,
               r->timed_out     ? ", the time bound"
               : r->stopped     ? ", stopped"
               : r->step_bound  ? ", the step bound"
               : r->epoch_bound ? ", the epoch bound"
                                : "",
               human_seconds(r->seconds), btfgmm::prediction_rmse(r->error_em, r->samples),
               btfgmm::prediction_rmse(r->error_colour, r->samples),
               btfgmm::prediction_rmse(r->error_final, r->samples), r->samples, r->training_rmse);
  }
}

// `fit --log FILE`: opened once the fit starts, with the iterations of the fit it resumes or
// continues first.
std::optional<IterationLog> open_iteration_log(const FitArguments& o, const btfgmm::FitRequest& r) {
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

}  // namespace

void run_mixture_fit(const FitArguments& options,
                     const std::shared_ptr<btfgmm::Communicator>& processes) {
  FitArguments o = options;
  if (processes && processes->rank() != 0) {
    o.quiet = true;
    o.log.clear();  // process 0 writes the iteration log
  }
  btfgmm::FitRequest r = fit_request(o);
  r.processes = processes;
  const bool resumed = r.resume && !r.resume->finished_model;
  check_output_file(r.output, o.overwrite || resumed);
  if (!r.checkpoint.empty()) {
    check_output_file(r.checkpoint, true);
    check_checkpoint_apart(r.checkpoint, r.output, r.input);
  }
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
  if (!o.quiet) {
    observer.planned = print_plan;
    observer.refinement_planned = print_refinement_plan;
  }
  observer.iteration = [&](const btfgmm::EmProgress& p) {
    if (!o.quiet) print_iteration(p, start);
    if (log) log->add({p.log_likelihood, p.seconds, std::uint32_t(p.components)});
  };
  double printed_at = 0.0;
  double refit_printed_at = 0.0;
  observer.refinement = [&](const btfgmm::GradientProgress& p) {
    if (o.quiet) return;
    if (p.colour_refit)
      print_colour_refit(p, refit_printed_at);
    else
      print_refinement(p, printed_at);
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

}  // namespace btfgmm::cli
