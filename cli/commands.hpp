// The btfgmm subcommands. Each registers itself on the app with the action to run when it was
// chosen; main() parses and runs it.
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

// One command a file: cmd_NAME.cpp registers the command NAME.
void register_generate_command(CLI::App& app, Commands& commands);
void register_info_command(CLI::App& app, Commands& commands);
void register_fit_command(CLI::App& app, Commands& commands);
void register_decode_command(CLI::App& app, Commands& commands);
void register_eval_command(CLI::App& app, Commands& commands);
void register_compare_command(CLI::App& app, Commands& commands);
void register_render_command(CLI::App& app, Commands& commands);
void register_tile_command(CLI::App& app, Commands& commands);
void register_sweep_command(CLI::App& app, Commands& commands);
void register_view_command(CLI::App& app, Commands& commands);
void register_export_shader_command(CLI::App& app, Commands& commands);
void register_rangemap_command(CLI::App& app, Commands& commands);
void register_convert_command(CLI::App& app, Commands& commands);

}  // namespace btfgmm::cli
