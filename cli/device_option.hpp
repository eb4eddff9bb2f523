// --device of decode, eval and compare (docs/GPU.md, "Decoding on the GPU"): where a model's
// predictions are computed.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/methods/prediction_device.hpp"

namespace btfgmm::cli {

inline void add_device_option(CLI::App* app, std::string& device) {
  app->add_option("--device", device,
                  "Where the predictions are computed: auto (a GPU where one exists, else the "
                  "CPU), cpu, or gpu (a GPU, else a software Vulkan such as lavapipe). The GPU "
                  "computes the Gaussian mixture's (gm), every component weighed, and the neural "
                  "BTF's network; the other methods compute on the CPU (docs/GPU.md)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "cpu", "gpu"}));
}

// Puts the predictions of `model` (read from `path`) on the device `word` names
// (compute_predictions_on) and returns where they are computed.
inline std::string compute_on_device(Representation& model, const std::string& word,
                                     const std::string& path) {
  return compute_predictions_on(model, parse_device_choice(word).value_or(DeviceChoice::kAuto),
                                path);
}

}  // namespace btfgmm::cli
