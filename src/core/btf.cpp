#include "btfgmm/core/btf.hpp"

#include <fmt/format.h>

#include <limits>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"

namespace btfgmm {

std::string to_string(SampleFormat f) {
  switch (f) {
    case SampleFormat::kLdr8:
      return "8-bit";
    case SampleFormat::kLdr16:
      return "16-bit";
    case SampleFormat::kHdr:
      return "HDR float";
  }
  return "?";
}

Btf::Btf(DirectionSet lights, DirectionSet views, int width, int height, SampleFormat format)
    : lights_(std::move(lights)),
      views_(std::move(views)),
      width_(width),
      height_(height),
      format_(format),
      origin_{.x = 0, .y = 0, .width = width, .height = height} {
  if (lights_.empty() || views_.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("a BTF needs at least one light and one view direction (got {} "
                            "lights, {} views)",
                            lights_.size(), views_.size()));
  if (width < 1 || height < 1)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("BTF image size {}x{} is empty; give a size of at least 1x1", width, height));
  const double floats = double(image_count()) * double(width) * double(height) * 3.0;
  if (floats > double(std::numeric_limits<std::ptrdiff_t>::max() / 8))
    throw Error(Error::Kind::kArgument,
                fmt::format("BTF of {} images of {}x{} pixels is too large to hold in memory; "
                            "load a smaller tile",
                            image_count(), width, height));
  limits::check_memory(
      floats * 4.0, fmt::format("a BTF of {} images of {}x{} pixels", image_count(), width, height),
      "use a smaller tile or image size, or fewer directions");
  data_.assign(image_count() * image_floats(), 0.0f);
}

}  // namespace btfgmm
