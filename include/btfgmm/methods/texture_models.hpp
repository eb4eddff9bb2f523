// The probabilistic BTF models of Haindl & Filip (IEEE PAMI 2007, "Extreme compression and
// modeling of bidirectional texture function"), the 3D CAR, 2D CAR and GMRF rows of the
// paper's Table 2 (docs/METHODS.md). They do not reproduce the measured pixels: they learn the
// texture's statistics and synthesise new texture of any size, seamless, from a seed.
//   1. The ni * nv images are clustered into c subspaces (k-means), one representative image
//      and model each, a label per (light, view).
//   2. The tile's range map (methods/range_map.hpp) is stored for its relief.
//   3. Each representative less its relief's structure (methods/relief_structure.hpp: the
//      range map's shape and its slope along the representative's light, fitted by least
//      squares) is modelled (methods/colour_texture.hpp): 3D CAR on the RGB vector, or 2D CAR
//      / GMRF on its Karhunen-Loeve bands, on each level of its Gaussian-Laplacian pyramid
//      (methods/pyramid.hpp; --levels K, default 3 or what the tile holds).
//   4. Each image's mean and deviation per channel (methods/image_moments.hpp), a byte each.
//   5. Any (light, view): the subspace of the nearest measured light and view, synthesised
//      from the seed with its relief's shape added and mapped onto its marginal, its relief's
//      slope along the nearest measured light added, times the range map's bump shading
//      1 + kRelief (s - 1), s = max(0, n.l) / mean_xy max(0, n.l) (the mean taken under the
//      nearest measured light), then moved and scaled per channel to the nearest measured
//      image's mean and deviation.
// Payload (after the model file's method tag): the frame (methods/factors.hpp), u64 seed,
// u8 pyramid levels K (1 in files written before the pyramid), u32 c, ni*nv u8 labels, the
// range map as factors (1 row of W*H heights, f16 unless --precision says otherwise), then c
// subspace models of K levels each, then (file flag kImageMoments, format version 6 on) the
// image moments, predicted as the mixture's mean BRDF is from version 7 on (flag
// kPredictedImageMoments; docs/FORMAT.md), then (flag kReliefStructure, version 8 on) each
// subspace's relief gains. A file without them synthesises as it always did.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/methods/representation.hpp"

namespace btfgmm {
namespace detail {
class ColourTexture;
struct ImageMoments;
struct ReliefStructure;
struct ReliefFeatures;
}  // namespace detail

class TextureModel final : public Representation {
 public:
  // How much of the range map's shading is laid over the synthesis: the subspace images hold
  // the relief's shading already (of their measured light), so a full bump shading would
  // count it twice (docs/METHODS.md).
  static constexpr float kRelief = 0.5f;
  using Subspace = std::shared_ptr<const detail::ColourTexture>;
  // `method`: "3d-car", "2d-car" or "gmrf"; `labels` (ni*nv, light-major) index
  // `subspaces`; `heights` W*H (the range map).
  // `moments`: each image's (ni*nv) mean and deviation, or none (a file before version 6).
  // `relief`: each subspace's relief structure (methods/relief_structure.hpp), added to its
  // synthesis, or none (a file before version 8).
  TextureModel(std::string_view method, ModelFrame frame, std::vector<std::uint8_t> labels,
               std::vector<Subspace> subspaces, std::vector<float> heights, std::uint64_t seed,
               FactorEncoding range_encoding = FactorEncoding::kF16,
               std::shared_ptr<const detail::ImageMoments> moments = nullptr,
               std::shared_ptr<const std::vector<detail::ReliefStructure>> relief = nullptr);

  std::string_view method() const override { return method_; }
  const ModelFrame& frame() const override { return frame_; }
  std::string size_text() const override;
  double size_order() const override { return double(parameter_count()); }
  // Labels (ni*nv) + range map (W*H) + every subspace model's values + 6 per image moments
  // + each subspace's relief gains.
  std::uint64_t parameter_count() const override;

  void predict(std::span<const Query> queries, std::span<float> rgb) const override;
  Btf decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
             double tolerance) const override;

  std::vector<std::uint8_t> payload() const override;
  std::vector<std::pair<std::string, std::string>> details() const override;
  // How the range map is stored (fit --precision; f16 by default); the models' few parameters
  // are 32-bit floats.
  FactorEncoding encoding() const override { return range_encoding_; }
  bool synthesises() const override { return true; }
  // kImageMoments | kPredictedImageMoments where they are stored (a version-6 file's are
  // written again predicted, the same values), | kReliefStructure where the gains are.
  std::uint32_t file_flags() const override;
  void set_synthesis_seed(std::uint64_t seed, std::string_view option) override;

