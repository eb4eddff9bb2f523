// LPCA (Mueller, Meseth & Klein 2003, "Compression and real-time rendering of measured BTFs
// using local PCA"; the local PCA of Kambhatla & Leen 1997): the texels' apparent BRDFs
// (vectors of ni x nv x 3 values) clustered into k clusters, each with its own PCA (a mean
// and c components), every texel in the cluster that reconstructs it best. Each texel stores
// its cluster index and c weights: its BRDF is mean_a + Σ_k w_k component_{a,k}.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/methods/measured_images.hpp"

namespace btfgmm {

// How the local PCA ended: rounds of per-cluster PCAs, and whether the last moved no texel.
struct LpcaRounds {
  std::uint32_t rounds = 0;
  bool converged = false;
};

class Lpca final : public MeasuredImages {
 public:
  // cluster_of: W*H indices < clusters; means: clusters x ni*nv*3 (BRDF order (light * nv +
  // view) * 3 + channel); basis: clusters*c x ni*nv*3 (cluster a's k-th at row a*c + k);
  // weights: c x W*H (a row per component, a column per texel); all stored as `encoding`.
  Lpca(ModelFrame frame, std::size_t clusters, std::size_t components, FactorEncoding encoding,
       std::vector<std::uint32_t> cluster_of, std::vector<float> means, std::vector<float> basis,
       std::vector<float> weights, LpcaRounds rounds);

  std::size_t clusters() const { return clusters_; }
  std::size_t components() const { return components_; }
  FactorEncoding encoding() const override { return encoding_; }
  std::span<const std::uint32_t> cluster_of() const { return cluster_; }
  std::span<const float> means() const { return means_; }
  std::span<const float> basis() const { return basis_; }
  std::span<const float> weights() const { return weights_; }
  const LpcaRounds& rounds() const { return rounds_; }

  std::string_view method() const override;
  std::string size_text() const override;
  double size_order() const override { return double(parameter_count()); }
  // k * (c + 1) * 3 * ni * nv + MN * (c + 1) (docs/METHODS.md).
  std::uint64_t parameter_count() const override;
  void measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const override;
  void measured_image(std::size_t light, std::size_t view, float* rgb) const override;
  // Measured pairs at the tile's size: a matrix product per cluster.
  Btf decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
             double tolerance) const override;
  std::vector<std::uint8_t> payload() const override;
  std::vector<std::pair<std::string, std::string>> details() const override;

 private:
  std::size_t clusters_, components_;
  FactorEncoding encoding_;
  std::vector<std::uint32_t> cluster_;
  std::vector<float> means_, basis_, weights_;
  LpcaRounds rounds_;
};

// k * (c + 1) * 3 * ni * nv + MN * (c + 1): LPCA's stored values on `frame`.
std::uint64_t lpca_parameter_count(const ModelFrame& frame, std::size_t clusters,
                                   std::size_t components);

// Fits LPCA to a tile: s.clusters = k (default 8, at most the texels), s.components = c
// (default 4, at most 3 * ni * nv and the texels less one), s.iterations = the most rounds
// (default 20), s.seed (k-means++ seeds), s.precision, s.threads. Throws Error(kArgument)
// naming --clusters, --components or --iterations and its range for this tile.
std::unique_ptr<Representation> fit_lpca(const Btf& tile, const FitOptions& s);
// Reads Lpca::payload(); Error(kFormat) naming `name`.
std::unique_ptr<Representation> read_lpca(std::span<const std::uint8_t> payload,
                                          std::uint32_t flags, const std::string& name);
// (k, c) pairs spanning Table 2 ratios from about 1:5 toward 1:500 on `frame`: c = 1 with
// k = 1, 2, 4, 8, then k = 8 with c growing.
std::vector<FitOptions> lpca_ladder(const ModelFrame& frame);

}  // namespace btfgmm
