// btfgmm fit: the arguments parsed, and the fit they ask for: the Gaussian mixture's
// (fit_mixture.cpp), another method's, or the best within a budget (fit_budget.cpp).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <map>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/fit_options.hpp"
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

void run_method_fit(const FitArguments& o) {
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument, "fit needs an input BTF and -o MODEL");
  check_fit_arguments(o, btfgmm::FitRoute::kNew);  // before any work
  check_output_file(o.out, o.overwrite);
  const auto t0 = Clock::now();
  auto src = std::make_shared<const btfgmm::BtfSource>(btfgmm::BtfSource::open(o.input));
  const btfgmm::Tile tile = o.tile.empty() ? btfgmm::Tile{} : tile_option(*src, o.tile, o.quiet);
  btfgmm::FitProgress progress;
  if (!o.quiet) {
    progress.started = [&](const btfgmm::FitTile& t) { print_loaded(t, seconds_since(t0)); };
    progress.progress = [&](double fraction, std::string_view stage) {
      fmt::print(stderr, "{} {:>5.1f}%  {}\n", o.options.method, 100.0 * fraction, stage);
    };
  }
  progress.stop = &g_stop;
  std::unique_ptr<btfgmm::Representation> r;
  {
    const StopOnSignals stop_on_signals;
    try {
      r = btfgmm::fit_representation(o.options, o.input, std::move(src), tile, progress);
    } catch (const Error&) {
      if (!g_stop.load()) throw;
      fmt::print(stderr, "interrupted: {} was not written\n", o.out);
      std::exit(130);
    }
  }
  const double fit_seconds = r->provenance().fit.seconds;
  const std::uint64_t bytes = btfgmm::save_representation(*r, o.out);
  if (const std::string stopped = stopped_note(*r); !stopped.empty() || g_stop.load()) {
    // The model is written, whole, but not the whole fit's (a fit that kept its best model
    // met) or after a stop asked for as it ended: said even with --quiet.
    if (stopped.empty())
      fmt::print(stderr, "interrupted as the fit ended: {} holds its whole model\n", o.out);
    else
      fmt::print(stderr,
                 "interrupted {}: {} holds that model and is complete; fit again for the whole "
                 "fit\n",
                 stopped, o.out);
    std::exit(130);
  }
  if (o.quiet) return;
  fmt::print(stderr,
             "wrote {}: {} {}, {} values, {} bytes, compression 1:{:.1f} (paper's count) / "
             "1:{:.1f} (file), fit in {}\n",
             o.out, o.options.method, r->size_text(), r->parameter_count(), bytes, r->paper_ratio(),
             r->file_ratio(bytes), human_seconds(fit_seconds));
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
  const std::shared_ptr<btfgmm::Communicator> processes = job_processes();
  if (o.options.method != btfgmm::kMixtureMethod) {
    if (processes && processes->size() > 1)
      throw Error(Error::Kind::kArgument,
                  fmt::format("--method {} runs in one process; start it without mpirun (only "
                              "the Gaussian mixture's EM is split over processes)",
                              o.options.method));
    return run_method_fit(o);
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
                "Save the fit's state here (atomically) every --checkpoint-every iterations and "
                "on SIGINT/SIGTERM; removed when the model is written");
  f->add_option("--checkpoint-every", fit->checkpoint_every, "Iterations between checkpoints")
      ->check(declared_range<int>("checkpoint_every"))
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
}

}  // namespace

void register_fit_command(CLI::App& app, Commands& commands) {
  auto fit = std::make_shared<FitArguments>();
  auto texts = std::make_shared<std::map<std::string, std::string>>();
  auto* f = app.add_subcommand(
      "fit", "Fit a model to a BTF tile: the Gaussian mixture (default) or another method");
  f->add_option("input", fit->input, "A BTF folder or Bonn .zip");
  f->add_option("--tile", fit->tile,
                "X,Y,W,H of the tile to fit, or auto:WxH for the most seamless tile of that size "
                "(default: the whole image)");
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
