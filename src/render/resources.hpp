// The files of src/render/glsl and src/render/web, built into the library by
// cmake/embed_resources.cmake (the generated render_resources.cpp).
#pragma once

#include <string_view>

namespace btfgmm::detail {

// The bytes of the resource `name` ("glsl/mixture.glsl", "web/viewer.js", ...); empty for a
// name that is not one.
std::string_view render_resource(std::string_view name);

}  // namespace btfgmm::detail
