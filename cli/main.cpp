// btfgmm: the command-line tool. A thin layer over the library: it parses options, calls the
// library, and formats what comes back. Errors from the library carry the file and the fix;
// they are printed as "btfgmm: error: ..." with exit status 1 (2 for bad usage).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "btfgmm/core/error.hpp"
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
  btfgmm::cli::register_data_commands(app, commands);
  btfgmm::cli::register_model_commands(app, commands);
  btfgmm::cli::register_compare_commands(app, commands);
  btfgmm::cli::register_render_commands(app, commands);
  btfgmm::cli::register_sweep_commands(app, commands);
  btfgmm::cli::register_view_commands(app, commands);
  btfgmm::cli::register_texture_commands(app, commands);
  btfgmm::cli::register_convert_commands(app, commands);

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
      const std::string mistyped = btfgmm::cli::mistyped_name(app, argc, argv);
      if (!mistyped.empty()) {
        fmt::print(stderr, "btfgmm: error: {}\n", mistyped);
        return 2;
      }
    }
    return app.exit(err) == 0 ? 0 : 2;
  }

  try {
    for (const auto& c : commands)
      if (*c.app) c.run();
  } catch (const btfgmm::Error& err) {
    fmt::print(stderr, "btfgmm: error: {}\n", err.what());
    return 1;
  } catch (const std::exception& err) {
    fmt::print(stderr, "btfgmm: internal error: {}\n", err.what());
    return 3;
  }
  return 0;
}
