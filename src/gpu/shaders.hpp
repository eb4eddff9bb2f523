// The compute shaders built into the library: src/gpu/shaders/NAME.comp compiled to SPIR-V by
// glslc at build time (CMakeLists.txt) and embedded by cmake/embed_resources.cmake.
#pragma once

#include <string_view>

namespace btfgmm::detail {

// The SPIR-V of the shader `name` (e.g. "em_normaliser.spv"); empty for an unknown name.
std::string_view gpu_shader(std::string_view name);

}  // namespace btfgmm::detail
