// btfgmm fit: the arguments parsed, and the fit they ask for: the Gaussian mixture's
// (fit_mixture.cpp), another method's, or the best within a budget (fit_budget.cpp).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/neural_btf_checkpoint.hpp"
#include "budget_fit.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "fit_command.hpp"
#include "mpi_processes.hpp"
#include "parameter_options.hpp"
#include "stop_signals.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {

bool FitArguments::has(std::string_view field) const {
  return std::find(fields.begin(), fields.end(), field) != fields.end();
}

void check_fit_arguments(const FitArguments& o, btfgmm::FitRoute route, std::string_view source) {
  try {
    btfgmm::check_fit_options(o.options, o.fields, route, source);
  } catch (const Error& e) {
    throw spelled_as_given(e, o.given);  // "-M/--components", as given
  }
}

namespace {

// ---- fit --method: any other method ------------------------------------------------------

// Where a fit stopped by the user kept its best model met (provenance.hpp, kStoppedSetting):
// the note it recorded; empty for a whole fit.
std::string stopped_note(const btfgmm::Representation& r) {
  for (const auto& [name, value] : r.provenance().fit.settings)
    if (name == btfgmm::kStoppedSetting) return value;
  return {};
}

// Runs `fit` with SIGINT and SIGTERM asking it to stop; a fit stopped without a model (every
// method's but the neural BTF's) ends the command: `out` is not written.
template <class Fit>
std::unique_ptr<btfgmm::Representation> fit_until_stopped(const std::string& out, const Fit& fit) {
  const StopOnSignals stop_on_signals;
  try {
    return fit();
  } catch (const Error& e) {
    if (!g_stop.load() || e.kind() == Error::Kind::kIo) throw;  // a failed save is said
    fmt::print(stderr, "interrupted: {} was not written\n", out);
    std::exit(130);
  }
}

// What a fit tells as it goes: the tile loaded, then the method's stages.
btfgmm::FitProgress method_progress(const FitArguments& o, std::string_view method,
                                    Clock::time_point t0) {
  btfgmm::FitProgress progress;
  if (!o.quiet) {
    progress.started = [t0](const btfgmm::FitTile& t) { print_loaded(t, seconds_since(t0)); };
    progress.progress = [method = std::string(method)](double fraction, std::string_view stage) {
      fmt::print(stderr, "{} {:>5.1f}%  {}\n", method, 100.0 * fraction, stage);
    };
  }
  progress.stop = &g_stop;
  return progress;
}

// " on the GPU NAME" where the model's fit ran on a compute device, as its provenance says.
std::string fit_device_words(const btfgmm::Representation& r) {
  for (const auto& [name, value] : r.provenance().fit.settings)
    if (name == btfgmm::kDeviceSetting && value != "cpu") return " on the GPU " + value;
  return "";
}

// Writes the model of a method's fit to `out` and says what it is; a fit stopped by the user
// that kept its best model met exits 130 (`state`: where it saved the state to go on from). A
// whole fit removes the state (a stale one of an earlier stop) and the checkpoint it was named.
void write_method_model(const FitArguments& o, const std::string& out,
                        const btfgmm::Representation& r, const std::string& state,
                        const std::string& checkpoint) {
  const double fit_seconds = r.provenance().fit.seconds;
  const std::uint64_t bytes = btfgmm::save_representation(r, out);
  const std::string stopped = stopped_note(r);
  if (stopped.empty()) {  // a whole fit's model: no state to go on from is left behind
    std::error_code ec;
    for (const std::string& path : {state, checkpoint})
      if (!path.empty()) std::filesystem::remove(path, ec);
  }
  if (!stopped.empty() || g_stop.load()) {
    // The model is written, whole, but not the whole fit's (a fit that kept its best model
    // met) or after a stop asked for as it ended: said even with --quiet.
    if (stopped.empty())
      fmt::print(stderr, "interrupted as the fit ended: {} holds its whole model\n", out);
    else if (!state.empty())
      fmt::print(stderr,
                 "interrupted {}: {} holds that model and is complete; the fit's state is in "
                 "{}\ncontinue with: btfgmm fit --resume {}\n",
                 stopped, out, state, state);
    else
      fmt::print(stderr,
                 "interrupted {}: {} holds that model and is complete; fit again for the whole "
                 "fit\n",
                 stopped, out);
    std::exit(130);
  }
  if (o.quiet) return;
  fmt::print(stderr,
             "wrote {}: {} {}, {} values, {} bytes, compression 1:{:.1f} (paper's count) / "
             "1:{:.1f} (file), fit in {}{}\n",
             out, r.method(), r.size_text(), r.parameter_count(), bytes, r.paper_ratio(),
             r.file_ratio(bytes), human_seconds(fit_seconds), fit_device_words(r));
}

// The neural BTF's fit with checkpoints: new, or resumed from `resume`; its state saved to
// `state` when stopped, and every --checkpoint-every epochs where --checkpoint names it.
std::unique_ptr<btfgmm::Representation> fit_neural_job(
    const FitArguments& o, std::shared_ptr<const btfgmm::BtfSource> src, const btfgmm::Tile& tile,
    const btfgmm::NeuralCheckpoint* resume, const std::string& state, Clock::time_point t0) {
  const btfgmm::NeuralFitJob job{.options = o.options,
                                 .input = o.input,
                                 .output = o.out,
                                 .tile = tile,
                                 .checkpoint = state,
                                 .every_epochs = o.checkpoint.empty() ? 0 : o.checkpoint_every,
                                 .resume = resume};
  return fit_until_stopped(resume ? resume->output : o.out, [&] {
    return btfgmm::fit_neural_job(job, std::move(src), method_progress(o, "neural", t0));
  });
}

void run_method_fit(const FitArguments& o) {
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument, "fit needs an input BTF and -o MODEL");
  check_fit_arguments(o, btfgmm::FitRoute::kNew);  // before any work
  check_output_file(o.out, o.overwrite);
  const auto t0 = Clock::now();
  btfgmm::BtfSource data = btfgmm::BtfSource::open(o.input);
  const btfgmm::Tile tile = o.tile.empty() ? btfgmm::Tile{} : tile_option(data, o.tile, o.quiet);
  auto src = std::make_shared<const btfgmm::BtfSource>(std::move(data));
  // A method whose declarations take a checkpoint (the neural BTF's) saves its state when
  // stopped: to --checkpoint, else MODEL.ckpt, as the mixture's fit does.
  const bool saves_state =
      btfgmm::method_parameter(btfgmm::find_method(o.options.method), "checkpoint") != nullptr;
  const std::string state = !saves_state           ? std::string()
                            : o.checkpoint.empty() ? o.out + ".ckpt"
                                                   : o.checkpoint;
  if (!state.empty()) {
    check_output_file(state, true);
    check_checkpoint_apart(state, o.out, o.input);
  }
  const std::unique_ptr<btfgmm::Representation> r =
      !saves_state ? fit_until_stopped(o.out,
                                       [&] {
                                         return btfgmm::fit_representation(
                                             o.options, o.input, std::move(src), tile,
                                             method_progress(o, o.options.method, t0));
                                       })
                   : fit_neural_job(o, std::move(src), tile, nullptr, state, t0);
  write_method_model(o, o.out, *r, state, o.checkpoint);
}

