// PCA RF (Sattler, Sarlette & Klein 2003, "Efficient and realistic visualization of cloth"):
// a separate PCA per view of that view's ni images, each image a vector of W x H x 3 values.
// Per view the model is a mean image, c eigen-images and c weights per light; the image of
// (light, view) is mean_view + Σ_k w_k(view, light) eigen-image_k(view).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/methods/measured_images.hpp"

namespace btfgmm {

class PcaRf final : public MeasuredImages {
 public:
  // means: nv x W*H*3; eigen_images: nv*c x W*H*3 (view v's k-th at row v*c + k); weights:
  // nv*c x ni (the same rows, a column per light); all already stored as `encoding`.
  PcaRf(ModelFrame frame, std::size_t components, FactorEncoding encoding, std::vector<float> means,
        std::vector<float> eigen_images, std::vector<float> weights);

  std::size_t components() const { return components_; }
  FactorEncoding encoding() const override { return encoding_; }
  std::span<const float> mean_images() const { return means_; }
  std::span<const float> eigen_images() const { return eigen_; }
  std::span<const float> weights() const { return weights_; }

  std::string_view method() const override;
  std::string size_text() const override;
  double size_order() const override { return double(parameter_count()); }
  // nv * ((c + 1) * 3MN + c * ni) (docs/METHODS.md).
  std::uint64_t parameter_count() const override;
  void measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const override;
  void measured_image(std::size_t light, std::size_t view, float* rgb) const override;
  // Measured pairs at the tile's size: a matrix product per view.
  Btf decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
             double tolerance) const override;
  std::vector<std::uint8_t> payload() const override;
  std::vector<std::pair<std::string, std::string>> details() const override;

 private:
  std::size_t components_;
  FactorEncoding encoding_;
  std::vector<float> means_, eigen_, weights_;
};

// nv * ((c + 1) * 3MN + c * ni): PCA RF's stored values for c eigen-images a view on `frame`.
std::uint64_t pca_rf_parameter_count(const ModelFrame& frame, std::size_t components);

// Fits PCA RF to a tile: s.components = c (default 6 as in the paper's Table 2, at most
// ni - 1 and 3MN), s.precision, s.threads. Throws Error(kArgument) naming --components and its
// range for this tile, or --clusters.
std::unique_ptr<Representation> fit_pca_rf(const Btf& tile, const FitOptions& s);
// Reads PcaRf::payload(); Error(kFormat) naming `name`.
std::unique_ptr<Representation> read_pca_rf(std::span<const std::uint8_t> payload,
                                            std::uint32_t flags, const std::string& name);
// Eigen-image counts spanning Table 2 ratios from about 1:5 toward 1:500 on `frame` (a
// per-view PCA cannot pass 1:ni).
std::vector<FitOptions> pca_rf_ladder(const ModelFrame& frame);

}  // namespace btfgmm
