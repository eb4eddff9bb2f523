// A model measured against the BTF tile it was fitted to; see compare.hpp and docs/METRICS.md.
#include "btfgmm/measure/compare.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/model/decode.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {

namespace {

// A model is compared only with the tile it was fitted to: the same direction sets and size.
void check_fitted_to(const Btf& original, const ModelFrame& model, const std::string& name) {
  if (!(original.lights() == model.lights) || !(original.views() == model.views))
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: the model was fitted to {} lights x {} views, the BTF has {} x {} "
                            "or other angles; compare a model with the BTF it was fitted to",
                            name, model.lights.size(), model.views.size(), original.lights().size(),
                            original.views().size()));
  if (original.width() != model.width || original.height() != model.height)
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: the model's tile is {}x{} pixels, the original {}x{}; load the "
                            "model's tile (origin and size) from the BTF",
                            name, model.width, model.height, original.width(), original.height()));
}

// The model without its mixture: every pixel of an image its image's mean colour.
Btf mean_brdf_alone(const Btf& original, const std::vector<float>& mean_brdf) {
  Btf mean_only(original.lights(), original.views(), original.width(), original.height(),
                original.format());
  const std::size_t pixels = std::size_t(original.width()) * std::size_t(original.height());
  for (std::size_t i = 0; i < original.image_count(); ++i)
    for (std::size_t p = 0; p < pixels; ++p)
      for (std::size_t k = 0; k < 3; ++k)
        mean_only.data()[i * original.image_floats() + p * 3 + k] = mean_brdf[i * 3 + k];
  return mean_only;
}

std::size_t extreme_theta(const DirectionSet& s, bool largest) {
  std::size_t best = 0;
  for (std::size_t i = 1; i < s.size(); ++i)
    if (largest ? s[i].theta_deg > s[best].theta_deg : s[i].theta_deg < s[best].theta_deg) best = i;
  return best;
}

// Adds the pair (l, v) to the pictures, or its label to the pair's if it is pictured already.
void picture_pair(ModelComparison& c, const Btf& original, const Btf& decoded, std::size_t l,
                  std::size_t v, const std::string& label) {
  for (PicturedPair& p : c.pairs)
    if (p.light == l && p.view == v) {
      p.label += ", " + label;
      return;
    }
  const std::size_t floats = original.image_floats();
  PicturedPair p;
  p.light = l;
  p.view = v;
  p.label = label;
  p.original.assign(original.image(l, v), original.image(l, v) + floats);
  p.model.assign(decoded.image(l, v), decoded.image(l, v) + floats);
  c.pairs.push_back(std::move(p));
}

// Frontal light and view, a grazing light, a grazing view, then the worst images by PSNR.
void picture_pairs(ModelComparison& c, const Btf& original, const Btf& decoded,
                   std::size_t worst_pairs) {
  const std::size_t nv = original.views().size();
  const std::size_t fl = extreme_theta(original.lights(), false),
                    gl = extreme_theta(original.lights(), true),
                    fv = extreme_theta(original.views(), false),
                    gv = extreme_theta(original.views(), true);
  picture_pair(c, original, decoded, fl, fv, "frontal light and view");
  picture_pair(c, original, decoded, gl, fv, "grazing light");
  picture_pair(c, original, decoded, fl, gv, "grazing view");
  const std::vector<std::size_t> order = c.quality.by_psnr();
  for (std::size_t k = 0; k < std::min(worst_pairs, order.size()); ++k)
    picture_pair(c, original, decoded, order[k] / nv, order[k] % nv,
                 fmt::format("worst PSNR {}", k + 1));
}

}  // namespace

std::string_view to_string(DataMatch m) {
  switch (m) {
    case DataMatch::kSame:
      return "same";
    case DataMatch::kNotRecorded:
      return "not recorded";
    case DataMatch::kOtherContent:
      return "other content";
    case DataMatch::kOtherDirections:
      return "other directions";
  }
  return "?";
}

DataCheck check_fitted_data(const Representation& model, const std::string& model_name,
                            const Btf& tile, const DataSource& data) {
  const Provenance& p = model.provenance();
  const ModelFrame& f = model.frame();
  const std::string recorded = describe_source(p, f.origin);
  const std::string given = data.name.empty() ? std::string("the data") : "'" + data.name + "'";
  if (!(tile.lights() == f.lights) || !(tile.views() == f.views) ||
      (tile.format() == SampleFormat::kHdr) != (f.format == SampleFormat::kHdr))
    return {DataMatch::kOtherDirections,
            fmt::format("{} is not the data '{}' was fitted to: the model records {} with {} "
                        "lights x {} views of {} data, and {} has {} x {} of {} data",
                        given, model_name, recorded, f.lights.size(), f.views.size(),
                        to_string(f.format), given, tile.lights().size(), tile.views().size(),
                        to_string(tile.format()))};
  if (!p.recorded)
    return {DataMatch::kNotRecorded,
            fmt::format("'{}' records no provenance (written by an older btfgmm), so {} cannot "
                        "be checked against the data it was fitted to",
                        model_name, given)};
  if (tile_content_hash(tile) == p.data.content_hash) return {};
  const std::string images =
      data.image_width > 0 ? fmt::format(" ({}x{} images)", data.image_width, data.image_height)
                           : "";
  return {
      DataMatch::kOtherContent,
      fmt::format("{} is not the data '{}' was fitted to, a partial match (the same light "
                  "and view directions, other values): the model records {}; the same tile "
                  "of {}{} has content hash {}",
                  given, model_name, recorded, given, images, hash_text(tile_content_hash(tile)))};
}

ModelComparison compare_model(const Btf& original, std::shared_ptr<const Representation> model,
                              const std::string& name, std::uint64_t file_bytes,
                              const CompareOptions& options) {
  const ModelFrame& f = model->frame();
  check_fitted_to(original, f, name);
  const auto t0 = Clock::now();
  const Btf decoded = model->decode(f.lights, f.views, f.width, f.height, kDecodeTolerance);
  ModelComparison c;
  c.decode_seconds = seconds_since(t0);
  c.name = name;
  c.model = std::move(model);
  c.file_bytes = file_bytes;
  if (c.model->provenance().recorded) c.fit_seconds = c.model->provenance().fit.seconds;
  c.tile = {.x = f.origin.x, .y = f.origin.y, .width = f.width, .height = f.height};
  c.quality = measure_quality(original, decoded, 0.0, options.ssim);
  c.mean_brdf = mean_brdf(original);
  c.mean_brdf_only = measure_quality(original, mean_brdf_alone(original, c.mean_brdf),
                                     c.quality.range, options.ssim);
  picture_pairs(c, original, decoded, options.worst_pairs);
  if (c.model->synthesises()) c.texture = texture_statistics(original, decoded);
  return c;
}

ModelComparison compare_model(const Btf& original, const BtfModel& model, const std::string& name,
                              std::uint64_t file_bytes, const CompareOptions& options) {
  ModelComparison c =
      compare_model(original, std::make_shared<GaussianMixture>(model), name, file_bytes, options);
  c.fit_seconds = model.settings.seconds;
  return c;
}

}  // namespace btfgmm
