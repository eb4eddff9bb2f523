// btfgmm fit: the arguments parsed, and the fit they ask for: the Gaussian mixture's
// (fit_mixture.cpp), another method's, or the best within a budget (fit_budget.cpp).
#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <memory>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "budget_fit.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "fit_command.hpp"
#include "mpi_processes.hpp"
#include "tile_option.hpp"

namespace btfgmm::cli {

std::vector<std::string_view> given_fields(const FitArguments& o) {
  std::vector<std::string_view> fields;
  for (const btfgmm::FitOptionRule& rule : btfgmm::fit_option_rules())
    if (o.given.count(command_line_option(rule.field))) fields.push_back(rule.field);
  return fields;
}

void check_fit_arguments(const FitArguments& o, btfgmm::FitRoute route, std::string_view source) {
  try {
    btfgmm::check_fit_options(given_fields(o), o.method, route, source);
  } catch (const Error& e) {
    // The options refused, named as they go on the command line ("-M/--components").
    throw Error(e.kind(), btfgmm::spell_options(e.what(), [&](std::string_view field) {
                  const std::string flag = command_line_option(field);
                  const auto it = o.given.find(flag);
                  return it != o.given.end() ? it->second : flag;
                }));
  }
}

btfgmm::FitOptions library_options(const FitArguments& o) {
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
  if (o.given.count("--device")) f.device = o.device;
  f.precision = o.precision;
  f.objective = o.objective;
  f.refine_steps = o.refine_steps;
  f.refine_seconds = o.refine_seconds;
  f.refine_epochs = o.refine_epochs;
  return f;
}

namespace {

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

// ---- fit --method: any other method ------------------------------------------------------

// Options of the mixture's EM that another method cannot use are errors, never ignored.
void check_method_options(const FitArguments& o) {
  check_fit_arguments(o, btfgmm::FitRoute::kNew);
  if (o.input.empty() || o.out.empty())
    throw Error(Error::Kind::kArgument, "fit needs an input BTF and -o MODEL");
}

void run_method_fit(const FitArguments& o) {
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

// With --budget or --ratio, the method and size are chosen (fit_budget.cpp): the options that
// set them, or belong to one method's fit, are errors.
void run_fit_within_budget(const FitArguments& o) {
  const char* budget = o.given.count("--budget") ? "budget" : "ratio";
  if (o.given.count("--budget") && o.given.count("--ratio"))
    throw Error(Error::Kind::kArgument,
                "--budget and --ratio both set the budget; give one of them");
  check_fit_arguments(o, btfgmm::FitRoute::kBudget, budget);
  if (const auto processes = job_processes(); processes && processes->size() > 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("fit {} runs in one process; start it without mpirun",
                            command_line_option(budget)));
  run_budget_fit({.input = o.input,
                  .out = o.out,
                  .tile = o.tile,
                  .budget = o.budget,
                  .ratio = o.ratio,
                  .seed = o.seed,
                  .threads = o.threads,
                  .iterations = o.iterations,
                  .refine_seconds = o.refine_seconds,
                  .refine_epochs = o.refine_epochs,
                  .overwrite = o.overwrite,
                  .quiet = o.quiet});
}

// An MPI job (mpirun) fits the mixture over its processes; an error in one ends them all.
void run_fit_command(const FitArguments& o) {
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
               processes->rank(), processes->size(), command_line_text(e.what()));
    end_job_on_error(1);
    throw;
  }
}

// ---- the subcommands ---------------------------------------------------------------------

// The range the table gives an option of the fit (methods/fit_options.hpp), in the type the
// command parses it as.
template <typename T>
CLI::Range table_range(std::string_view field) {
  const btfgmm::FitOptionRule& rule = btfgmm::fit_option_rule(field);
  return CLI::Range(T(rule.min), T(rule.max));
}

// The methods that take an option of the fit, by the table: "3d-car, 2d-car, gmrf".
std::string methods_of(std::string_view field) {
  std::vector<std::string_view> names;
  for (const btfgmm::MethodInfo& m : btfgmm::all_methods())
    if (btfgmm::fit_option_rule(field).takes(m.name)) names.push_back(m.name);
  return fmt::format("{}", fmt::join(names, ", "));
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
  f->add_option("-o,--output", fit->out, "The model file to write (.btfgmm)");
  f->add_option("--checkpoint", fit->checkpoint,
                "Save the fit's state here (atomically) every --checkpoint-every iterations and "
                "on SIGINT/SIGTERM; removed when the model is written");
  f->add_option("--checkpoint-every", fit->checkpoint_every, "Iterations between checkpoints")
      ->check(table_range<int>("checkpoint_every"))
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

// The mixture's objective and its refinement's bounds.
void add_refinement_options(CLI::App& f, FitArguments& fit) {
  f.add_option("--objective", fit.objective,
               methods_of("objective") +
                   ": prediction (default: EM, then the mixture refined for the prediction's "
                   "error, Eq. 8-11: the colour means by least squares, gradient steps on every "
                   "parameter, the colour means again) or likelihood (the paper's EM alone, "
                   "exactly)");
  f.add_option("--refine-steps", fit.refine_steps,
               methods_of("refine_steps") +
                   ", --objective prediction: exactly this many Adam steps of the refinement "
                   "(default: until the error on the held-out samples stops falling, at most " +
                   fmt::to_string(btfgmm::kDefaultRefineSteps) + ", docs/ALGORITHM.md)")
      ->check(table_range<int>("refine_steps"));
  f.add_option("--refine-seconds", fit.refine_seconds,
               methods_of("refine_seconds") +
                   ", --objective prediction: the most seconds the refinement takes, in place of "
                   "the default bound in steps; the lowest held-out error met is kept. The model "
                   "then depends on the machine and its load (its provenance says so)")
      ->check(table_range<double>("refine_seconds"));
  f.add_option("--refine-epochs", fit.refine_epochs,
               methods_of("refine_epochs") +
                   ", --objective prediction: the most passes over the tile's samples the "
                   "refinement takes, in place of the default bound in steps (default: at most " +
                   fmt::to_string(btfgmm::kDefaultRefineSteps) +
                   " steps); with --budget, of each mixture it fits")
      ->check(table_range<int>("refine_epochs"));
}

}  // namespace

void register_fit_command(CLI::App& app, Commands& commands) {
  auto fit = std::make_shared<FitArguments>();
  auto* f = app.add_subcommand(
      "fit", "Fit a model to a BTF tile: the Gaussian mixture (default) or another method");
  f->add_option("input", fit->input, "A BTF folder or Bonn .zip");
  f->add_option("--tile", fit->tile,
                "X,Y,W,H of the tile to fit, or auto:WxH for the most seamless tile of that size "
                "(default: the whole image)");
  f->add_option("--method", fit->method, method_help())->capture_default_str();
  f->add_option("--components,-M", fit->components,
                fmt::format("The model's size: mixture components M (gm, default {}), "
                            "eigen-images c (pca-btf, pca-rf) or components per cluster (lpca); "
                            "default: the method's",
                            btfgmm::FitConfig{}.components))
      ->check(table_range<std::size_t>("components"));
  f->add_option("--clusters", fit->clusters,
                methods_of("clusters") +
                    ": the number of clusters k (lpca) or of BTF subspaces c (the others)")
      ->check(table_range<std::size_t>("clusters"));
  f->add_option("--degree", fit->degree,
                methods_of("degree") + ": the degree of the per-image polynomial")
      ->check(table_range<std::size_t>("degree"));
  f->add_option("--iterations", fit->iterations,
                fmt::format("Maximum EM iterations (gm, default {}; with --resume or --continue, "
                            "the total to go on to), re-assignment rounds (lpca) or "
                            "Levenberg-Marquardt steps (plm-rf)",
                            btfgmm::EmConfig{}.max_iterations))
      ->check(table_range<int>("iterations"));
  f->add_option("--levels", fit->levels,
                methods_of("levels") +
                    ": levels K of each subspace image's Gaussian-Laplacian pyramid, a model "
                    "each (default 3, or as many as the tile holds with the coarsest level at "
                    "least 8 x 8 pixels)")
      ->check(table_range<int>("levels"));
  f->add_option("--epsilon", fit->epsilon, "Stop when the relative gain of L is below this")
      ->check(table_range<double>("epsilon"))
      ->capture_default_str();
  f->add_option("--seed", fit->seed, "Seed of the random initialisation")->capture_default_str();
  add_refinement_options(*f, *fit);
  f->add_option("--threads", fit->threads,
                "Threads (0: all cores; the model does not depend "
                "on it)")
      ->check(table_range<int>("threads"))
      ->capture_default_str();
  f->add_option("--device", fit->device,
                methods_of("device") +
                    ": where EM runs: auto (a GPU where one exists, else the CPU), cpu, or gpu "
                    "(a GPU, else a software Vulkan such as lavapipe; docs/GPU.md)")
      ->check(CLI::IsMember({"auto", "cpu", "gpu"}))
      ->capture_default_str();
  f->add_option("--precision", fit->precision,
                "gm: compact (default: each parameter quantised with a stated step, zstd; "
                "docs/FORMAT.md), f32 (exact, for --continue to match one longer fit) or f16; "
                "other methods: compact (default: quantised with a step per component, predicted "
                "from neighbouring pixels or directions, zstd), f32, f16 or q8 (8 bits with an "
                "offset and scale per component); 3d-car, 2d-car, gmrf: the range map's (f16 "
                "default; their few model "
                "parameters are always f32)");
  add_budget_and_run_options(*f, *fit);

  commands.push_back({f, [fit, f] {
                        fit->given = given_options(*f);
                        run_fit_command(*fit);
                      }});
}

}  // namespace btfgmm::cli
