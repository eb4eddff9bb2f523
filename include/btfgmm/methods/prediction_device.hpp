// Where a model's predictions are computed (docs/GPU.md, "Decoding on the GPU"): the device
// `--device` of decode, eval, compare and sweep, and the `device` keyword of Python's load and
// fit, choose.
#pragma once

#include <string>
#include <string_view>

#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/representation.hpp"

namespace btfgmm {

// Puts the predictions of `model` (named `name` in errors) on the device `choice` takes
// (open_compute_device): kCpu and kAuto without a hardware GPU keep the CPU, as does kAuto for
// a method with no kernels for a device; kGpu for such a method throws Error(kArgument) naming
// `device` cpu. Returns where they are computed: "the CPU" or "the GPU NAME (Vulkan, DRIVER)".
std::string compute_predictions_on(Representation& model, DeviceChoice choice,
                                   std::string_view name);

// The predictions of `model`, fitted with `s`, on the device of its fit (fit_device), where
// the method has kernels for one: how sweep and `fit --budget` measure what they fit. kAuto
// without a hardware GPU, kCpu and the methods without kernels keep the CPU.
void compute_where_fitted(Representation& model, const FitOptions& s);

}  // namespace btfgmm
