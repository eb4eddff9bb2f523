// The one refusal of work a compute device cannot hold (docs/GPU.md, "Bounds and faults"),
// made before any transfer.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/gpu/compute_device.hpp"

namespace btfgmm::detail {

// Throws Error(kArgument) where `info`'s device cannot hold `bytes` (more than 90 % of its
// memory) or a buffer of `largest` bytes: "the GPU NAME cannot hold `what`: they take ..."
// with the bytes needed and the device's, naming a smaller tile and `device` cpu.
inline void check_device_holds(const DeviceInfo& info, double bytes, double largest,
                               std::string_view what) {
  if (bytes <= 0.9 * double(info.memory_bytes) && largest <= double(info.max_buffer_bytes)) return;
  throw Error(Error::Kind::kArgument,
              "the GPU " + info.name + " cannot hold " + std::string(what) + ": they take " +
                  human_bytes(bytes) + " of its " + human_bytes(double(info.memory_bytes)) +
                  " (its largest buffer: " + human_bytes(double(info.max_buffer_bytes)) +
                  "); fit a smaller tile, or on the CPU (" + option_name("device") + " cpu)");
}

// Mesa's lavapipe (22.3) ends a shader's loop nest after 65,535 iterations of its loops in all,
// silently; a pass that would run more in one workgroup on a software device is refused.
constexpr std::size_t kSoftwareLoopIterations = 65535;

// Throws Error(kArgument) where `info` is a software device and a workgroup of `what` would
// run more than kSoftwareLoopIterations iterations of a loop nest, naming `device` cpu.
inline void check_loop_nest(const DeviceInfo& info, std::size_t iterations, std::string_view what) {
  if (!info.software || iterations <= kSoftwareLoopIterations) return;
  throw Error(Error::Kind::kArgument,
              "the software Vulkan device " + info.name + " cannot run " + std::string(what) +
                  ": " + std::to_string(iterations) +
                  " iterations of a loop in one workgroup, past the 65,535 it runs; a smaller "
                  "tile, or the CPU (" +
                  option_name("device") + " cpu)");
}

}  // namespace btfgmm::detail
