// The fitted BTF model: everything evaluation needs (the mixture, the mean BRDF, the tile and
// direction sets, the scaling to model units) and how it was fitted.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {

enum class Precision : std::uint32_t { kF32 = 0, kF16 = 1 };

struct FitSettings {
  std::uint32_t components = 0;  // M requested
  std::uint32_t max_iterations = 0;
  double epsilon = 0.0;
  std::uint64_t seed = 0;
  std::uint32_t iterations = 0;  // run
  std::uint32_t dropped = 0;     // components dropped by EM
  double log_likelihood = 0.0;   // final mean log-likelihood (model units)
  double seconds = 0.0;          // fit time (not stored in the model file: files are reproducible)
};

// Everything evaluation needs.
struct BtfModel {
  DirectionSet lights, views;
  int width = 0, height = 0;  // the tile
  Tile origin;                // where the tile was cut from its source
  SampleFormat format = SampleFormat::kLdr8;
  VariableScaling scaling;
  std::vector<float> mean_brdf;  // ni * nv * 3
  ProductMixture mixture;        // model units
  FitSettings settings;
  Precision precision = Precision::kF32;

  // Compression ratio as the paper counts it (docs/ALGORITHM.md, "Compression ratio"): W*H*ni*nv*3
  // bytes of 8-bit data against M*9*2 floats (4 bytes) plus the mean BRDF as ni*nv*3 bytes.
  double compression_ratio_paper() const;
  // The same data against the bytes of the model file actually written.
  double compression_ratio_file(std::uint64_t file_bytes) const;
};

}  // namespace btfgmm
