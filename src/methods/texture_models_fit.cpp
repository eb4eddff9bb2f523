// Fitting and reading the probabilistic BTF models (Haindl & Filip, PAMI 2007): subspaces,
// range map, a texture model per subspace.
#include <fmt/format.h>

#include <algorithm>
#include <atomic>

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/range_map.hpp"
#include "btfgmm/methods/texture_models.hpp"
#include "btfgmm/model/model_file.hpp"
#include "methods/car.hpp"
#include "methods/colour_texture.hpp"
#include "methods/factors.hpp"
#include "methods/image_moments.hpp"
#include "methods/pyramid.hpp"
#include "methods/relief_structure.hpp"
#include "methods/subspaces.hpp"

namespace btfgmm {
namespace {

using detail::TextureKind;

constexpr std::size_t kDefaultSubspaces = 15;
constexpr int kMinTileSide = 8;    // of the tile, and of the pyramid's coarsest level
constexpr int kDefaultLevels = 3;  // or as many as the tile holds, if fewer

std::string_view method_name(TextureKind kind) {
  return kind == TextureKind::kCar3d ? "3d-car" : kind == TextureKind::kCar2d ? "2d-car" : "gmrf";
}

void check_settings(TextureKind kind, const Btf& tile, const FitOptions& s) {
  const auto refuse = [&](std::string_view option, auto value) {
    throw Error(Error::Kind::kArgument,
                fmt::format("{} {}: {} takes its size from `clusters` (subspaces) alone and "
                            "chooses its neighbourhood itself; leave {} out",
                            option, value, method_name(kind), option));
  };
  if (s.components != 0) refuse("`components`", s.components);
  if (s.degree != 0) refuse("`degree`", s.degree);
  if (s.iterations != 0) refuse("`iterations`", s.iterations);
  if (s.clusters > 255)
    throw Error(Error::Kind::kArgument, fmt::format("`clusters` {}: {} takes 1 to 255 subspaces",
                                                    s.clusters, method_name(kind)));
  if (tile.width() < kMinTileSide || tile.height() < kMinTileSide)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("{} needs a tile of at least {} x {} pixels to learn a texture; "
                    "this one is {} x {}: give a larger `tile`",
                    method_name(kind), kMinTileSide, kMinTileSide, tile.width(), tile.height()));
  const int most = detail::max_levels(tile.width(), tile.height(), kMinTileSide);
  if (s.levels < 0 || s.levels > most)
    throw Error(Error::Kind::kArgument,
                fmt::format("`levels` {}: a {} x {} tile holds at most {} pyramid level{} (the "
                            "coarsest at least {} x {} pixels); give `levels` 1 to {}, or a "
                            "larger `tile`",
                            s.levels, tile.width(), tile.height(), most, most == 1 ? "" : "s",
                            kMinTileSide, kMinTileSide, most));
}

// The pyramid's levels: as asked, or kDefaultLevels where the tile holds them.
int pyramid_levels(const Btf& tile, const FitOptions& s) {
  if (s.levels > 0) return s.levels;
  return std::min(kDefaultLevels, detail::max_levels(tile.width(), tile.height(), kMinTileSide));
}

detail::Field image_field(const Btf& tile, std::size_t image) {
  detail::Field f(tile.width(), tile.height(), 3);
  const float* p = tile.data().data() + image * tile.image_floats();
  f.values.assign(p, p + tile.image_floats());
  return f;
}

// The light of a tile's image.
Vec3 light_of(const Btf& tile, std::size_t image) {
  return to_vector(tile.lights()[image / tile.views().size()]);
}

// Each subspace's model of its representative image less its relief structure, fitted on
// the range map's `features` into `relief`.
std::vector<TextureModel::Subspace> fit_subspaces(TextureKind kind, const Btf& tile,
                                                  const detail::Subspaces& sub,
                                                  const FitOptions& s,
                                                  const detail::ReliefFeatures& features,
                                                  std::vector<detail::ReliefStructure>& relief) {
  std::vector<TextureModel::Subspace> out(sub.representatives.size());
  relief.assign(out.size(), {});
  std::atomic<std::size_t> done{0};
  std::atomic<bool> stopped{false};
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t k = 0; k < std::ptrdiff_t(out.size()); ++k) {
    if (stopped || (s.stop && s.stop->load())) {
      stopped = true;
      continue;
    }
    const std::size_t representative = sub.representatives[std::size_t(k)];
    detail::Field image = image_field(tile, representative);
    const Vec3 light = light_of(tile, representative);
    detail::ReliefStructure& r = relief[std::size_t(k)];
    r = detail::fit_relief_structure(features, light, image.values.data());
    detail::add_relief_shape(r, features, image.values.data(), tile.width(), tile.height(), -1);
    detail::add_relief_slope(r, features, light, image.values.data(), tile.width(), tile.height(),
                             -1);
    out[std::size_t(k)] =
        detail::fit_colour_texture(kind, image, detail::kMaxCausalOrder, pyramid_levels(tile, s),
                                   detail::CarSynthesis::kSpectral);
    const std::size_t n = ++done;
    if (s.progress) {
#pragma omp critical(btfgmm_texture_progress)
      s.progress(double(n) / double(out.size()), "a model per subspace");
    }
  }
  if (stopped)
    throw Error(Error::Kind::kArgument, fmt::format("{}'s fit was stopped", method_name(kind)));
  return out;
}

