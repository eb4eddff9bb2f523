// A model against a data set on disk, as `btfgmm compare` checks and reports it: that the
// model's frame fits the data, what to do with data other than the model's, and the
// comparison as JSON (the command's `--json`, the report's compare.json, the Python module's
// dict).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "btfgmm/core/directions.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/measure/compare.hpp"
#include "btfgmm/methods/representation.hpp"

namespace btfgmm {

// "81 (the UBO2003/UTIA set)" or "25 (theta 0..75 deg, 4 distinct elevations)".
std::string describe_set(const DirectionSet& s);

// That `model` (named `name`) can be compared with the data set `btf` (its `info`): the same
// direction sets and kind of samples, and its tile inside the images. Throws Error(kArgument)
// saying what differs.
void check_model_frame(const Representation& model, const std::string& name, const BtfInfo& info,
                       const std::string& btf);

// Data other than the model's (kOtherContent, kOtherDirections) is refused unless `force`:
// Error(kArgument) with the check's message and how to go on anyway (`action`: "compare",
// "render"). The same data and data the model records nothing of pass.
void refuse_other_data(const DataCheck& check, bool force, std::string_view action);

// The model's method, size, stored values and named facts; for a Gaussian mixture also how it
// was fitted and its L.
void put_model_json(nlohmann::json& j, const Representation& r);

// A synthesis model's texture statistics against the data (measure/texture_statistics.hpp),
// as `compare --json` and `sweep` write them.
nlohmann::json texture_json(const TextureStatistics& t);

// One comparison as `btfgmm compare --json` writes it: the data set `btf`, the tile, RMSE,
// PSNR and SSIM (overall, per channel, the worst and best images), the mean BRDF alone, the
// compression ratios, the model (put_model_json), the times and `match`.
nlohmann::json comparison_json(const std::string& btf, const ModelComparison& c, DataMatch match);

}  // namespace btfgmm
