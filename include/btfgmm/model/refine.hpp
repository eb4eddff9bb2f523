// Fits that aim at the error of the prediction (Eq. 8-11) rather than the likelihood of the
// samples (Eq. 3): after EM, the mixture's colour means are refitted by least squares for the
// gating weights EM found (docs/ALGORITHM.md, "Fitting for the prediction").
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <functional>
#include <string_view>
#include <vector>

#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/provenance.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {

// What a fit optimises: the paper's likelihood of the 9-D samples (EM alone, Eq. 3-7), or,
// from EM's result, the squared error of the prediction (Eq. 8-11) that users measure.
enum class FitObjective { kLikelihood, kPrediction };
// "likelihood", "prediction"; parse: Error(kArgument) naming `option` for another name.
std::string_view objective_name(FitObjective o);
FitObjective parse_objective(std::string_view text, std::string_view option);
// The objective a model's provenance records (its "objective" setting); a fit that records
// none (written before the setting, or by another method) was the paper's: kLikelihood.
FitObjective recorded_objective(const Provenance& p);

// The least-squares problem of the colour means for fixed gating weights: the prediction of
// sample i, channel c, is sum_m W_m(x_I,i) mu_m,6+c (Eq. 8-9, model units, the mean BRDF
// already taken out of the residual r_ic), so its squared error is
//   E_c(mu) = sum_i (r_ic - sum_m W_im mu_mc)^2 = e_c - 2 mu_c . b_c + mu_c^T G mu_c
// with the normal matrix G = sum_i W_i W_i^T (M x M, one for all channels), b_c = sum_i W_i r_ic
// and e_c = sum_i r_ic^2. Weights below e^-25 of a sample's largest are left out.
struct ColourNormalEquations {
  std::size_t components = 0;
  std::vector<double> gram;               // M x M, row-major, symmetric
  std::vector<double> rhs;                // M x 3: b_mc at m * 3 + c
  std::array<double, 3> energy{0, 0, 0};  // e_c
  std::size_t samples = 0;
};
// `stride` > 1: only the samples of pixel p and (light, view) pair l nv + v with p + l nv + v
// divisible by it enter the sums, a systematic subsample for large sample sets that keeps
// every stride-th pixel of every image.
ColourNormalEquations colour_normal_equations(const SampleSet& samples, const ProductMixture& mix,
                                              int threads = 0, std::size_t stride = 1);

// The RMSE (model units: levels) of a squared error summed over `samples` samples' three
// channels.
double prediction_rmse(double squared_error, std::size_t samples);

// sum_c E_c of the mixture's colour means (model units squared).
double prediction_squared_error(const ColourNormalEquations& eq, const ProductMixture& mix);

struct ColourRefit {
  double error_before = 0.0, error_after = 0.0;  // sum_c E_c, model units squared
  double ridge = 0.0;                            // lambda as used
  bool kept = false;  // the solve did not lower the error (round-off): the means were kept
};

// Replaces the colour means mu_m,7..9 with those that minimise
//   E_c(mu) + lambda |mu_c - mu0_c|^2,  lambda = ridge * trace(G) / M,
// mu0 the means given (a small pull towards them keeps components that no sample weighs
// determined), solved in closed form per channel: (G + lambda I) mu_c = b_c + lambda mu0_c.
// The error never increases: the minimum of the pulled objective is at most its value at mu0.
ColourRefit refit_colour_means(const ColourNormalEquations& eq, ProductMixture& mix,
                               double ridge = 1e-6);

