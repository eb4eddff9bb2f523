// A model compared with the BTF tile it was fitted to: its quality (docs/METRICS.md), the
// quality of its mean BRDF alone, and the (light, view) images a report pictures.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/measure/metrics.hpp"
#include "btfgmm/measure/texture_statistics.hpp"
#include "btfgmm/methods/representation.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {

// One (light, view) pair pictured: its original and model images (the tile, in the data's
// scale) and why it was chosen.
struct PicturedPair {
  std::size_t light = 0, view = 0;
  std::string label;  // e.g. "frontal light and view", "worst PSNR 1"
  std::vector<float> original, model;
};

struct ModelComparison {
  std::string name;                             // how the report names the model (its file)
  std::shared_ptr<const Representation> model;  // any method
  std::uint64_t file_bytes = 0;                 // the size of the model file (0: not written)
  double fit_seconds = 0.0;                     // the fit's time, where known (0: not known)
  double decode_seconds = 0.0;                  // decoding every image of the tile
  Tile tile;                                    // the tile of the source the model was fitted to
  BtfQuality quality;                           // the model against the original tile
  BtfQuality mean_brdf_only;     // the mean BRDF alone (every pixel its image's mean)
  std::vector<float> mean_brdf;  // of the original tile, ni * nv * 3 (Fig. 2)
  std::vector<PicturedPair> pairs;
  // For a model that synthesises new texture (Representation::synthesises()): its statistics
  // against the data; `quality` is then not meaningful.
  std::optional<TextureStatistics> texture;
};

struct CompareOptions {
  std::size_t worst_pairs = 3;  // pictures of the worst images by PSNR
  SsimSettings ssim;
};

// How a tile of data compares with the data a model was fitted to, by the model's provenance
// (model/provenance.hpp).
enum class DataMatch {
  kSame,             // the tile's content hash is the one the model records
  kNotRecorded,      // the model records no provenance (an older file): nothing to check
  kOtherContent,     // the same direction sets, other values in the tile: a partial match
  kOtherDirections,  // other direction sets, or another sample format
};
std::string_view to_string(DataMatch m);  // "same", "not recorded", "other content", ...

struct DataCheck {
  DataMatch match = DataMatch::kSame;
  // Unless kSame: what differs, naming the data the model records (source, tile, content
  // hash) and the data given (the same).
  std::string message;
};
// `tile` is the model's tile (its origin and size) as read from `data`, the data given for
// it; `model_name` names the model.
DataCheck check_fitted_data(const Representation& model, const std::string& model_name,
                            const Btf& tile, const DataSource& data);

// Decodes `model` at its own direction sets and tile size, measures it against `original` (the
// tile it was fitted to) and keeps the images of the pairs to picture: frontal light and view,
// a grazing light, a grazing view, then the worst by PSNR. Throws Error(kArgument) naming
// `name` if the original's direction sets or size differ from the model's.
ModelComparison compare_model(const Btf& original, std::shared_ptr<const Representation> model,
                              const std::string& name, std::uint64_t file_bytes,
                              const CompareOptions& options = {});
// The same for a Gaussian mixture.
ModelComparison compare_model(const Btf& original, const BtfModel& model, const std::string& name,
                              std::uint64_t file_bytes, const CompareOptions& options = {});

}  // namespace btfgmm