// fit --resume of a neural fit's checkpoint: its input, tile, settings and output (--iterations
// the epochs in all); the checkpoint keeps the state unless --checkpoint names another.
void run_neural_resume(const FitArguments& given) {
  btfgmm::NeuralCheckpoint k = btfgmm::load_neural_checkpoint(given.resume);
  FitArguments o = given;
  o.options.method = "neural";
  check_fit_arguments(o, btfgmm::FitRoute::kResume, o.resume);
  // --iterations N: the epochs in all, as the mixture's resume takes it.
  if (o.has("iterations")) {
    if (o.options.iterations < k.state.epoch + 1)
      throw Error(Error::Kind::kArgument,
                  fmt::format("{} {}: the fit in '{}' stands in epoch {}; give at least {} (the "
                              "epochs in all, not those to add)",
                              command_line_option("iterations"), o.options.iterations, o.resume,
                              k.state.epoch + 1, k.state.epoch + 1));
    k.options.iterations = o.options.iterations;
  }
  const std::string checkpoint = o.checkpoint.empty() ? o.resume : o.checkpoint;
  check_output_file(checkpoint, true);
  check_output_file(k.output, true);  // the model a stopped fit wrote is its to replace
  check_checkpoint_apart(checkpoint, k.output, k.input);
  if (!o.quiet)
    fmt::print(stderr, "resuming from {} at step {} of epoch {}\n", o.resume, k.state.steps_done,
               k.state.epoch + 1);
  o.checkpoint = checkpoint;  // saved every --checkpoint-every epochs, removed at the end
  std::unique_ptr<btfgmm::Representation> r;
  try {
    std::shared_ptr<const btfgmm::BtfSource> made;  // a made tile, made again
    if (!k.made_from.empty())
      made = std::make_shared<const btfgmm::BtfSource>(
          btfgmm::made_tile_source(btfgmm::BtfSource::open(k.input), k.made_from));
    r = fit_neural_job(o, made, {}, &k, checkpoint, Clock::now());
  } catch (const Error& e) {
    if (e.kind() != Error::Kind::kFormat) throw;
    throw Error(e.kind(), fmt::format("checkpoint '{}': {}", o.resume, e.what()));
  }
  write_method_model(o, k.output, *r, checkpoint, checkpoint);
}

