// Usage help beyond CLI11's: the overview a bare `btfgmm` prints, and the nearest name for a
// mistyped command or option (CLI11 only says that an argument was not expected).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

namespace btfgmm::cli {

// The command's help (its commands listed) and an example, on stdout.
void print_overview(const CLI::App& app);

// For a command line CLI11 refused: the message naming a mistyped command or an unknown option
// (and the nearest known name), or empty when the refusal is about something else.
std::string mistyped_name(const CLI::App& app, int argc, const char* const* argv);

// For a number CLI11 refused as out of its range (or not a number at all): the option, the
// value and the range allowed in btfgmm's words; empty for any other refusal.
std::string out_of_range(const CLI::ParseError& err);

}  // namespace btfgmm::cli
