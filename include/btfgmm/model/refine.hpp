// Fits that aim at the error of the prediction (Eq. 8-11) rather than the likelihood of the
// samples (Eq. 3): after EM, the mixture's colour means are refitted by least squares for the
// gating weights EM found (docs/ALGORITHM.md, "Fitting for the prediction").
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string_view>
#include <utility>
#include <vector>

#include "btfgmm/gpu/compute_device.hpp"
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
// every stride-th pixel of every image. `training`: the validation samples
// (validation_sample) left out. Summed light by light, folded in light order over the
// processes of a distributed set: the same for any number of threads and processes. `stop`
// set while it runs: the remaining samples are skipped (checked at every sample) and the
// sums are incomplete; the caller, which gave the flag, discards them. `progress`, where
// given, is called with the share of this process's lights summed as each is folded in.
ColourNormalEquations colour_normal_equations(
    const SampleSet& samples, const ProductMixture& mix, int threads = 0, std::size_t stride = 1,
    bool training = false, const std::atomic<bool>* stop = nullptr,
    const std::function<void(double fraction)>& progress = {});

// About the samples the closed-form colour refit of refine_for_prediction takes: 3 M unknowns
// against a quarter of a million equations; the sums over every image of a large tile (M^2 / 2
// products a sample) would cost more than EM's iterations (docs/ALGORITHM.md, "The cost of
// an epoch"). The Adam epochs fit the colour means to every training sample.
constexpr std::size_t kColourRefitSamples = 250000;

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
  // The fraction of the samples' components weighed: 1 in the double pass; the float pass
  // skips chunks of components whose weights are negligible (below e^-17.5 of a sample's
  // weights together) and weighs this share.
  double weighed = 1.0;
};
// kDouble: every weight and sum in double (std::exp), every component of every sample;
// kFloat: the weights and the per-sample sums in float (fast_exp, vectorised over chunks of
// 16 components), the totals in double, only the chunks of components whose weights are not
// negligible for the sample weighed (docs/ALGORITHM.md, "The cost of an epoch"): what the
// Adam steps use (within 1e-4 relative of kDouble, tests).
enum class PassPrecision { kDouble, kFloat };
PredictionGradient prediction_gradient(const SampleSet& samples, const ProductMixture& mix,
                                       int threads = 0, std::size_t stride = 1,
                                       PassPrecision precision = PassPrecision::kDouble);

// The prediction's squared error (model units squared) over the validation samples
// (validation_sample) and their count, in the float pass the refinement validates with.
std::pair<double, std::size_t> validation_error(const SampleSet& samples, const ProductMixture& mix,
                                                int threads = 0);

// The held-out validation set of the fit for the prediction: 1 in kValidationEvery samples of
// the tile (pixels x directions), chosen by a hash of the sample's place in the whole tile,
// pixel p and (light, view) pair j = l nv + v of `pairs` = ni nv, so the same on any number
// of processes. No step of the refinement uses them; they choose the parameters kept and
// when to stop (docs/ALGORITHM.md, "Fitting for the prediction").
constexpr std::size_t kValidationEvery = 20;
bool validation_sample(std::size_t pixel, std::size_t pair, std::size_t pairs);

// The most epochs a refinement takes (GradientConfig::max_epochs; fit --refine-epochs).
constexpr int kMaxRefineEpochs = 1000;

// The refinement's default bound on its work: at most this many Adam steps, the stopping
// rule on. A step weighs M components of a minibatch, so its cost grows with M as the earlier
// default bound in time did (M / 6 s), but a bound in steps gives the same model at any load,
// with any thread count and on any machine (docs/ALGORITHM.md, "Reproducible fits"). 2,400
// steps are about 10 epochs of a 25 x 25 tile of 81 x 81 directions, what that time bound gave
// on a quiet 2-core machine at M = 600.
constexpr int kDefaultRefineSteps = 2400;

// Where the refinement is, after a validation: `step` Adam steps in `epoch` epochs (passes
// over the training samples, from 1); the validation RMSE (model units: levels) of the
// parameters just reached and the lowest met, the training RMSE over the last epoch's
// minibatches, and the seconds since the refinement began of at most `seconds`.
struct GradientProgress {
  int epoch = 1, step = 0, steps = 0;   // steps: those asked for (GradientConfig::steps), or 0
  int max_steps = kDefaultRefineSteps;  // GradientConfig::max_steps (0: none)
  double validation_rmse = 0.0, best_validation_rmse = 0.0, training_rmse = 0.0;
  double elapsed = 0.0, seconds = 0.0;
  // How far along, 0 before the first step to 1 after the last: of the steps asked for, or the
  // most of the step bound's, the time bound's, the epochs' and the stopping rule's halvings'
  // shares.
  double fraction = 0.0;
  int max_epochs = kMaxRefineEpochs;  // GradientConfig::max_epochs
  // A colour refit under way (before the steps, or after them): `fraction` is its share
  // done, `elapsed` its seconds; the other fields are those of the last validation.
  bool colour_refit = false;
};
using GradientCallback = std::function<void(const GradientProgress&)>;

constexpr double kMaxRefineSeconds = 7.0 * 24 * 3600;
constexpr int kMaxRefineSteps = 100000;  // the most a fit may ask for (fit --refine-steps)

