// btfgmm: the command-line tool. A thin layer over the library: it parses options, calls the
// library, and formats what comes back. Errors from the library carry the file and the fix;
// they are printed as "btfgmm: error: ..." with exit status 1 (2 for bad usage).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "btfgmm/core/error.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "usage.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "btfgmm: compress a BTF (an RGB image for every light and view direction) into a "
      "Gaussian mixture of product components, and evaluate it"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "btfgmm 0.1.0");
  app.name("btfgmm");
  app.footer(
      "Run 'btfgmm COMMAND --help' for a command's options. Example (a synthetic BTF, a model "
      "of it, the model's quality):\n"
      "  btfgmm generate -o corduroy32/ && btfgmm fit corduroy32/ --tile 0,0,16,16 -M 100 -o "
      "corduroy.btfgmm && btfgmm compare corduroy32/ corduroy.btfgmm");
  btfgmm::cli::Commands commands;
  using namespace btfgmm::cli;
  for (const auto register_command :
       {register_generate_command, register_info_command, register_fit_command,
        register_decode_command, register_eval_command, register_compare_command,
        register_render_command, register_tile_command, register_sweep_command,
        register_view_command, register_export_shader_command, register_rangemap_command,
        register_convert_command})
    register_command(app, commands);

  if (argc == 1) {  // a bare `btfgmm`: what it does, its commands and an example
    btfgmm::cli::print_overview(app);
    return 0;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& err) {
    // A mistyped command or option gets the nearest name; otherwise CLI11 prints the help,
    // the version or the usage error. Its own exit codes (105 for a value out of range, ...)
    // become the documented 2.
    if (err.get_exit_code() != 0) {
      std::string plain = btfgmm::cli::mistyped_name(app, argc, argv);
      if (plain.empty()) plain = btfgmm::cli::out_of_range(err);
      if (!plain.empty()) {
        fmt::print(stderr, "btfgmm: error: {}\n", plain);
        return 2;
      }
    }
    return app.exit(err) == 0 ? 0 : 2;
  }

  try {
    for (const auto& c : commands)
      if (*c.app) c.run();
  } catch (const btfgmm::cli::UsageError& err) {
    fmt::print(stderr, "btfgmm: error: {}\n", btfgmm::cli::command_line_text(err.what()));
    return 2;
  } catch (const btfgmm::Error& err) {
    fmt::print(stderr, "btfgmm: error: {}\n", btfgmm::cli::command_line_text(err.what()));
    return 1;
  } catch (const std::exception& err) {
    fmt::print(stderr, "btfgmm: internal error: {}\n", err.what());
    return 3;
  }
  return 0;
}
