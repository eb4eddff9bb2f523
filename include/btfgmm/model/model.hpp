// The fitted BTF model: everything evaluation needs (the mixture, the mean BRDF, the tile and
// direction sets, the scaling to model units) and how it was fitted.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/provenance.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {

// How the mixture's parameters are stored (docs/FORMAT.md): 32- or 16-bit floats, or the
// compact encoding (each parameter quantised with a stated step, zstd; model/compact.hpp).
enum class Precision : std::uint32_t { kF32 = 0, kF16 = 1, kCompact = 2 };
// "f32", "f16", "compact": as `fit --precision` takes it.
std::string_view precision_name(Precision p);
// "32-bit float", "16-bit float", "compact (quantised, zstd)": for people.
std::string_view precision_text(Precision p);

// The quantisation steps of the compact encoding (docs/FORMAT.md, "The compact encoding"). A
// value is stored as the integer nearest to value / step, so the value read back is within
// step / 2 of the one written.
struct CompactSteps {
  double log_weight = 1.0 / 256.0;  // ln w_m (weights renormalised to sum 1 when read)
  double log_sigma = 1.0 / 512.0;   // ln sigma_mn, all nine variables (model units)
  double input_mean = 1.0 / 256.0;  // mu_mn of the six inputs, as a fraction of sigma_mn read
  double colour_mean = 1.0 / 16.0;  // mu_m7..9, model units (8-bit levels for 8-bit data)
  // The mean BRDF, in colour units: a level of 8-bit data (the paper counts it as bytes),
  // 1/255 of the range of HDR data. Files of version 4 were written with 1/8.
  double mean_brdf = 1.0;
};

struct FitSettings {
  std::uint32_t components = 0;  // M requested
  std::uint32_t max_iterations = 0;
  double epsilon = 0.0;
  std::uint64_t seed = 0;
  std::uint32_t iterations = 0;  // run
  std::uint32_t dropped = 0;     // components dropped by EM
  double log_likelihood = 0.0;   // final mean log-likelihood (model units)
  double seconds = 0.0;          // this run's fit time (the file's provenance has the whole)
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
  // The steps a compact file stores the model with: the defaults, or, for a model read from a
  // compact file, the file's, so that written again it holds the very same values.
  CompactSteps compact_steps;
  // Written to and read from the model file beside the payload (model/provenance.hpp).
  Provenance provenance;

  // Compression ratio as the paper counts it: paper_compression_ratio() of this model's tile,
  // direction sets and M.
  double compression_ratio_paper() const;
  // The same data against the bytes of the model file actually written.
  double compression_ratio_file(std::uint64_t file_bytes) const;
};

// The paper's size count (docs/ALGORITHM.md, "Compression ratio"): a model of M `components`
// as M*9*2 four-byte floats (a mean and a variance per variable and component) plus the mean
// BRDF of `lights` x `views` directions as ni*nv*3 bytes.
double paper_model_bytes(std::size_t lights, std::size_t views, std::size_t components);
// The paper's compression ratio of a tile of `pixels` = W*H pixels with `lights` x `views`
// directions and M `components`: W*H*ni*nv*3 bytes of 8-bit data against paper_model_bytes().
// Linear in the pixel count (the paper's Fig. 4). Throws Error(kArgument) for no pixels or an
// empty direction set.
double paper_compression_ratio(double pixels, std::size_t lights, std::size_t views,
                               std::size_t components);

}  // namespace btfgmm
