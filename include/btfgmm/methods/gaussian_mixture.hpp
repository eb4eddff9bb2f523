// The paper's Gaussian mixture (model/model.hpp, Eq. 1-11) as one Representation among the
// methods: fitted by EM (model/fit.hpp), predicted by Eq. (8)-(11), decoded on the grid.
#pragma once

#include <memory>
#include <span>
#include <string_view>

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
  // predict and decode on a compute device (model/predict_gpu.hpp): true for any device.
  bool compute_on(std::shared_ptr<ComputeDevice> device) override;

 private:
  BtfModel model_;
  ModelFrame frame_;
  std::shared_ptr<ComputeDevice> device_;  // null: the CPU
};

// fit_model (model/fit.hpp) with `s`: components M (default 600), iterations (default 40),
// seed; the encoding kF16 stores the parameters as half floats, kQ8 is refused.
std::unique_ptr<Representation> fit_gaussian_mixture(const Btf& tile, const FitOptions& s);

// `fit --budget`'s quick search of the mixture's size (QuickSizeSearch, methods/registry.hpp):
// a probe is EM's first kProbeIterations iterations alone (the likelihood objective), whose
// file's components take about 1 / kProbeBytesRatio of the bytes of the same M's fitted as the
// search fits its choice: at most kBudgetIterations EM iterations (unless `iterations` is given),
// then the refinement for the prediction as by default. On generated knit 25 x 25 at M = 1998,
// 6 EM iterations before the refinement gave 28.65 dB, 12 gave 27.70, and the default 40 gave
// 26.50 at M = 1919, the same bytes; 3 gave 0.13 dB more than 6 there, but less on 12 x 12
// tiles (docs/BENCHMARKS.md). The search brings a file over the
// budget within it by coarser steps (coarsened_mixture), so an error of a few percent in the
// ratio costs no refit.
inline constexpr int kProbeIterations = 1;
inline constexpr double kProbeBytesRatio = 1.15;
inline constexpr int kBudgetIterations = 6;
FitOptions mixture_byte_probe(const FitOptions& s);
FitOptions mixture_budget_choice(FitOptions s, std::span<const std::string_view> given);

// The most components the fit of `s` takes on a tile of `frame`: for the prediction objective,
// supported_components of its samples (model/refine.hpp); no bound for the likelihood.
std::size_t mixture_most_components(const ModelFrame& frame, const FitOptions& s);

// The mixture with no components (its mean BRDF, frame and provenance kept): its file holds
// the bytes that do not grow with M. Throws Error(kArgument) for another method's model.
std::unique_ptr<Representation> mixture_without_components(const Representation& model);

// A copy of a mixture stored with the quantisation steps of its weights, deviations and means
// (docs/FORMAT.md: s_w, s_sigma, s_mu, s_c) `factor` times as coarse; the mean BRDF's step is
// kept. Throws Error(kArgument) for another method's model or a factor below 1.
std::unique_ptr<Representation> coarsened_mixture(const Representation& model, double factor);

}  // namespace btfgmm
