// What every representation shares: its frame and its compression ratios.
#include "btfgmm/methods/representation.hpp"

#include <fmt/format.h>

#include "btfgmm/core/error.hpp"

namespace btfgmm {

ModelFrame ModelFrame::of(const Btf& tile) {
  ModelFrame f;
  f.lights = tile.lights();
  f.views = tile.views();
  f.width = tile.width();
  f.height = tile.height();
  f.origin = tile.origin();
  f.format = tile.format();
  return f;
}

double Representation::paper_ratio() const {
  return frame().data_values() / double(parameter_count());
}

double Representation::file_ratio(std::uint64_t file_bytes) const {
  return frame().data_values() / double(file_bytes);
}

void Representation::set_synthesis_seed(std::uint64_t, std::string_view option) {
  throw Error(Error::Kind::kArgument,
              fmt::format("{}: a '{}' model reproduces its data and synthesises nothing; {} "
                          "applies to the texture models (3d-car, 2d-car, gmrf)",
                          option, method(), option));
}

bool Representation::compute_on(std::shared_ptr<ComputeDevice> device) {
  return device == nullptr;
}

}  // namespace btfgmm

namespace btfgmm {

FactorEncoding stored_encoding(const FitOptions& s) {
  return s.precision.value_or(FactorEncoding::kF16);
}

}  // namespace btfgmm