  std::uint64_t seed() const { return seed_; }
  std::span<const std::uint8_t> labels() const { return labels_; }
  std::span<const float> heights() const { return heights_; }
  // The Gaussian-Laplacian pyramid's levels, a model each (every subspace alike).
  int levels() const;

 private:
  std::size_t label_of(const Direction& light, const Direction& view) const;
  // The bump shading of every range-map pixel, 1 + kRelief (s - 1) with s = max(0, n.l) over
  // its mean over the map under the nearest measured light (so that predict and decode agree
  // at any light).
  std::vector<float> shading(const Direction& light) const;
  float shading(std::size_t pixel, const Direction& light) const;  // one pixel's
  // The subspaces' syntheses at the tile's size (what predict reads), made from seed_.
  void synthesise_tiles();
  std::string pyramid_text() const;  // for details()
  // The image nearest (light, view), light-major.
  std::size_t image_of(const Direction& light, const Direction& view) const;
  // The mean and deviation per channel of each subspace's tile-sized synthesis under each
  // measured light's shading (subspace-major, 6 each): what predict scales from.
  void measure_shaded_tiles();

  std::string method_;
  ModelFrame frame_;
  std::vector<std::uint8_t> labels_;
  std::vector<Subspace> subspaces_;
  std::vector<float> heights_, normals_, mean_lit_;
  std::uint64_t seed_;
  FactorEncoding range_encoding_;
  std::vector<std::vector<float>> tiles_;
  std::shared_ptr<const detail::ImageMoments> moments_;
  std::shared_ptr<const std::vector<detail::ReliefStructure>> relief_;
  // The range map's (relief_features), where relief_.
  std::shared_ptr<const detail::ReliefFeatures> relief_features_;
  std::vector<float> shaded_moments_;
  // decode's syntheses at the last size asked, each made when first needed (decode is called
  // a light at a time by the command): guarded by cache_lock_.
  struct Synthesised {
    int width = 0, height = 0;
    std::uint64_t seed = 0;
    std::vector<std::vector<float>> fields;
  };
  const std::vector<float>& synthesised(std::size_t subspace, int width, int height) const;
  // Subspace k's synthesis at width x height from seed_: its model's field, its relief's
  // shape added, mapped onto its marginal.
  std::vector<float> synthesise_subspace(std::size_t k, int width, int height) const;
  // What a light's images share: the bump shading of the range map under it (shading) and
  // the nearest measured light, along which the relief's slope is taken.
  struct Lighting {
    std::vector<float> shade;
    Vec3 measured;
  };
  Lighting lighting_of(const Direction& light) const;
  // Subspace k's synthesis `s` (width x height) under a light: its relief's slope along the
  // nearest measured light added (where the model has a relief), times the bump shading.
  void light_synthesis(std::size_t k, const Lighting& lighting, std::span<const float> s, int width,
                       int height, float* out) const;
  mutable std::mutex cache_lock_;
  mutable Synthesised cache_;
};

// Fit each model to a tile: --clusters c (default 15), --levels K (default 3, or as many as
// the tile holds with the coarsest level at least 8 x 8), the range map stored as
// s.precision says. Throws Error(kArgument) for a tile smaller than 8 x 8, more levels than
// the tile holds (naming the most), fewer than 3 lights near the top for the range map, or
// a size setting the models do not take (--components, --degree, --iterations).
std::unique_ptr<Representation> fit_car3d(const Btf& tile, const FitOptions& s);
std::unique_ptr<Representation> fit_car2d(const Btf& tile, const FitOptions& s);
std::unique_ptr<Representation> fit_gmrf(const Btf& tile, const FitOptions& s);
// Read each payload; Error(kFormat) naming `name`.
std::unique_ptr<Representation> read_car3d(std::span<const std::uint8_t> payload,
                                           std::uint32_t flags, const std::string& name);
std::unique_ptr<Representation> read_car2d(std::span<const std::uint8_t> payload,
                                           std::uint32_t flags, const std::string& name);
std::unique_ptr<Representation> read_gmrf(std::span<const std::uint8_t> payload,
                                          std::uint32_t flags, const std::string& name);
// The sizes sweep fits: c = 5, 15, 40 subspaces.
std::vector<FitOptions> texture_model_ladder(const ModelFrame& frame);

}  // namespace btfgmm
