// The paper's Gaussian mixture (model/model.hpp, Eq. 1-11) as one Representation among the
// methods: fitted by EM (model/fit.hpp), predicted by Eq. (8)-(11), decoded on the grid.
#pragma once

#include <memory>

#include "btfgmm/methods/representation.hpp"
#include "btfgmm/model/model.hpp"

namespace btfgmm {

class GaussianMixture final : public Representation {
 public:
  // The model's provenance moves to provenance(); model().provenance is left empty.
  explicit GaussianMixture(BtfModel model);

  const BtfModel& model() const { return model_; }

  std::string_view method() const override;
  const ModelFrame& frame() const override { return frame_; }
  std::string size_text() const override;
  double size_order() const override { return double(model_.mixture.size()); }
  // M*9*2 means and deviations plus the ni*nv*3 values of the mean BRDF.
  std::uint64_t parameter_count() const override;
  // The paper's own count (bytes: floats and an 8-bit mean BRDF), BtfModel's.
  double paper_ratio() const override { return model_.compression_ratio_paper(); }
  void predict(std::span<const Query> queries, std::span<float> rgb) const override;
  Btf decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
             double tolerance) const override;
  std::vector<std::uint8_t> payload() const override;
  std::uint32_t file_flags() const override;  // mixture_file_flags
  std::vector<std::pair<std::string, std::string>> details() const override;
  FactorEncoding encoding() const override;

 private:
  BtfModel model_;
  ModelFrame frame_;
};

// fit_model (model/fit.hpp) with `s`: components M (default 600), iterations (default 40),
// seed; the encoding kF16 stores the parameters as half floats, kQ8 is refused.
std::unique_ptr<Representation> fit_gaussian_mixture(const Btf& tile, const FitOptions& s);

}  // namespace btfgmm