// With --budget or --ratio, the method and size are chosen (fit_budget.cpp): the options that
// set them, or belong to one method's fit, are errors.
void run_fit_within_budget(const FitArguments& o) {
  const char* budget = o.given.count("--budget") ? "budget" : "ratio";
  if (o.given.count("--budget") && o.given.count("--ratio"))
    throw Error(Error::Kind::kArgument,
                "--budget and --ratio both set the budget; give one of them");
  if (const auto processes = job_processes(); processes && processes->size() > 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("fit {} runs in one process; start it without mpirun",
                            command_line_option(budget)));
  try {
    run_budget_fit(o);
  } catch (const Error& e) {
    throw spelled_as_given(e, o.given);
  }
}

// An MPI job (mpirun) fits the mixture over its processes; an error in one ends them all.
void run_fit_command(const FitArguments& o) {
  if (o.given.count("--budget") || o.given.count("--ratio")) return run_fit_within_budget(o);
  const bool neural_resume = !o.resume.empty() && btfgmm::is_neural_checkpoint_file(o.resume);
  const std::shared_ptr<btfgmm::Communicator> processes = job_processes();
  if (o.options.method != btfgmm::kMixtureMethod || neural_resume) {
    if (processes && processes->size() > 1)
      throw Error(Error::Kind::kArgument,
                  fmt::format("--method {} runs in one process; start it without mpirun (only "
                              "the Gaussian mixture's EM is split over processes)",
                              neural_resume ? "neural" : o.options.method));
    return neural_resume ? run_neural_resume(o) : run_method_fit(o);
  }
  if (!processes || processes->size() == 1) return run_mixture_fit(o, processes);
  try {
    run_mixture_fit(o, processes);
  } catch (const std::exception& e) {
    fmt::print(stderr,
               "btfgmm: error: process {} of {}: {}\nbtfgmm: ending every process of "
               "the job; a checkpoint already written is whole (continue with fit --resume)\n",
               processes->rank(), processes->size(), command_line_text(e.what()));
    end_job_on_error(1);
    throw;
  }
}