std::unique_ptr<Representation> read_texture_model(TextureKind kind,
                                                   std::span<const std::uint8_t> payload,
                                                   std::uint32_t flags, const std::string& name) {
  detail::ByteReader r(payload, "model file", name, "fit the model again");
  constexpr std::uint32_t predicted = kImageMoments | kPredictedImageMoments;
  constexpr std::uint32_t with_relief = predicted | kReliefStructure;
  if (flags != 0 && flags != kImageMoments && flags != predicted && flags != with_relief)
    r.fail(fmt::format("{} takes flags 0, {:#x}, {:#x} or {:#x}, the file has {:#x}",
                       method_name(kind), kImageMoments, predicted, with_relief, flags));
  // A file with the image moments (version 6 on) synthesises its CAR models on the torus;
  // one before them in raster order, as it always did.
  const bool moments = (flags & kImageMoments) != 0;
  const auto synthesis = moments ? detail::CarSynthesis::kSpectral : detail::CarSynthesis::kRaster;
  ModelFrame frame = detail::get_frame(r);
  const auto seed = r.get<std::uint64_t>("seed");
  const int levels = r.get<std::uint8_t>("pyramid levels");
  if (levels < 1 || levels > detail::max_levels(frame.width, frame.height, 1))
    r.fail(fmt::format("{} pyramid levels for a {} x {} tile", levels, frame.width, frame.height));
  const std::size_t c = detail::get_count(r, 1, 255, "subspaces");
  std::vector<std::uint8_t> labels(frame.lights.size() * frame.views.size());
  for (std::uint8_t& l : labels)
    if ((l = r.get<std::uint8_t>("labels")) >= c)
      r.fail(fmt::format("label {} of {} subspaces", l, c));
  const std::size_t at = r.pos();  // the range map's encoding, which get_factors checks
  std::vector<float> heights = detail::get_factors(r, 1, frame.pixels(), "range map");
  const auto encoding = FactorEncoding(payload[at]);
  std::vector<TextureModel::Subspace> subspaces;
  for (std::size_t k = 0; k < c; ++k)
    subspaces.push_back(detail::get_colour_texture(kind, levels, r, synthesis));
  std::shared_ptr<const detail::ImageMoments> image_moments;
  if (moments) {
    detail::ImageMoments m =
        detail::get_image_moments(r, labels.size(), frame.views.size(),
                                  flags & kPredictedImageMoments ? detail::MomentsCoding::kPredicted
                                                                 : detail::MomentsCoding::kDeltas);
    for (std::size_t k = 0; k < c; ++k) m.marginals.push_back(detail::get_marginal(r));
    image_moments = std::make_shared<detail::ImageMoments>(std::move(m));
  }
  std::shared_ptr<std::vector<detail::ReliefStructure>> relief;
  if (flags & kReliefStructure) {
    relief = std::make_shared<std::vector<detail::ReliefStructure>>();
    for (std::size_t k = 0; k < c; ++k) relief->push_back(detail::get_relief_structure(r));
  }
  if (r.remaining() != 0) r.fail(fmt::format("{} bytes follow the model", r.remaining()));
  return std::make_unique<TextureModel>(method_name(kind), std::move(frame), std::move(labels),
                                        std::move(subspaces), std::move(heights), seed, encoding,
                                        std::move(image_moments), std::move(relief));
}

