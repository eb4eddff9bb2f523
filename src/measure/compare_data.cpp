// A model against a data set on disk: the checks and the JSON of `btfgmm compare`.
#include "btfgmm/measure/compare_data.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <set>

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {
namespace {

// How a Gaussian mixture was fitted.
void put_fit_settings(nlohmann::json& j, const BtfModel& m) {
  const auto& s = m.settings;
  j["components"] = m.mixture.size();
  j["components_requested"] = s.components;
  j["components_dropped"] = s.dropped;
  j["iterations"] = s.iterations;
  j["max_iterations"] = s.max_iterations;
  j["epsilon"] = s.epsilon;
  j["seed"] = s.seed;
  j["precision"] = std::string(precision_name(m.precision));
}

nlohmann::json image_json(const ModelFrame& m, const BtfQuality& q, std::size_t image) {
  const std::size_t nv = m.views.size();
  const Direction& l = m.lights[image / nv];
  const Direction& v = m.views[image % nv];
  const ImageQuality& iq = q.images[image];
  return {{"light", {l.theta_deg, l.phi_deg}},
          {"view", {v.theta_deg, v.phi_deg}},
          {"rmse", iq.rmse},
          {"psnr_db", iq.psnr_db},
          {"ssim", iq.ssim}};
}

}  // namespace

std::string describe_set(const DirectionSet& s) {
  if (s == DirectionSet::ubo81()) return "81 (the UBO2003/UTIA set)";
  double lo = 90, hi = 0;
  std::set<double> thetas;
  for (const auto& d : s) {
    lo = std::min(lo, d.theta_deg);
    hi = std::max(hi, d.theta_deg);
    thetas.insert(d.theta_deg);
  }
  return fmt::format("{} (theta {:g}..{:g} deg, {} distinct elevations)", s.size(), lo, hi,
                     thetas.size());
}

void check_model_frame(const Representation& model, const std::string& name, const BtfInfo& info,
                       const std::string& btf) {
  const ModelFrame& m = model.frame();
  if (!(m.lights == info.lights) || !(m.views == info.views))
    throw Error(
        Error::Kind::kArgument,
        fmt::format("{}: the model was fitted to {} lights and {} views of {}, but {} has {} "
                    "lights and {} views{}; compare a model with the BTF it was fitted to",
                    name, describe_set(m.lights), describe_set(m.views),
                    describe_source(model.provenance(), m.origin), btf, describe_set(info.lights),
                    describe_set(info.views),
                    m.lights.size() == info.lights.size() && m.views.size() == info.views.size()
                        ? " (same counts, other directions)"
                        : ""));
  if ((m.format == SampleFormat::kHdr) != (info.format == SampleFormat::kHdr))
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: the model was fitted to {} data, {} holds {} data; compare a "
                            "model with the BTF it was fitted to",
                            name, to_string(m.format), btf, to_string(info.format)));
  const Tile tile{.x = m.origin.x, .y = m.origin.y, .width = m.width, .height = m.height};
  if (tile.x < 0 || tile.y < 0 || tile.x + tile.width > info.width ||
      tile.y + tile.height > info.height)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("{}: the model's tile is {}x{} pixels at ({}, {}), outside the "
                    "{}x{} images of {}; compare a model with the BTF it was fitted to",
                    name, tile.width, tile.height, tile.x, tile.y, info.width, info.height, btf));
}

void refuse_other_data(const DataCheck& check, bool force, std::string_view action) {
  if (check.match == DataMatch::kSame || check.match == DataMatch::kNotRecorded || force) return;
  throw Error(Error::Kind::kArgument,
              fmt::format("{}; give the data the model was fitted to, or add `force` to {} "
                          "anyway",
                          check.message, action));
}

void put_model_json(nlohmann::json& j, const Representation& r) {
  j["method"] = std::string(r.method());
  j["size"] = r.size_text();
  j["parameters"] = r.parameter_count();
  nlohmann::json details = nlohmann::json::object();
  for (const auto& [k, v] : r.details()) details[k] = v;
  j["details"] = details;
  if (const auto* gm = dynamic_cast<const GaussianMixture*>(&r)) {
    put_fit_settings(j, gm->model());
    j["log_likelihood"] = gm->model().settings.log_likelihood;
  }
}

nlohmann::json texture_json(const TextureStatistics& t) {
  return {{"data_mean", t.data_mean},
          {"model_mean", t.model_mean},
          {"data_deviation", t.data_deviation},
          {"model_deviation", t.model_deviation},
          {"mean_difference", t.mean_difference},
          {"deviation_difference", t.deviation_difference},
          {"histogram_distance", t.histogram_distance},
          {"autocorrelation_difference", t.autocorrelation_difference},
          {"autocorrelation_max_lag", t.max_lag},
          {"worst_mean_difference", t.worst_mean_difference},
          {"deviation_ratio_range", {t.lowest_deviation_ratio, t.highest_deviation_ratio}},
          {"worst_autocorrelation_difference", t.worst_autocorrelation_difference},
          {"worst_streak_ratio", t.worst_streak_ratio},
          {"saturated_data", t.saturated_data},
          {"saturated_model", t.saturated_model}};
}

nlohmann::json comparison_json(const std::string& btf, const ModelComparison& c, DataMatch match) {
  const ModelFrame& m = c.model->frame();
  const BtfQuality& q = c.quality;
  nlohmann::json j;
  j["btf"] = btf;
  j["model"] = c.name;
  j["tile"] = {c.tile.x, c.tile.y, c.tile.width, c.tile.height};
  j["lights"] = m.lights.size();
  j["views"] = m.views.size();
  j["bit_depth"] = to_string(m.format);
  j["rmse"] = q.rmse;
  j["psnr_db"] = q.psnr_db;  // +infinity (identical images) is written as null
  j["ssim"] = q.ssim;
  j["rmse_rgb"] = q.rmse_rgb;
  j["psnr_db_rgb"] = q.psnr_db_rgb;
  j["ssim_rgb"] = q.ssim_rgb;
  j["data_range"] = q.range;
  j["ssim_window"] = q.ssim_window;
  j["worst_psnr"] = image_json(m, q, q.worst_psnr);
  j["best_psnr"] = image_json(m, q, q.best_psnr);
  j["worst_ssim"] = image_json(m, q, q.worst_ssim);
  j["best_ssim"] = image_json(m, q, q.best_ssim);
  j["mean_brdf_only"] = {{"rmse", c.mean_brdf_only.rmse},
                         {"psnr_db", c.mean_brdf_only.psnr_db},
                         {"ssim", c.mean_brdf_only.ssim}};
  j["compression_ratio_paper"] = c.model->paper_ratio();
  j["compression_ratio_file"] = c.model->file_ratio(c.file_bytes);
  j["file_bytes"] = c.file_bytes;
  put_model_json(j, *c.model);
  j["decode_seconds"] = c.decode_seconds;
  if (c.fit_seconds > 0) j["fit_seconds"] = c.fit_seconds;
  j["pixelwise_meaningful"] = !c.texture;
  if (c.texture) j["texture_statistics"] = texture_json(*c.texture);
  j["data_match"] = std::string(to_string(match));
  return j;
}

}  // namespace btfgmm