// The prediction's squared error E = sum_i sum_c (r_ic - sum_m W_m(x_I,i) mu_m,6+c)^2 (Eq. 8-11,
// model units, over the samples of a stride as colour_normal_equations takes them) and its
// gradient with respect to every parameter the prediction depends on. W_m is the softmax of
// t_m = a_m - 1/2 sum_n s_mn - sum_n d_mn^2 / (2 exp(s_mn)) (Eq. 9-10), a_m = log w_m,
// s_mn = log sigma^2_mn, d_mn = x_n - mu_mn (its minimum image for x and y), so with
// g_im = dE/dt_m = -2 W_im sum_c (r_ic - yhat_ic)(mu_m,6+c - yhat_ic):
//   dE/da_m = sum_i g_im,  dE/dmu_mn = sum_i g_im d_imn / sigma^2_mn,
//   dE/ds_mn = sum_i g_im (d_imn^2 / sigma^2_mn - 1) / 2,
//   dE/dmu_m,6+c = -2 sum_i W_im (r_ic - yhat_ic).
// The sums are taken per pixel, light and view (the exponent's three parts) and reduced in a
// fixed order: the same bit for bit with any number of threads.
struct PredictionGradient {
  double error = 0.0;
  std::vector<double> log_weight;                    // dE/da_m
  std::vector<std::array<double, kVariables>> mean;  // dE/dmu_mn, n = 0..8
  std::vector<std::array<double, kInputs>> log_var;  // dE/ds_mn, n = 0..5
  std::size_t samples = 0;
};
// kDouble: every weight and sum in double (std::exp); kFloat: the weights and the per-sample
// sums in float (fast_exp, vectorised over the components), the totals in double, several
// times faster: what the Adam steps use (within 1e-4 relative of kDouble, tests).
enum class PassPrecision { kDouble, kFloat };
PredictionGradient prediction_gradient(const SampleSet& samples, const ProductMixture& mix,
                                       int threads = 0, std::size_t stride = 1,
                                       PassPrecision precision = PassPrecision::kDouble);

// Where the gradient passes are: after `step` of `steps` Adam steps of round `round` (from 1),
// the RMSE (model units: levels) of the lowest error met, on the passes' subsample.
struct GradientProgress {
  int round = 1, step = 0, steps = 0;
  double rmse = 0.0;
};
using GradientCallback = std::function<void(const GradientProgress&)>;

// The gradient passes of refine_for_prediction: `rounds` times, `steps` Adam steps on all
// parameters at a constant rate (warmed up over the first 20 steps; `rate` in each
// parameter's own unit: a_m, the input means in their units, s_mn; `colour_rate` levels for
// the colour means), the parameters of the lowest error met kept, then the colour means
// refitted in closed form. rounds 0: the colour refit alone. The passes take a systematic
// subsample of about `samples` samples (a stride as colour_normal_equations takes it), the
// refits their own (refine_for_prediction).
struct GradientConfig {
  int rounds = 1;
  int steps = 600;
  double rate = 0.02;
  double colour_rate = 2.0;
  std::size_t samples = 40000;
  GradientCallback progress;  // after every step (may be empty)
  // Checked after every step: when set, the steps end there, the parameters of the lowest
  // error met are kept and closed by the colour refit as after the last step
  // (PredictionRefinement::stopped). Null: never.
  const std::atomic<bool>* stop = nullptr;
};

// The gradient passes a fit can afford beside EM's `em_iterations` iterations over `samples`
// samples, within twice the time of EM alone: steps whose work (steps x the samples of a
// pass) is kGradientWorkShare of EM's (iterations x samples), between kMinGradientSteps and
// kMaxGradientSteps. In a whole fit a sample of a pass costs about four times a sample of an
// EM iteration (EM skips the negligible components of whole groups of samples; a pass weighs
// them all), so the passes take about 0.4 of EM's time; the two colour refits and the last E
// pass add a few per cent (docs/ALGORITHM.md).
constexpr double kGradientWorkShare = 0.10;
constexpr int kMaxRefineSteps = 100000;  // the most a fit may ask for (fit --refine-steps)
constexpr int kMinGradientSteps = 10, kMaxGradientSteps = 1000;
GradientConfig affordable_gradient(std::size_t samples, int em_iterations);

// What refine_for_prediction did: the prediction's squared error (model units squared, all
// samples and channels) after EM and after each stage.
struct PredictionRefinement {
  double error_em = 0.0;      // EM's mixture
  double error_colour = 0.0;  // after the colour means' refit
  double error_final = 0.0;   // after the gradient passes and the last colour refit
  int passes = 0;             // gradient passes (each one over the samples)
  int steps = 0;              // Adam steps taken, every round's
  int steps_planned = 0;      // rounds x steps asked for
  bool stopped = false;       // ended early by GradientConfig::stop
  std::size_t samples = 0;    // of the colour refits' subsample, on which the errors are
};

// The mixture EM fitted, refined for the prediction's error (docs/ALGORITHM.md, "Fitting for
// the prediction"): the colour means refitted by least squares (refit_colour_means), then
// the gradient passes of `gradient` (all parameters, Adam), each round closed by a colour
// refit; the result with the lowest error is kept, so it is never above the first refit's.
// `threads` 0: all cores; the result is the same for any number of threads.
PredictionRefinement refine_for_prediction(const SampleSet& samples, ProductMixture& mix,
                                           int threads = 0, const GradientConfig& gradient = {});

}  // namespace btfgmm