// ---- the subcommands ---------------------------------------------------------------------

// The range a job option's declaration gives (methods/parameters.hpp), in the type the command
// parses it as.
template <typename T>
CLI::Range declared_range(std::string_view field) {
  const btfgmm::FitParameter* p = btfgmm::find_fit_parameter(field);
  return CLI::Range(T(p->min), T(p->max));
}

// The methods whose size fit --budget predicts from short fits (MethodInfo::quick_search).
std::string quick_search_methods() {
  std::vector<std::string_view> names;
  for (const btfgmm::MethodInfo& m : btfgmm::all_methods())
    if (m.quick_search.probe) names.push_back(m.name);
  return fmt::format("{}", fmt::join(names, " and "));
}

// --method's help: every method with its paper.
std::string method_help() {
  std::string h = "The representation to fit:";
  for (const btfgmm::MethodInfo& m : btfgmm::all_methods())
    h += fmt::format("\n  {:<8} {} ({})", m.name, m.title, m.citation);
  return h;
}

// The options of the fit itself: a budget instead of a method, the output, the mixture's
// checkpoints, resuming and continuing, its log, and what is printed.
void add_budget_and_run_options(CLI::App& app, FitArguments& a) {
  CLI::App* f = &app;
  auto* fit = &a;
  f->add_option("--budget", fit->budget,
                "Choose the method and size that decode the tile best (PSNR) within this many "
                "bytes of model file; prints the candidates tried")
      ->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 50));
  f->add_option("--ratio", fit->ratio,
                "As --budget, with the budget the tile's data bytes (a byte a value) over R")
      ->check(CLI::Range(1.0, 1e9));
  f->add_flag("--exhaustive", fit->exhaustive,
              fmt::format("With --budget or --ratio: fit every size the search tries in full, as "
                          "sweep does, also those of {} (whose size is otherwise predicted from "
                          "short fits and only the one chosen fitted in full): slower, for "
                          "comparison",
                          quick_search_methods()));
  f->add_option("-o,--output", fit->out, "The model file to write (.btfgmm)");
  f->add_option("--checkpoint", fit->checkpoint,
                "Save the fit's state here (atomically) every --checkpoint-every iterations (the "
                "neural BTF: epochs) and on SIGINT/SIGTERM; removed when the model is written "
                "(gm and neural)");
  f->add_option("--checkpoint-every", fit->checkpoint_every,
                "EM iterations (the neural BTF: epochs) between checkpoints")
      ->check(declared_range<int>("checkpoint_every"))
      ->capture_default_str();
  f->add_option("--resume", fit->resume,
                "Continue an interrupted fit from its checkpoint (input, tile, settings and "
                "output come from it; --iterations N goes on to N iterations, or the neural BTF's "
                "epochs, in all); the model equals an uninterrupted fit's, bit for bit")
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
}

}  // namespace

void register_fit_command(CLI::App& app, Commands& commands) {
  auto fit = std::make_shared<FitArguments>();
  auto texts = std::make_shared<std::map<std::string, std::string>>();
  auto* f = app.add_subcommand(
      "fit", "Fit a model to a BTF tile: the Gaussian mixture (default) or another method");
  f->add_option("input", fit->input, "A BTF folder, Bonn .zip or Bonn .btf file");
  f->add_option(
      "--tile", fit->tile,
      fmt::format("X,Y,W,H of the tile to fit, or {} (default: the whole image)", kAutoTileHelp));
  add_parameter_options(*f, btfgmm::FitRoute::kNew, *texts, method_help());
  add_budget_and_run_options(*f, *fit);

  commands.push_back({f, [fit, texts, f] {
                        fit->given = given_options(*f);
                        fit->fields = read_parameters(fit->given, *texts, fit->options,
                                                      btfgmm::FitRoute::kNew);
                        run_fit_command(*fit);
                      }});
}

}  // namespace btfgmm::cli
