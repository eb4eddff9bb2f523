// The compression ratios of a model.
#include "btfgmm/model/model.hpp"

#include <fmt/format.h>

#include "btfgmm/core/error.hpp"

namespace btfgmm {

double paper_model_bytes(std::size_t lights, std::size_t views, std::size_t components) {
  const double pairs = double(lights) * double(views);
  return double(components) * kVariables * 2.0 * 4.0 + pairs * 3.0;
}

double paper_compression_ratio(double pixels, std::size_t lights, std::size_t views,
                               std::size_t components) {
  // docs/ALGORITHM.md, "Compression ratio": W*H*ni*nv*3 bytes of 8-bit data against M*9*2 4-byte
  // floats plus the mean BRDF counted as ni*nv*3 bytes.
  const double pairs = double(lights) * double(views);
  if (!(pixels > 0.0) || pairs <= 0.0)
    throw Error(Error::Kind::kArgument,
                fmt::format("compression ratio: {} pixels and {} x {} directions; give a tile "
                            "of at least one pixel and non-empty direction sets",
                            pixels, lights, views));
  const double data = pixels * pairs * 3.0;
  return data / paper_model_bytes(lights, views, components);
}

namespace {

// The data as the paper counts it: W*H*ni*nv*3 bytes of 8-bit RGB.
double data_bytes(const BtfModel& m) {
  return double(m.width) * double(m.height) * double(m.lights.size()) * double(m.views.size()) *
         3.0;
}

}  // namespace

double BtfModel::compression_ratio_paper() const {
  return data_bytes(*this) / paper_model_bytes(lights.size(), views.size(), mixture.size());
}

double BtfModel::compression_ratio_file(std::uint64_t file_bytes) const {
  return data_bytes(*this) / double(file_bytes);
}

std::string_view precision_name(Precision p) {
  return p == Precision::kF16 ? "f16" : p == Precision::kCompact ? "compact" : "f32";
}

std::string_view precision_text(Precision p) {
  return p == Precision::kF16       ? "16-bit float"
         : p == Precision::kCompact ? "compact (quantised, zstd; docs/FORMAT.md)"
                                    : "32-bit float";
}

}  // namespace btfgmm
