// The fit command's arguments and its stages: cmd_fit.cpp parses them and chooses the fit,
// fit_mixture.cpp runs the Gaussian mixture's (resumed, continued, over MPI processes),
// fit_budget.cpp the fit within a budget.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/core/communicator.hpp"
#include "btfgmm/methods/fit_options.hpp"

namespace btfgmm::cli {

// The fit's command-line arguments (the library's settings: btfgmm::FitOptions).
struct FitArguments {
  std::string input, out, tile, precision, method = "gm", objective;
  std::size_t components = 0, clusters = 0, degree = 0;  // 0: the method's default
  int iterations = 0;                                    // 0: the method's default
  int levels = 0;                                        // 0: the method's default
  int refine_steps = 0;                                  // 0: until converged
  double refine_seconds = 0.0;                           // 0: the default bound
  int refine_epochs = 0;                                 // 0: bounded in time
  double epsilon = 0.0;
  std::uint64_t seed = 1;
  int threads = 0;
  std::string device = "auto";  // where EM runs: auto, cpu or gpu
  bool overwrite = false, quiet = false;
  std::string checkpoint, resume, continue_from, log;
  int checkpoint_every = 1;
  std::uint64_t budget = 0;  // --budget BYTES (0: none)
  double ratio = 0.0;        // --ratio R (0: none)
  // The options given on the command line, by long name ("--components"), each with the
  // names it goes by ("-M/--components") for messages.
  std::map<std::string, std::string> given;
};

// The options given, by the fields the library names them (methods/fit_options.hpp).
std::vector<std::string_view> given_fields(const FitArguments& o);

// Options that cannot apply to what the fit does (`route`, from `source`) are errors, never
// ignored: the library's one check of the options given (btfgmm::check_fit_options).
void check_fit_arguments(const FitArguments& o, btfgmm::FitRoute route,
                         std::string_view source = {});

// The settings of the fit as the library takes them (btfgmm/methods/fit_options.hpp).
btfgmm::FitOptions library_options(const FitArguments& o);

void print_loaded(const btfgmm::FitTile& t, double seconds);

// The mixture's fit, in this process alone or as one of `processes` (only process 0 prints
// and writes files).
void run_mixture_fit(const FitArguments& options,
                     const std::shared_ptr<btfgmm::Communicator>& processes);

}  // namespace btfgmm::cli
