// The float pass of the fit for the prediction (refine_gradient.cpp, the Adam steps and their
// validations): the prediction's squared error (Eq. 8-11) over the samples of a selection and
// its gradient, as prediction_gradient defines them, weighing for each sample only the
// components whose conditional weight W_m(x_I) (Eq. 9) can matter.
//
// The components are laid out in chunks of kChunk, in a k-d order of their input means
// (each input scaled by its median standard deviation), so that a chunk's components lie
// close together in the inputs and are negligible for a sample together. For each sample the
// exponents t_m of every component are summed from the pixel's, light's and view's rows (as
// the grid weights are); a chunk whose largest t_m lies more than the margin
// Delta = log M + kSkipMargin below the sample's largest is skipped: its weights, each below
// e^-Delta, together below e^-kSkipMargin (about 2.5e-8) of the sample's weights, are taken
// as zero, which changes the prediction by less than float's rounding. The others (the live
// chunks) get their exp, the prediction and the gradient's sums: the costly part of a sample,
// done only where it counts. Sums across the lanes of a chunk are taken lane by lane and
// folded in a fixed order, so the pass is the same bit for bit on any number of threads and
// processes (the lights' sums folded as in GradientPass, refine_internal.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"
#include "model/mixture_internal.hpp"
#include "model/refine_internal.hpp"

namespace btfgmm::detail {

// Components a chunk; a chunk is one vector of floats on AVX-512.
constexpr std::size_t kChunk = 16;
// The skip margin beyond log M (natural log units): the skipped weights of a sample sum to
// at most e^-17.5 of its weights (EM's E pass skips at the same margin, em_tables.cpp).
constexpr double kSkipMargin = 17.5;

class SparsePass final : public PredictionPass {
 public:
  SparsePass(const SampleSet& s, std::size_t m, int threads);
  // The error (and, with `gradient`, the gradient) of `mix` over the samples of `selection`.
  PredictionGradient operator()(const ProductMixture& mix, const Selection& selection,
                                bool gradient = true) override;
  ColourNormalEquations normal_equations(const ProductMixture& mix, std::size_t stride,
                                         const std::atomic<bool>* stop,
                                         const std::function<void(double)>& progress) override;

  // One thread's working space.
  struct Scratch {
    std::vector<float> t_storage, chunk_max;
    std::vector<std::uint32_t> live, taken;
    explicit Scratch(std::size_t views, std::size_t stride);
    float* t();  // the sample's exponents, then weights, at a 64-byte boundary
  };
  // A light's sums over its samples: the error, the samples and the live chunks met, and with
  // the gradient, at `sums` (sums_size() floats, the columns in the order): g_m per view
  // (nv rows), dE/dmu_m,6+c (3 rows), g_m times the pixel's 4 rows (d / sigma^2 and
  // (d^2 / sigma^2 - 1) / 2 of x and y), g_m (1 row). Kept from one pass to the next, cleared
  // as they are folded.
  struct LightSums {
    double error = 0.0;
    std::size_t samples = 0, live_chunks = 0;
    float* sums = nullptr;
  };

 private:
  std::size_t chunks() const { return stride_ / kChunk; }
  // The rows of a light's sums and of the totals (the lights' rows of g_m last in the totals).
  std::size_t at_colour() const { return s_.views * stride_; }
  std::size_t at_position() const { return at_colour() + 3 * stride_; }
  std::size_t at_light() const { return at_position() + 4 * stride_; }
  std::size_t sums_size() const { return at_light() + stride_; }
  std::size_t total_size() const { return at_light() + s_.lights * stride_ + 3; }

  void set_order(const ProductMixture& mix);
  void set_tables(const ProductMixture& mix);
  std::size_t live_chunks(Scratch& sc, float& top) const;
  void add_sample(std::size_t p, std::size_t l, std::size_t v, Scratch& sc, LightSums& acc) const;
  void add_gradient(std::size_t p, std::size_t v, const float* w, float inv, const float (&e)[3],
                    float base, std::size_t n_live, const Scratch& sc, float* sums) const;
  void add_pixel(std::size_t p, std::size_t l, Scratch& sc, LightSums& acc) const;
  void sum_over_lights();
  void fold_lights(std::vector<double>& t);
  PredictionGradient result(const ProductMixture& mix) const;

  const SampleSet& s_;
  std::size_t m_, stride_;
  int threads_;
  float margin_;  // Delta = log M + kSkipMargin
  Selection selection_;
  bool gradient_ = true;
  Periods periods_;
  std::vector<std::size_t> order_;           // column k holds component order_[k]
  std::vector<float> pixel_, light_, view_;  // the exponents' parts, stride a row
  std::vector<float> colour_;                // mu_m,6+c, 3 rows
  std::vector<float> spatial_;               // mu_m0, mu_m1, 1 / sigma^2_m0, 1 / sigma^2_m1
  std::vector<float> light_sums_;            // sums_size() a held light
  std::vector<LightSums> per_light_;         // a held light's
  std::vector<double> total_;
  std::vector<Scratch> scratch_;  // a thread's
};

}  // namespace btfgmm::detail
