// The compression ratios of a model.
#include "btfgmm/model/model.hpp"
#include "btfgmm/core/error.hpp"

namespace btfgmm {

double BtfModel::compression_ratio_paper() const {
  // docs/ALGORITHM.md, "Compression ratio": W*H*ni*nv*3 bytes of 8-bit data against M*9*2 4-byte
  // floats plus the mean BRDF counted as ni*nv*3 bytes.
  const double pairs = double(lights.size()) * double(views.size());
  const double data = double(width) * height * pairs * 3.0;
  const double model = double(mixture.size()) * kVariables * 2 * 4 + pairs * 3.0;
  return data / model;
}

double BtfModel::compression_ratio_file(std::uint64_t file_bytes) const {
  const double pairs = double(lights.size()) * double(views.size());
  return double(width) * height * pairs * 3.0 / double(file_bytes);
}

}  // namespace btfgmm