// The gradient epochs of refine_for_prediction: Adam steps (Kingma & Ba 2015) on every
// parameter over minibatches of about `batch` training samples, the batches of an epoch
// covering every training sample of the tile once (in an order drawn from `seed`), at a rate
// (`rate` in each parameter's own unit: a_m, the input means, s_mn; `colour_rate` levels for
// the colour means) warmed up over the first 20 steps and halved whenever the validation
// error has not fallen by `min_gain` (relative) over `patience` validations (each a quarter
// of an epoch); the steps end after `plateaus` such halvings, after `max_steps` steps, after
// `max_epochs`, after `seconds` (none by default: a bound in time makes the model depend on
// the machine and its load), or when `stop` is set, and the parameters of the lowest
// validation error met are kept. `steps` > 0: exactly that many steps instead (the rule and
// max_steps off; seconds and stop still end them). gradient false: the colour refit alone.
struct RefinementEstimate;
struct GradientConfig {
  bool gradient = true;
  int steps = 0;
  int max_steps = kDefaultRefineSteps;  // 0: no bound in steps
  double seconds = kMaxRefineSeconds;
  int max_epochs = kMaxRefineEpochs;
  int patience = 4;
  int plateaus = 3;
  double min_gain = 1e-3;
  double rate = 0.02;
  double colour_rate = 2.0;
  std::size_t batch = 16384;
  std::uint64_t seed = 1;
  // Before the first step, after every validation, after the last; during each colour refit,
  // as its lights are summed (GradientProgress::colour_refit).
  GradientCallback progress;
  // Where set, called before any work with what the refinement will take, timed on the mixture
  // it starts from (estimate_refinement).
  std::function<void(const RefinementEstimate&)> planned;
  // Checked after every step: when set, the steps end there, the parameters of the lowest
  // validation error met are kept and closed by the colour refit as after the last step
  // (PredictionRefinement::stopped). Null: never.
  const std::atomic<bool>* stop = nullptr;
  // Where set, the gradient passes, the validations and the colour refits' normal equations
  // run on this device (docs/GPU.md), the same numbers but for the order of float sums and the
  // negligible weights the CPU skips; the refits' solves stay on the CPU. Null: the CPU.
  std::shared_ptr<ComputeDevice> device = {};
};

// What the refinement of `gradient` will take on this machine, timed on `mix`: one Adam step
// (a minibatch's gradient pass), a validation (on an eighth of the held-out samples, scaled),
// the colour refits (their normal equations on at most a sixteenth of the refit's subsample,
// fewer samples as M grows, scaled; their solve on at most 1,000 components, scaled as M^3),
// the steps its bounds allow and the seconds in all: at most about, since the stopping rule
// may end the steps sooner. Costs about two steps and a second at most of sums; a set
// gradient.stop ends it early (its figures then of no use).
struct RefinementEstimate {
  double colour_refit_seconds = 0.0;  // both refits (one without the gradient steps)
  double step_seconds = 0.0;
  double validation_seconds = 0.0;
  std::size_t steps_per_epoch = 0;
  long long steps = 0;      // at most, by the bounds in steps and epochs
  bool time_bound = false;  // the bound in time (GradientConfig::seconds) ends them first
  double seconds = 0.0;     // in all
};
RefinementEstimate estimate_refinement(const SampleSet& samples, const ProductMixture& mix,
                                       int threads, const GradientConfig& gradient);

// The most components a tile supports for the fit for the prediction: one per
// kSamplesPerComponent training samples (16 parameters each); more are refused before the
// work (fit --components).
constexpr std::size_t kSamplesPerComponent = 64;
std::size_t supported_components(std::size_t samples);

// What refine_for_prediction did: the prediction's squared error (model units squared, over
// the validation samples, all channels) after EM and after each stage.
struct PredictionRefinement {
  double error_em = 0.0;       // EM's mixture
  double error_colour = 0.0;   // after the colour means' refit
  double error_final = 0.0;    // the mixture kept
  double training_rmse = 0.0;  // levels, over the last epoch's minibatches (0: no steps)
  int passes = 0;              // validation and gradient passes over parts of the samples
  int steps = 0;               // Adam steps taken
  int steps_planned = 0;       // GradientConfig::steps (0: the stopping rule's)
  int epochs = 0;              // epochs begun
  bool stopped = false;        // ended early by GradientConfig::stop
  bool step_bound = false;     // ended by GradientConfig::max_steps
  bool timed_out = false;      // ended by GradientConfig::seconds
  bool epoch_bound = false;    // ended by GradientConfig::max_epochs
  std::size_t samples = 0;     // validation samples, on which the errors are
  std::size_t training_samples = 0;
  std::size_t batch_samples = 0;      // training samples of a minibatch (about)
  double seconds = 0.0;               // the whole refinement's
  double gradient_seconds = 0.0;      // its epochs' (steps and validations)
  double gradient_cpu_seconds = 0.0;  // the same epochs' CPU time, of every thread
  double weighed = 1.0;               // PredictionGradient::weighed over the last epoch's steps
};

// The mixture EM fitted, refined for the prediction's error (docs/ALGORITHM.md, "Fitting for
// the prediction"): the colour means refitted by least squares (refit_colour_means, on the
// training samples), then the gradient epochs of `gradient` (all parameters, Adam, every
// training sample), closed by a colour refit; of EM's mixture and each stage's, the one of
// the lowest validation error is kept, so the result's is never above EM's. Over several
// processes (samples.processes) every sum is folded in light order: the same result.
// `threads` 0: all cores; the result is the same for any number of threads.
PredictionRefinement refine_for_prediction(const SampleSet& samples, ProductMixture& mix,
                                           int threads = 0, const GradientConfig& gradient = {});

}  // namespace btfgmm
