// The fit's parameters as a command's options, made from the methods' declarations
// (btfgmm/methods/parameters.hpp): `fit` and `sweep` take them so, each value read into the
// library's options and checked by the library.
#pragma once

#include <CLI/CLI.hpp>

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/methods/fit_options.hpp"
#include "cli_util.hpp"

namespace btfgmm::cli {

// An option of `app` for each parameter FitOptions holds that some method takes with `route`:
// the flag from its field (--refine-steps; -M too for --components), the help from its
// declarations (parameter_help; `method_help` for --method), the text given kept in `texts`.
void add_parameter_options(CLI::App& app, btfgmm::FitRoute route,
                           std::map<std::string, std::string>& texts,
                           const std::string& method_help = {});

// The options given to `app`, by long name ("--components"), each with the names it goes by
// ("-M/--components") for messages.
std::map<std::string, std::string> given_options(const CLI::App& app);

// A library error with the options it names spelled as they were given (`given`, as
// given_options: "-M/--components"), the others as flags.
Error spelled_as_given(const Error& e, const std::map<std::string, std::string>& given);

// The parameters given (`given`: by long flag) read from `texts` into `options` (parsed and
// checked as declared: btfgmm::set_parameter); returns the fields of the parameters given and,
// for `fit` (`route` kNew), of its job's options a declaration names (the output, the
// checkpoints), in the declarations' order.
std::vector<std::string_view> read_parameters(const std::map<std::string, std::string>& given,
                                              const std::map<std::string, std::string>& texts,
                                              btfgmm::FitOptions& options, btfgmm::FitRoute route);

}  // namespace btfgmm::cli
