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

// The fit's command-line arguments: the fit's parameters, read straight into the library's
// options (their flags and help made from the methods' declarations, methods/parameters.hpp),
// and the options of the job itself (its files, checkpoints, log, budget, what is printed).
struct FitArguments {
  std::string input, out, tile;
  btfgmm::FitOptions options;
  bool overwrite = false, quiet = false;
  std::string checkpoint, resume, continue_from, log;
  int checkpoint_every = 1;
  std::uint64_t budget = 0;  // --budget BYTES (0: none)
  double ratio = 0.0;        // --ratio R (0: none)
  bool exhaustive = false;   // --exhaustive: every size tried fitted in full
  // The options given on the command line, by long name ("--components"), each with the
  // names it goes by ("-M/--components") for messages; and by field, in the declarations'
  // order (the parameters and the job's options alike).
  std::map<std::string, std::string> given;
  std::vector<std::string_view> fields;
  bool has(std::string_view field) const;
};

// The library's one check of the options given (btfgmm::check_fit_options), its message with
// the options named as they were given ("-M/--components"). Options that cannot apply to what
// the fit does (`route`, from `source`) are errors, never ignored.
void check_fit_arguments(const FitArguments& o, btfgmm::FitRoute route,
                         std::string_view source = {});

void print_loaded(const btfgmm::FitTile& t, double seconds);

// The mixture's fit, in this process alone or as one of `processes` (only process 0 prints
// and writes files).
void run_mixture_fit(const FitArguments& options,
                     const std::shared_ptr<btfgmm::Communicator>& processes);

}  // namespace btfgmm::cli
