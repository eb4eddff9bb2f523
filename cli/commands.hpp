// The btfgmm subcommands. Each group registers its subcommands on the app and the action to
// run when one of them was chosen; main() parses and runs it.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <vector>

namespace btfgmm::cli {

struct Command {
  CLI::App* app;
  std::function<void()> run;
};
using Commands = std::vector<Command>;

void register_data_commands(CLI::App& app, Commands& commands);     // generate, info
void register_model_commands(CLI::App& app, Commands& commands);    // fit, decode, eval
void register_compare_commands(CLI::App& app, Commands& commands);  // compare
void register_render_commands(CLI::App& app, Commands& commands);   // render, tile
void register_sweep_commands(CLI::App& app, Commands& commands);    // sweep
void register_view_commands(CLI::App& app, Commands& commands);     // view, export-shader
void register_texture_commands(CLI::App& app, Commands& commands);  // rangemap
void register_convert_commands(CLI::App& app, Commands& commands);  // convert

}  // namespace btfgmm::cli
