// A Vulkan call's result as the library's error (gpu layer).
#pragma once

#include <vulkan/vulkan.h>

#include <string>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"

namespace btfgmm::detail {

inline std::string vulkan_result_text(VkResult r) {
  switch (r) {
    case VK_ERROR_OUT_OF_HOST_MEMORY:
      return "out of host memory";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
      return "out of device memory";
    case VK_ERROR_DEVICE_LOST:
      return "the device was lost";
    case VK_ERROR_INITIALIZATION_FAILED:
      return "initialisation failed";
    case VK_ERROR_FEATURE_NOT_PRESENT:
      return "a feature is not present";
    case VK_ERROR_INCOMPATIBLE_DRIVER:
      return "no compatible driver";
    default:
      return "Vulkan error " + std::to_string(int(r));
  }
}

// Throws Error(kIo) for a failed call: what was being done, on which device, and the way on.
inline void vulkan_check(VkResult r, const std::string& what, const std::string& device) {
  if (r == VK_SUCCESS) return;
  throw Error(Error::Kind::kIo, "the GPU " + device + " failed " + what + ": " +
                                    vulkan_result_text(r) + "; run it on the CPU (" +
                                    option_name("device") + " cpu)");
}

}  // namespace btfgmm::detail
