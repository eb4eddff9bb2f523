// PCA BTF (Koudelka, Magda, Belhumeur & Kriegman 2003, "Acquisition, compression and
// synthesis of bidirectional texture functions"): one PCA of all ni x nv images of the tile,
// each image a vector of W x H x 3 values. The model is the mean image, c eigen-images and c
// weights per (light, view) pair; an image is mean + Σ_k w_k(light, view) eigen-image_k.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/methods/measured_images.hpp"

namespace btfgmm {

class PcaBtf final : public MeasuredImages {
 public:
  // mean: W*H*3 values; eigen_images: c x W*H*3 (row-major); weights: c x ni*nv (a row per
  // eigen-image, pairs in the Btf's light-major order), all already stored as `encoding`.
  PcaBtf(ModelFrame frame, std::size_t components, FactorEncoding encoding, std::vector<float> mean,
         std::vector<float> eigen_images, std::vector<float> weights);

  std::size_t components() const { return components_; }
  FactorEncoding encoding() const override { return encoding_; }
  std::span<const float> mean_image() const { return mean_; }
  std::span<const float> eigen_images() const { return eigen_; }
  std::span<const float> weights() const { return weights_; }

  std::string_view method() const override;
  std::string size_text() const override;
  double size_order() const override { return double(parameter_count()); }
  // (c + 1) * 3MN + c * ni * nv (docs/METHODS.md).
  std::uint64_t parameter_count() const override;
  void measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const override;
  void measured_image(std::size_t light, std::size_t view, float* rgb) const override;
  // Measured pairs at the tile's size: all images as one matrix product.
  Btf decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
             double tolerance) const override;
  std::vector<std::uint8_t> payload() const override;
  std::vector<std::pair<std::string, std::string>> details() const override;

 private:
  std::size_t components_;
  FactorEncoding encoding_;
  std::vector<float> mean_, eigen_, weights_;
};

// (c + 1) * 3MN + c * ni * nv: PCA BTF's stored values for c eigen-images on `frame`.
std::uint64_t pca_btf_parameter_count(const ModelFrame& frame, std::size_t components);

// Fits PCA BTF to a tile: s.components = c (default 61 as in the paper's Table 2, at most
// ni*nv - 1 and 3MN), s.precision, s.threads. Throws Error(kArgument) naming --components and
// its range for this tile, or --clusters.
std::unique_ptr<Representation> fit_pca_btf(const Btf& tile, const FitOptions& s);
// Reads PcaBtf::payload(); Error(kFormat) naming `name`.
std::unique_ptr<Representation> read_pca_btf(std::span<const std::uint8_t> payload,
                                             std::uint32_t flags, const std::string& name);
// Eigen-image counts spanning Table 2 ratios from about 1:5 to 1:500 on `frame`.
std::vector<FitOptions> pca_btf_ladder(const ModelFrame& frame);

}  // namespace btfgmm
