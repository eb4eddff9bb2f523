// btfgmm: the command-line tool. A thin layer over the library: it parses options, calls the
// library, and formats what comes back. Errors from the library carry the file and the fix;
// they are printed as "btfgmm: error: ..." with exit status 1 (2 for bad usage).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "btfgmm/core/error.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "btfgmm: compress a BTF (an RGB image for every light and view direction) into a "
      "Gaussian mixture of product components, and evaluate it"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "btfgmm 0.1.0");
  btfgmm::cli::Commands commands;
  btfgmm::cli::register_data_commands(app, commands);
  btfgmm::cli::register_model_commands(app, commands);
  btfgmm::cli::register_compare_commands(app, commands);
  btfgmm::cli::register_render_commands(app, commands);
  btfgmm::cli::register_sweep_commands(app, commands);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& err) {
    // CLI11 prints the help, the version or the usage error; its own exit codes (105 for a
    // value out of range, ...) become the documented 2.
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
