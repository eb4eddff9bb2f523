// The least-squares refit of the colour means for the prediction (Eq. 8-11) on the sample
// grid: the conditional weights of every sample (model/grid_weights.hpp), the normal matrix
// and right-hand sides, and the closed-form solve (Eigen's LDLT).
#include "btfgmm/model/refine.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "core/eigen_dense.hpp"
#include "model/grid_weights.hpp"
#include "model/refine_internal.hpp"

namespace btfgmm {

std::string_view objective_name(FitObjective o) {
  return o == FitObjective::kLikelihood ? "likelihood" : "prediction";
}

FitObjective parse_objective(std::string_view text, std::string_view option) {
  if (text == "likelihood") return FitObjective::kLikelihood;
  if (text == "prediction") return FitObjective::kPrediction;
  throw Error(Error::Kind::kArgument,
              fmt::format("{} '{}': give likelihood (the paper's EM alone) or prediction (EM, "
                          "then the colour means refitted for the prediction's error)",
                          option, text));
}

FitObjective recorded_objective(const Provenance& p) {
  for (const auto& [name, value] : p.fit.settings)
    if (name == "objective") return parse_objective(value, "the model's objective");
  return FitObjective::kLikelihood;
}

namespace {

// One thread's share of the normal equations (one chunk of pixels at a time), in batches of kBatch
// samples: their weights as the rows of a dense matrix B, then G += B^T B and b += B^T r (BLAS-3
// products: at M = 600 a sample's weights are mostly above e^-25, so G gains most of its M^2 / 2
// terms per sample).
constexpr Eigen::Index kBatch = 256;
struct Accumulator {
  Eigen::MatrixXd gram, rhs, batch, colour;
  std::array<double, 3> energy{0, 0, 0};
  Eigen::Index rows = 0;
  std::size_t samples = 0;
  explicit Accumulator(std::size_t m)
      : gram(Eigen::MatrixXd::Zero(Eigen::Index(m), Eigen::Index(m))),
        rhs(Eigen::MatrixXd::Zero(Eigen::Index(m), 3)),
        batch(Eigen::MatrixXd::Zero(kBatch, Eigen::Index(m))),
        colour(kBatch, 3) {}
  void add(const detail::SampleWeights& s) {
    for (std::size_t a = 0; a < s.component.size(); ++a)
      batch(rows, Eigen::Index(s.component[a])) = s.weight[a];
    for (int c = 0; c < 3; ++c) {
      colour(rows, c) = s.residual[c];
      energy[std::size_t(c)] += double(s.residual[c]) * s.residual[c];
    }
    if (++rows == kBatch) flush();
  }
  void flush() {
    if (rows == 0) return;
    const auto b = batch.topRows(rows);
    gram.selfadjointView<Eigen::Upper>().rankUpdate(b.transpose());
    rhs.noalias() += b.transpose() * colour.topRows(rows);
    batch.topRows(rows).setZero();
    rows = 0;
  }
  void clear() {
    gram.setZero();
    rhs.setZero();
    energy = {0, 0, 0};
    samples = 0;
  }
};

}  // namespace

ColourNormalEquations colour_normal_equations(const SampleSet& samples, const ProductMixture& mix,
                                              int threads, std::size_t stride, bool training,
                                              const std::atomic<bool>* stop,
                                              const std::function<void(double)>& progress) {
  const std::size_t m = mix.size();
  ColourNormalEquations eq;
  eq.components = m;
  const detail::GridWeights grid(samples, mix, std::max<std::size_t>(stride, 1), training);
  // The totals as one vector: G's upper triangle (row-major, all M^2 places), b, e, the count.
  const std::size_t at_rhs = m * m, at_energy = at_rhs + 3 * m, at_count = at_energy + 3;
  std::size_t count = 0, folded = 0;
  std::vector<double> total = detail::fold_over_processes(
      samples.processes.get(), at_count + 1, [&](std::vector<double>& t) {
        grid.reduce_over_lights(
            threads, [m] { return Accumulator(m); },
            [stop](const detail::SampleWeights& s, Accumulator& acc) {
              if (stop && stop->load(std::memory_order_relaxed)) return;
              acc.add(s);
              ++acc.samples;
            },
            [&t, &count, &folded, &progress, &samples, m, at_rhs, at_energy](Accumulator& acc) {
              acc.flush();
              if (progress) progress(double(++folded) / double(samples.held_lights()));
              for (std::size_t a = 0; a < m; ++a) {
                for (std::size_t b = a; b < m; ++b)
                  t[a * m + b] += acc.gram(Eigen::Index(a), Eigen::Index(b));
                for (std::size_t c = 0; c < 3; ++c)
                  t[at_rhs + a * 3 + c] += acc.rhs(Eigen::Index(a), Eigen::Index(c));
              }
              for (std::size_t c = 0; c < 3; ++c) t[at_energy + c] += acc.energy[c];
              count += acc.samples;
              acc.clear();
            },
            stop);
        t[at_count] += double(count);
      });
  eq.gram.assign(total.begin(), total.begin() + std::ptrdiff_t(at_rhs));
  eq.rhs.assign(total.begin() + std::ptrdiff_t(at_rhs), total.begin() + std::ptrdiff_t(at_energy));
  for (std::size_t c = 0; c < 3; ++c) eq.energy[c] = total[at_energy + c];
  eq.samples = std::size_t(total[at_count]);
  for (std::size_t a = 0; a < m; ++a)  // the lower triangle from the upper
    for (std::size_t b = a + 1; b < m; ++b) eq.gram[b * m + a] = eq.gram[a * m + b];
  return eq;
}

double prediction_rmse(double squared_error, std::size_t samples) {
  return std::sqrt(squared_error / double(3 * std::max<std::size_t>(samples, 1)));
}

double prediction_squared_error(const ColourNormalEquations& eq, const ProductMixture& mix) {
  const std::size_t m = eq.components;
  double total = 0.0;
  for (int c = 0; c < 3; ++c) {
    double lin = 0.0, quad = 0.0;
    for (std::size_t a = 0; a < m; ++a) {
      const double mu = mix.mean[a][std::size_t(6 + c)];
      lin += mu * eq.rhs[a * 3 + std::size_t(c)];
      double g = 0.0;
      for (std::size_t b = 0; b < m; ++b) g += eq.gram[a * m + b] * mix.mean[b][std::size_t(6 + c)];
      quad += mu * g;
    }
    total += eq.energy[std::size_t(c)] - 2.0 * lin + quad;
  }
  return total;
}

ColourRefit refit_colour_means(const ColourNormalEquations& eq, ProductMixture& mix, double ridge) {
  const std::size_t m = eq.components;
  if (m != mix.size() || m == 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("refit_colour_means: normal equations of {} components for a "
                            "mixture of {}",
                            m, mix.size()));
  ColourRefit out;
  out.error_before = prediction_squared_error(eq, mix);
  const Eigen::Map<const Eigen::MatrixXd> gram(eq.gram.data(), Eigen::Index(m), Eigen::Index(m));
  const double trace = gram.trace();
  out.ridge = ridge * (trace > 0.0 ? trace / double(m) : 1.0);
  Eigen::MatrixXd a = gram;
  a.diagonal().array() += out.ridge;
  Eigen::MatrixXd rhs(Eigen::Index(m), 3);
  for (std::size_t k = 0; k < m; ++k)
    for (int c = 0; c < 3; ++c)
      rhs(Eigen::Index(k), c) =
          eq.rhs[k * 3 + std::size_t(c)] + out.ridge * mix.mean[k][std::size_t(6 + c)];
  const Eigen::MatrixXd mu = a.ldlt().solve(rhs);
  ProductMixture refitted = mix;
  for (std::size_t k = 0; k < m; ++k)
    for (int c = 0; c < 3; ++c) refitted.mean[k][std::size_t(6 + c)] = mu(Eigen::Index(k), c);
  out.error_after = prediction_squared_error(eq, refitted);
  if (!(out.error_after <= out.error_before) || !mu.allFinite()) {
    out.error_after = out.error_before;
    out.kept = true;
    return out;
  }
  mix = std::move(refitted);
  return out;
}

bool validation_sample(std::size_t pixel, std::size_t pair, std::size_t pairs) {
  return detail::mix_bits(std::uint64_t(pixel) * pairs + pair) % kValidationEvery == 0;
}

std::size_t supported_components(std::size_t samples) {
  return samples * (kValidationEvery - 1) / kValidationEvery / kSamplesPerComponent;
}

namespace detail {

bool any_process(Communicator* processes, bool mine) {
  if (!processes || processes->size() == 1) return mine;
  const std::uint8_t flag = mine ? 1 : 0;
  for (const auto& r : all_gather_values<std::uint8_t>(*processes, std::span(&flag, 1)))
    if (!r.empty() && r[0]) return true;
  return false;
}

}  // namespace detail

namespace {

// The colour means of `mix` refitted on the training samples of the refit's subsample, kept
// where they lower the validation error `error`; returns the validation error of `mix`. Set
// `gradient.stop` ends it without a refit; `gradient.progress` is told how far the sums are.
double refit_where_it_validates(const SampleSet& samples, ProductMixture& mix,
                                detail::PredictionPass& pass, double error,
                                const GradientConfig& gradient) {
  const std::size_t stride = detail::subsample_stride(samples.size(), kColourRefitSamples);
  ProductMixture trial = mix;
  const auto t0 = Clock::now();
  std::function<void(double)> progress;
  if (gradient.progress)
    progress = [&gradient, t0](double fraction) {
      gradient.progress({.max_steps = gradient.max_steps,
                         .elapsed = seconds_since(t0),
                         .seconds = gradient.seconds,
                         .fraction = fraction,
                         .max_epochs = gradient.max_epochs,
                         .colour_refit = true});
    };
  const ColourNormalEquations eq = pass.normal_equations(trial, stride, gradient.stop, progress);
  if (gradient.stop && gradient.stop->load()) return error;
  refit_colour_means(eq, trial);
  const detail::Selection validation{1, 0, detail::Selection::Part::kValidation};
  const double after = detail::selection_error(pass, trial, validation).first;
  if (!(after < error)) return error;
  mix = std::move(trial);
  return after;
}

// The seconds of the closed-form solve of a colour refit: timed on the first min(M, 1000)
// components of `part`, scaled as M^3.
double time_solve(const ColourNormalEquations& part, const ProductMixture& mix) {
  constexpr std::size_t kSolved = 1000;
  const std::size_t m = std::min(mix.size(), kSolved);
  ColourNormalEquations eq;
  eq.components = m;
  eq.gram.resize(m * m);
  eq.rhs.assign(part.rhs.begin(), part.rhs.begin() + std::ptrdiff_t(m * 3));
  eq.energy = part.energy;
  for (std::size_t i = 0; i < m; ++i)
    std::copy_n(part.gram.begin() + std::ptrdiff_t(i * mix.size()), m,
                eq.gram.begin() + std::ptrdiff_t(i * m));
  ProductMixture head = mix;
  head.resize(m);
  const auto at = Clock::now();
  refit_colour_means(eq, head);
  return seconds_since(at) * std::pow(double(mix.size()) / double(m), 3.0);
}

// The samples the estimate of a colour refit sums: at most a sixteenth of the refit's
// subsample, fewer as M grows (a sample costs up to M^2 / 2 products), at least 2,000 so that the
// two timings of time_colour_refit differ by more than their noise.
std::size_t estimate_samples(std::size_t components) {
  const double m = double(std::max<std::size_t>(components, 1));
  return std::clamp<std::size_t>(std::size_t(8e9 / (m * m)), 2000, kColourRefitSamples / 16);
}

// The seconds of one colour refit: its normal equations on estimate_samples of the refit's
// subsample, scaled, and the solve on the first min(M, 1000) components, scaled as M^3. A set
// `stop` ends it (the estimate is then of no use).
double time_colour_refit(const SampleSet& samples, const ProductMixture& mix, int threads,
                         const std::atomic<bool>* stop) {
  const std::size_t stride = detail::subsample_stride(samples.size(), kColourRefitSamples);
  const std::size_t sparse =
      std::max(stride, detail::subsample_stride(samples.size(), estimate_samples(mix.size())));
  // Timed on two subsamples, the second half the first: the sums cost a part per sample and a
  // part per light (each light's M x M sums folded in), which the two times tell apart.
  auto at = Clock::now();
  const ColourNormalEquations half =
      colour_normal_equations(samples, mix, threads, 2 * sparse, true, stop);
  const double t_half = seconds_since(at);
  at = Clock::now();
  const ColourNormalEquations part =
      colour_normal_equations(samples, mix, threads, sparse, true, stop);
  const double t_part = seconds_since(at);
  const double n_part = double(part.samples), n_half = double(half.samples);
  const double per_sample = n_part > n_half ? std::max(0.0, (t_part - t_half) / (n_part - n_half))
                                            : t_part / std::max(n_part, 1.0);
  const double per_run = std::max(0.0, t_part - per_sample * n_part);
  const double taken =
      double(samples.size()) / double(stride) * (1.0 - 1.0 / double(kValidationEvery));
  return per_run + per_sample * taken + time_solve(part, mix);
}

// The seconds of one colour refit with its normal equations on a compute device: the sums
// timed in full (a fraction of a second there), the solve as time_solve.
double time_device_refit(const SampleSet& samples, const ProductMixture& mix,
                         detail::PredictionPass& pass, const std::atomic<bool>* stop) {
  const std::size_t stride = detail::subsample_stride(samples.size(), kColourRefitSamples);
  const auto at = Clock::now();
  const ColourNormalEquations eq = pass.normal_equations(mix, stride, stop, {});
  return seconds_since(at) + time_solve(eq, mix);
}

// estimate_refinement over a pass already built (refine_for_prediction's, which then
// refines with it: a device's pass uploads the samples once).
RefinementEstimate estimate_with(const SampleSet& samples, const ProductMixture& mix, int threads,
                                 const GradientConfig& gradient, detail::PredictionPass& pass) {
  RefinementEstimate e;
  const double refit = gradient.device ? time_device_refit(samples, mix, pass, gradient.stop)
                                       : time_colour_refit(samples, mix, threads, gradient.stop);
  if (gradient.stop && gradient.stop->load()) return e;
  e.colour_refit_seconds = gradient.gradient ? 2.0 * refit : refit;
  e.seconds = e.colour_refit_seconds;
  if (!gradient.gradient) return e;
  const detail::StepTimes t = detail::time_gradient_step(samples, mix, pass, gradient.batch);
  e.step_seconds = t.step;
  e.validation_seconds = t.validation;
  e.steps_per_epoch = t.batches;
  const double by_epochs = double(gradient.max_epochs) * double(t.batches);
  double steps = gradient.steps > 0 ? double(gradient.steps) : by_epochs;
  if (gradient.steps == 0 && gradient.max_steps > 0)
    steps = std::min(steps, double(gradient.max_steps));
  e.steps = static_cast<long long>(steps);
  const double stepping =
      steps * t.step + (std::floor(steps / double(t.validate_every)) + 1.0) * t.validation;
  e.time_bound = stepping > gradient.seconds;
  e.seconds += std::min(stepping, gradient.seconds);
  return e;
}

}  // namespace

RefinementEstimate estimate_refinement(const SampleSet& samples, const ProductMixture& mix,
                                       int threads, const GradientConfig& gradient) {
  const auto pass =
      detail::make_prediction_pass(samples, mix.size(), threads, gradient.device.get());
  return estimate_with(samples, mix, threads, gradient, *pass);
}

PredictionRefinement refine_for_prediction(const SampleSet& samples, ProductMixture& mix,
                                           int threads, const GradientConfig& gradient) {
  // The refinement's seconds count the pass's making, not the estimate.
  auto t0 = std::chrono::steady_clock::now();
  const auto pass =
      detail::make_prediction_pass(samples, mix.size(), threads, gradient.device.get());
  // Every process of a distributed fit estimates, told or not: its timed passes are folded
  // over the processes, which each must join.
  if (gradient.planned || samples.processes) {
    const auto estimating = std::chrono::steady_clock::now();
    const RefinementEstimate estimate = estimate_with(samples, mix, threads, gradient, *pass);
    if (gradient.planned) gradient.planned(estimate);
    t0 += std::chrono::steady_clock::now() - estimating;
  }
  PredictionRefinement out;
  const detail::Selection validation{1, 0, detail::Selection::Part::kValidation};
  const auto [em_error, held_out] = detail::selection_error(*pass, mix, validation);
  out.samples = held_out;
  out.error_em = em_error;
  out.error_colour = refit_where_it_validates(samples, mix, *pass, em_error, gradient);
  out.stopped = gradient.stop && gradient.stop->load();
  out.error_final = out.error_colour;
  out.steps_planned = gradient.steps;
  if (gradient.gradient && !out.stopped) {
    detail::gradient_epochs(samples, mix, *pass, gradient, out);
    out.error_final = refit_where_it_validates(samples, mix, *pass, out.error_final, gradient);
    out.stopped = out.stopped || (gradient.stop && gradient.stop->load());
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace btfgmm