std::unique_ptr<Representation> fit_texture_model(TextureKind kind, const Btf& tile,
                                                  const FitOptions& s) {
  check_settings(kind, tile, s);
  if (s.progress) s.progress(0.0, "range map");
  std::vector<float> heights = estimate_range_map(tile).heights;
  detail::quantise_factors(heights, heights.size(), stored_encoding(s));
  const detail::Subspaces sub =
      detail::cluster_images(tile, s.clusters ? s.clusters : kDefaultSubspaces, s.seed);
  const detail::ReliefFeatures features =
      detail::relief_features(heights, tile.width(), tile.height());
  auto relief = std::make_shared<std::vector<detail::ReliefStructure>>();
  std::vector<TextureModel::Subspace> models = fit_subspaces(kind, tile, sub, s, features, *relief);
  auto moments = std::make_shared<detail::ImageMoments>(detail::measure_image_moments(tile));
  // Each representative's marginal without its relief's slope along its light, which each
  // image takes along its own after the marginal is matched.
  for (std::size_t k = 0; k < sub.representatives.size(); ++k) {
    const float* image = tile.data().data() + sub.representatives[k] * tile.image_floats();
    std::vector<float> flat(image, image + tile.image_floats());
    detail::add_relief_slope((*relief)[k], features, light_of(tile, sub.representatives[k]),
                             flat.data(), tile.width(), tile.height(), -1);
    moments->marginals.push_back(detail::measure_marginal(flat.data(), tile.image_floats() / 3));
  }
  const TextureModel fitted(method_name(kind), ModelFrame::of(tile), sub.labels, std::move(models),
                            std::move(heights), s.seed, stored_encoding(s), std::move(moments),
                            std::move(relief));
  // The model as its file holds it (parameters as 32-bit floats): memory and file agree.
  return read_texture_model(kind, fitted.payload(), fitted.file_flags(), "the fitted model");
}

}  // namespace

std::unique_ptr<Representation> fit_car3d(const Btf& tile, const FitOptions& s) {
  return fit_texture_model(TextureKind::kCar3d, tile, s);
}
std::unique_ptr<Representation> fit_car2d(const Btf& tile, const FitOptions& s) {
  return fit_texture_model(TextureKind::kCar2d, tile, s);
}
std::unique_ptr<Representation> fit_gmrf(const Btf& tile, const FitOptions& s) {
  return fit_texture_model(TextureKind::kGmrf, tile, s);
}

std::unique_ptr<Representation> read_car3d(std::span<const std::uint8_t> payload,
                                           std::uint32_t flags, const std::string& name) {
  return read_texture_model(TextureKind::kCar3d, payload, flags, name);
}
std::unique_ptr<Representation> read_car2d(std::span<const std::uint8_t> payload,
                                           std::uint32_t flags, const std::string& name) {
  return read_texture_model(TextureKind::kCar2d, payload, flags, name);
}
std::unique_ptr<Representation> read_gmrf(std::span<const std::uint8_t> payload,
                                          std::uint32_t flags, const std::string& name) {
  return read_texture_model(TextureKind::kGmrf, payload, flags, name);
}

std::vector<FitOptions> texture_model_ladder(const ModelFrame&) {
  std::vector<FitOptions> out;
  for (std::size_t c : {5, 15, 40}) {
    FitOptions s;
    s.clusters = c;
    out.push_back(s);
  }
  return out;
}

}  // namespace btfgmm
