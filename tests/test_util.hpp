// Helpers shared by the test files.
#pragma once

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/methods/representation.hpp"
#include "btfgmm/synth/generate.hpp"

namespace btfgmm::test {

// In CI (CI=true), where a GPU test that would skip for want of a device fails instead.
inline bool in_ci() {
  const char* ci = std::getenv("CI");
  return ci && std::string(ci) == "true";
}

// The device `device gpu` opens (a hardware GPU, else lavapipe); null after a skip, or a
// failure in CI.
inline std::shared_ptr<ComputeDevice> test_device() {
  try {
    return open_compute_device(DeviceChoice::kGpu);
  } catch (const Error& e) {
    if (in_ci()) ADD_FAILURE() << "CI runs the GPU kernels on lavapipe: " << e.what();
    return nullptr;
  }
}

// Opens the test device as `name`, or skips the test (fails it in CI) where there is none.
#define REQUIRE_DEVICE(name)                                                                \
  const std::shared_ptr<ComputeDevice> name = ::btfgmm::test::test_device();                \
  if (!name) {                                                                              \
    if (!::btfgmm::test::in_ci()) GTEST_SKIP() << "no Vulkan device (mesa-vulkan-drivers)"; \
    return;                                                                                 \
  }

// A generated tile (btfgmm generate) of `size` x `size` pixels at the direction sets given.
inline Btf generated_tile(const std::string& material, int size, std::uint64_t seed,
                          const std::string& lights, const std::string& views) {
  GenerateConfig g;
  g.material = material;
  g.size = size;
  g.seed = seed;
  g.lights = DirectionSet::parse(lights);
  g.views = DirectionSet::parse(views);
  return generate(g);
}

// A neural BTF's fit small enough for any test's tile: L = 4, 2 x 16, at most `epochs` epochs.
inline FitOptions small_neural_options(int epochs) {
  FitOptions s;
  s.method = "neural";
  s.components = 4;
  s.width = 16;
  s.depth = 2;
  s.iterations = epochs;
  return s;
}

// The command's flag of a field (cli/cli_util.hpp, command_line_option): "--refine-steps".
inline std::string command_line_option(std::string_view field) {
  std::string flag = "--" + std::string(field);
  for (char& c : flag)
    if (c == '_') c = '-';
  return flag;
}

// A library message as the command shows it: the options it names (core/text.hpp,
// option_name) spelled as the command's flags.
inline std::string as_the_command_shows(const std::string& message) {
  return spell_options(message, command_line_option);
}

// The message of the btfgmm::Error `f` throws, as the command shows it; a test failure if it
// throws nothing or something else.
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const btfgmm::Error& e) {
    return as_the_command_shows(e.what());
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not a btfgmm::Error: " << e.what();
    return "";
  }
  ADD_FAILURE() << "no error";
  return "";
}

// The btfgmm command's exit status and its stdout and stderr apart.
struct CliRun {
  int status = 0;
  std::string out, err;
};

#ifdef BTFGMM_CLI_PATH
// Runs the built command with `args` (a shell command line's tail); `tag` names its
// temporary output files, removed afterwards.
inline CliRun run_cli(const std::string& args, const std::string& tag) {
  const std::string base = (std::filesystem::temp_directory_path() /
                            ("btfgmm_" + tag + "_" + std::to_string(::getpid())))
                               .string();
  const std::string cmd =
      std::string(BTFGMM_CLI_PATH) + " " + args + " > " + base + ".out 2> " + base + ".err";
  CliRun r;
  const int raw = std::system(cmd.c_str());
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  auto slurp = [](const std::string& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  r.out = slurp(base + ".out");
  r.err = slurp(base + ".err");
  std::filesystem::remove(base + ".out");
  std::filesystem::remove(base + ".err");
  return r;
}
#endif

}  // namespace btfgmm::test
