// Gradient passes on the prediction's squared error (Eq. 8-11) over every parameter of the
// mixture (the weights, the means and variances of the six inputs, the colour means), Adam
// steps, each round closed by the closed-form colour refit (refine.cpp); docs/ALGORITHM.md,
// "Fitting for the prediction".
#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <limits>
#include <numeric>
#include <random>
#include <type_traits>
#include <vector>

#include "btfgmm/model/refine.hpp"
#include "core/adam.hpp"
#include "core/fast_exp.hpp"
#include "model/grid_weights.hpp"
#include "model/mixture_internal.hpp"
#include "model/refine_gpu.hpp"
#include "model/refine_internal.hpp"
#include "model/refine_parameters.hpp"
#include "model/refine_pass.hpp"

namespace btfgmm {

namespace {

template <class Real>
Real exp_of(Real x) {
  if constexpr (std::is_same_v<Real, float>)
    return detail::fast_exp(x);
  else
    return std::exp(x);
}

// One thread's sums over a light's samples: g_im per view, dE/dmu_m,6+c (3 rows of M), the
// light's own g_im, dE/da_m and dE/dmu, dE/ds of x and y (5 rows of M: g_im times the pixel's
// `rows`, d / sigma^2 and (d^2 / sigma^2 - 1) / 2 of x and y), the error and the samples; `w`
// the weights of the sample at hand.
template <class Real>
struct PassSums {
  std::vector<Real> view, colour, light, position, rows;
  std::vector<std::size_t> taken;  // the views of the pixel and light at hand in the selection
  double error = 0.0;
  std::size_t samples = 0;
  PassSums(std::size_t views, std::size_t m)
      : view(views * m),
        colour(3 * m),
        light(m),
        position(5 * m),
        rows(4 * m),
        w_storage_(m + kAlign / sizeof(Real)) {
    taken.reserve(views);
  }
  // The weights of the sample at hand, at an address aligned to kAlign bytes in every
  // thread: the vectorised sums over them then run in the same order whichever thread takes a
  // light (a loop peeled to an alignment would otherwise depend on the buffer's address).
  Real* w() {
    const auto at = reinterpret_cast<std::uintptr_t>(w_storage_.data());
    return w_storage_.data() + ((kAlign - at % kAlign) % kAlign) / sizeof(Real);
  }

 private:
  static constexpr std::size_t kAlign = 64;
  std::vector<Real> w_storage_;
};

// A pass of the prediction's squared error (prediction_gradient, model/refine.hpp) over the
// samples of a selection (detail::Selection), with its gradient or the error alone, weighing
// every component of every sample: the reference the float pass the Adam steps take
// (detail::SparsePass, refine_pass.cpp) is tested against, taken with Real = double. Every
// weight and per-light sum in `Real`; each light's sums in double, folded in light order over
// the processes (detail::fold_over_processes): the same for any number of threads and processes.
template <class Real>
class GradientPass {
 public:
  GradientPass(const SampleSet& s, std::size_t m, int threads)
      : s_(s),
        m_(m),
        threads_(threads > 0 ? threads : omp_get_max_threads()),
        pixel_(s.pixels() * m),
        light_(s.lights * m),
        view_(s.views * m),
        colour_(3 * m),
        mean_(2 * m),
        inv_var_(2 * m),
        periods_(detail::variable_periods({double(s.width), double(s.height)})),
        sums_(std::size_t(threads_), PassSums<Real>(s.views, m)) {}

  // The error (and, with `gradient`, the gradient) of `mix` over the samples of `selection`.
  PredictionGradient operator()(const ProductMixture& mix, const detail::Selection& selection,
                                bool gradient = true) {
    set_tables(mix);
    selection_ = selection;
    gradient_ = gradient;
    sum_over_lights();
    return result(mix);
  }

 private:
  // The places in a light's partial sums (and, but for the light's row, in the totals).
  std::size_t at_colour() const { return s_.views * m_; }
  std::size_t at_position() const { return at_colour() + 3 * m_; }
  std::size_t at_light() const { return at_position() + 5 * m_; }
  std::size_t partial_size() const { return gradient_ ? at_light() + m_ + 2 : 2; }
  std::size_t total_size() const { return gradient_ ? at_light() + s_.lights * m_ + 2 : 2; }

  void set_tables(const ProductMixture& mix) {
    detail::exponent_parts(s_, mix, pixel_.data(), light_.data(), view_.data());
    for (std::size_t k = 0; k < m_; ++k) {
      for (std::size_t c = 0; c < 3; ++c) colour_[c * m_ + k] = Real(mix.mean[k][6 + c]);
      for (std::size_t n = 0; n < 2; ++n) {
        mean_[n * m_ + k] = Real(mix.mean[k][n]);
        inv_var_[n * m_ + k] = Real(1.0 / mix.var[k][n]);
      }
    }
  }

  // One sample's part (Eq. 8-10): its weights W_m = softmax(t_m) over all M components, the
  // prediction yhat_c = sum_m W_m mu_m,6+c, its error, and g_m = dE/dt_m
  // = -2 W_m sum_c e_c (mu_m,6+c - yhat_c) added to the sums of its pixel, light and view.
  void add_sample(std::size_t p, std::size_t l, std::size_t v, PassSums<Real>& acc) const {
    const std::size_t m = m_;
    const Real *tp = &pixel_[p * m], *tl = &light_[l * m], *tv = &view_[v * m];
    const Real *mu0 = &colour_[0], *mu1 = &colour_[m], *mu2 = &colour_[2 * m];
    Real* w = acc.w();
#pragma omp simd
    for (std::size_t k = 0; k < m; ++k) w[k] = tp[k] + tl[k] + tv[k];
    Real top = -std::numeric_limits<Real>::infinity();
#pragma omp simd reduction(max : top)
    for (std::size_t k = 0; k < m; ++k) top = top > w[k] ? top : w[k];
    Real sum = 0;
#pragma omp simd reduction(+ : sum)
    for (std::size_t k = 0; k < m; ++k) {
      w[k] = exp_of(w[k] - top);
      sum += w[k];
    }
    const Real inv = Real(1) / sum;
    Real y0 = 0, y1 = 0, y2 = 0;
#pragma omp simd reduction(+ : y0, y1, y2)
    for (std::size_t k = 0; k < m; ++k) {
      w[k] *= inv;
      y0 += w[k] * mu0[k];
      y1 += w[k] * mu1[k];
      y2 += w[k] * mu2[k];
    }
    const Real e0 = Real(s_.residual_of(p, l, v, 0)) - y0,
               e1 = Real(s_.residual_of(p, l, v, 1)) - y1,
               e2 = Real(s_.residual_of(p, l, v, 2)) - y2;
    acc.error += double(e0) * double(e0) + double(e1) * double(e1) + double(e2) * double(e2);
    ++acc.samples;
    if (!gradient_) return;
    const Real base = e0 * y0 + e1 * y1 + e2 * y2;
    Real *light = acc.light.data(), *view = &acc.view[v * m];
    Real *c0 = &acc.colour[0], *c1 = &acc.colour[m], *c2 = &acc.colour[2 * m];
    Real *a = &acc.position[0], *mx = &acc.position[m], *my = &acc.position[2 * m],
         *sx = &acc.position[3 * m], *sy = &acc.position[4 * m];
    const Real *rx = &acc.rows[0], *ry = &acc.rows[m], *qx = &acc.rows[2 * m],
               *qy = &acc.rows[3 * m];
#pragma omp simd
    for (std::size_t k = 0; k < m; ++k) {
      const Real w2 = Real(-2) * w[k];
      const Real g = w2 * (e0 * mu0[k] + e1 * mu1[k] + e2 * mu2[k] - base);
      light[k] += g;
      view[k] += g;
      a[k] += g;
      mx[k] += g * rx[k];
      my[k] += g * ry[k];
      sx[k] += g * qx[k];
      sy[k] += g * qy[k];
      c0[k] += w2 * e0;
      c1[k] += w2 * e1;
      c2[k] += w2 * e2;
    }
  }

  // Pixel p's samples of light l in the selection, each adding g_m to the sums of the
  // pixel's terms of t_m (Eq. 10): a_m and, through d / sigma^2 and (d^2 / sigma^2 - 1) / 2
  // of x and y (the pixel's rows, computed once for its samples), dE/dmu and dE/ds of x, y.
  void add_pixel(std::size_t p, std::size_t l, PassSums<Real>& acc) const {
    const std::size_t nv = s_.views, pairs = s_.lights * nv, modulus = selection_.modulus;
    const std::size_t first = l * nv;
    acc.taken.clear();
    const std::size_t start = (selection_.residue + modulus - (p + first) % modulus) % modulus;
    for (std::size_t v = start; v < nv; v += modulus)
      if (selection_.takes(p, first + v, pairs)) acc.taken.push_back(v);
    if (acc.taken.empty()) return;
    if (gradient_) set_rows(p, acc.rows.data());
    for (const std::size_t v : acc.taken) add_sample(p, l, v, acc);
  }

  // d / sigma^2 and (d^2 / sigma^2 - 1) / 2 of x and y for pixel p, 4 rows of M.
  void set_rows(std::size_t p, Real* rows) const {
    const std::size_t m = m_;
    const Real x[2] = {Real(p % std::size_t(s_.width)), Real(p / std::size_t(s_.width))};
    for (std::size_t n = 0; n < 2; ++n) {
      const Real period = Real(periods_[n]);
      const Real inv_period = period > Real(0) ? Real(1) / period : Real(0);
      const Real *mean = &mean_[n * m], *inv_var = &inv_var_[n * m];
      Real *r = rows + n * m, *q = rows + (2 + n) * m;
#pragma omp simd
      for (std::size_t k = 0; k < m; ++k) {
        Real d = x[n] - mean[k];
        d -= period * std::floor(d * inv_period + Real(0.5));  // the minimum image
        r[k] = d * inv_var[k];
        q[k] = Real(0.5) * (d * r[k] - Real(1));
      }
    }
  }

  // Every held light's sums, each light's in its own partial (in double), then folded in
  // light order over the processes.
  void sum_over_lights() {
    const std::size_t held = s_.held_lights(), n = partial_size();
    partials_.assign(held * n, 0.0);
#pragma omp parallel num_threads(threads_)
    {
      PassSums<Real>& acc = sums_[std::size_t(omp_get_thread_num())];
#pragma omp for schedule(dynamic, 1)
      for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(held); ++i) {
        const std::size_t l = s_.first_light + std::size_t(i);
        for (std::size_t p = 0; p < s_.pixels(); ++p) add_pixel(p, l, acc);
        move_into(acc, &partials_[std::size_t(i) * n]);
      }
    }
    total_ = detail::fold_over_processes(s_.processes.get(), total_size(),
                                         [this, held, n](std::vector<double>& t) {
                                           for (std::size_t i = 0; i < held; ++i)
                                             fold(&partials_[i * n], s_.first_light + i, t);
                                         });
  }

  // A light's sums into its partial (in double), the sums cleared.
  void move_into(PassSums<Real>& acc, double* partial) const {
    const std::size_t n = partial_size();
    partial[n - 2] = acc.error;
    partial[n - 1] = double(acc.samples);
    acc.error = 0.0;
    acc.samples = 0;
    if (!gradient_) return;
    move(acc.view, partial);
    move(acc.colour, partial + at_colour());
    move(acc.position, partial + at_position());
    move(acc.light, partial + at_light());
  }
  static void move(std::vector<Real>& from, double* to) {
    for (std::size_t i = 0; i < from.size(); ++i) {
      to[i] = double(from[i]);
      from[i] = Real(0);
    }
  }

  // Light l's partial added to the totals.
  void fold(const double* partial, std::size_t l, std::vector<double>& t) const {
    const std::size_t n = partial_size();
    t[t.size() - 2] += partial[n - 2];
    t[t.size() - 1] += partial[n - 1];
    if (!gradient_) return;
    for (std::size_t i = 0; i < at_light(); ++i) t[i] += partial[i];
    for (std::size_t k = 0; k < m_; ++k) t[at_light() + l * m_ + k] += partial[at_light() + k];
  }

  // d t / d mu and d t / d s of an angle: the term -s/2 - d^2 / (2 sigma^2) of Eq. (10).
  static void add_angle_gradient(double g, double x, std::size_t k, std::size_t n,
                                 const ProductMixture& mix, PredictionGradient& out) {
    const double var = mix.var[k][n];
    const double d = x - mix.mean[k][n];
    out.mean[k][n] += g * d / var;
    out.log_var[k][n] += 0.5 * g * (d * d / var - 1.0);
  }

  PredictionGradient result(const ProductMixture& mix) const {
    PredictionGradient out;
    out.error = total_[total_.size() - 2];
    out.samples = std::size_t(total_[total_.size() - 1]);
    if (!gradient_) return out;
    out.log_weight.assign(m_, 0.0);
    out.mean.assign(m_, {});
    out.log_var.assign(m_, {});
    const double* position = &total_[at_position()];
    for (std::size_t k = 0; k < m_; ++k) {
      out.log_weight[k] = position[k];
      for (std::size_t n = 0; n < 2; ++n) {
        out.mean[k][n] = position[(1 + n) * m_ + k];
        out.log_var[k][n] = position[(3 + n) * m_ + k];
      }
      for (std::size_t l = 0; l < s_.lights; ++l)
        for (std::size_t j = 0; j < 2; ++j)
          add_angle_gradient(total_[at_light() + l * m_ + k], s_.light_ab[l][j], k, 2 + j, mix,
                             out);
      for (std::size_t v = 0; v < s_.views; ++v)
        for (std::size_t j = 0; j < 2; ++j)
          add_angle_gradient(total_[v * m_ + k], s_.view_ab[v][j], k, 4 + j, mix, out);
      for (std::size_t c = 0; c < 3; ++c) out.mean[k][6 + c] = total_[at_colour() + c * m_ + k];
    }
    return out;
  }

  const SampleSet& s_;
  std::size_t m_;
  int threads_;
  detail::Selection selection_;
  bool gradient_ = true;
  std::vector<Real> pixel_, light_, view_, colour_;  // the exponents' parts, mu_m,6+c
  std::vector<Real> mean_, inv_var_;                 // mu_m0, mu_m1; 1 / sigma^2_m0, 1 / sigma^2_m1
  detail::Periods periods_;
  std::vector<double> partials_, total_;  // per held light; folded
  std::vector<PassSums<Real>> sums_;      // one per thread
};

}  // namespace

PredictionGradient prediction_gradient(const SampleSet& samples, const ProductMixture& mix,
                                       int threads, std::size_t stride, PassPrecision precision) {
  const detail::Selection all{std::max<std::size_t>(stride, 1), 0, detail::Selection::Part::kAll};
  if (precision == PassPrecision::kFloat)
    return detail::SparsePass(samples, mix.size(), threads)(mix, all);
  return GradientPass<double>(samples, mix.size(), threads)(mix, all);
}

std::pair<double, std::size_t> validation_error(const SampleSet& samples, const ProductMixture& mix,
                                                int threads) {
  return detail::selection_error(samples, mix, threads,
                                 {1, 0, detail::Selection::Part::kValidation});
}

namespace detail {

std::pair<double, std::size_t> selection_error(const SampleSet& samples, const ProductMixture& mix,
                                               int threads, const Selection& selection) {
  SparsePass pass(samples, mix.size(), threads);
  return selection_error(pass, mix, selection);
}

std::pair<double, std::size_t> selection_error(PredictionPass& pass, const ProductMixture& mix,
                                               const Selection& selection) {
  const PredictionGradient g = pass(mix, selection, false);
  return {g.error, g.samples};
}

std::unique_ptr<PredictionPass> make_prediction_pass(const SampleSet& samples, std::size_t m,
                                                     int threads, ComputeDevice* device) {
  if (device) return std::make_unique<GpuPredictionPass>(*device, samples, m);
  return std::make_unique<SparsePass>(samples, m, threads);
}

}  // namespace detail

namespace {

using detail::adam_epsilons;
using detail::keep_within_bounds;
using detail::kParams;
using detail::pack;
using detail::rate_of_parameter;
using detail::unpack;

// The stopping rule on the validation error (GradientConfig): the lowest met, the error the
// next gain is measured from, the validations since the last gain, the rate's halvings.
struct Convergence {
  double best = INFINITY, reference = INFINITY, rate_scale = 1.0;
  int since_gain = 0, plateaus = 0;
  // After a validation of error e: whether the steps have converged.
  bool converged(double e, const GradientConfig& c) {
    best = std::min(best, e);
    if (e < reference * (1.0 - c.min_gain)) {
      reference = e;
      since_gain = 0;
      return false;
    }
    if (++since_gain < c.patience) return false;
    since_gain = 0;
    reference = best;
    rate_scale *= 0.5;
    return ++plateaus >= c.plateaus;
  }
};

// The minibatches of the training samples: `count` of them, batch b the samples with
// (p + l nv + v) mod count = b (every image keeps every count-th pixel), less those held out.
std::size_t minibatches(const SampleSet& samples, std::size_t batch) {
  const std::size_t training = samples.size() - samples.size() / kValidationEvery;
  return std::max<std::size_t>(1, training / std::max<std::size_t>(batch, 1));
}

// Where the steps are, for the progress and the stop.
struct Epochs {
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  std::clock_t cpu_start = std::clock();
  double train_error = 0.0, weighed = 0.0;  // weighed: PredictionGradient::weighed x samples
  std::size_t train_samples = 0;
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
};

// The progress after a validation (`last`: after the last step, fraction 1).
void report(const GradientConfig& config, const Epochs& at, const Convergence& rule,
            const PredictionRefinement& out, double rmse, bool last) {
  if (!config.progress) return;
  const double step_share = config.max_steps > 0 ? double(out.steps) / config.max_steps : 0.0;
  const double fraction = last             ? 1.0
                          : out.steps == 0 ? 0.0
                          : config.steps > 0
                              ? double(out.steps) / config.steps
                              : std::max({step_share, at.elapsed() / config.seconds,
                                          double(out.epochs - 1) / config.max_epochs,
                                          double(rule.plateaus) / std::max(1, config.plateaus)});
  config.progress({.epoch = out.epochs,
                   .step = out.steps,
                   .steps = config.steps,
                   .max_steps = config.steps > 0 ? 0 : config.max_steps,
                   .validation_rmse = rmse,
                   .best_validation_rmse = prediction_rmse(out.error_final, out.samples),
                   .training_rmse = prediction_rmse(at.train_error, at.train_samples),
                   .elapsed = at.elapsed(),
                   .seconds = config.seconds,
                   .fraction = std::min(fraction, 1.0),
                   .max_epochs = config.max_epochs});
}

// Validation after a step: the lowest error's mixture kept in `best`; the progress reported.
// Returns whether the rule has converged.
bool validate(detail::PredictionPass& pass, const ProductMixture& mix, const GradientConfig& config,
              const Epochs& at, Convergence& rule, ProductMixture& best,
              PredictionRefinement& out) {
  const detail::Selection validation{1, 0, detail::Selection::Part::kValidation};
  const double e = pass(mix, validation, false).error;
  ++out.passes;
  if (e < out.error_final) {
    best = mix;
    out.error_final = e;
  }
  const bool converged = rule.converged(e, config);
  report(config, at, rule, out, prediction_rmse(e, out.samples), false);
  return converged && config.steps == 0;
}

// Whether the steps end after this one: a stop asked for (in any process), the time bound,
// the steps asked for, the bound on steps.
bool steps_end(const SampleSet& samples, const GradientConfig& config, const Epochs& at,
               PredictionRefinement& out) {
  const bool asked = config.stop && config.stop->load();
  const bool late = at.elapsed() > config.seconds;
  if (detail::any_process(samples.processes.get(), asked || late)) {
    out.stopped = detail::any_process(samples.processes.get(), asked);
    out.timed_out = !out.stopped;
    return true;
  }
  if (config.steps > 0) return out.steps >= config.steps;
  out.step_bound = config.max_steps > 0 && out.steps >= config.max_steps;
  return out.step_bound;
}

}  // namespace

namespace detail {

StepTimes time_gradient_step(const SampleSet& samples, const ProductMixture& mix,
                             PredictionPass& pass, std::size_t batch) {
  using Clock = std::chrono::steady_clock;
  StepTimes t;
  t.batches = minibatches(samples, batch);
  t.validate_every = std::max<std::size_t>(1, t.batches / 4);
  // The second of two steps: the first starts the threads.
  t.step = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < std::min<std::size_t>(2, t.batches); ++k) {
    const auto at = Clock::now();
    pass(mix, {t.batches, k, Selection::Part::kTraining});
    t.step = std::chrono::duration<double>(Clock::now() - at).count();
  }
  const std::size_t held = samples.size() / kValidationEvery;
  const auto at = Clock::now();
  const PredictionGradient part = pass(mix, {8, 0, Selection::Part::kValidation}, false);
  const double seconds = std::chrono::duration<double>(Clock::now() - at).count();
  t.validation = seconds * double(held) / double(std::max<std::size_t>(part.samples, 1));
  return t;
}

void gradient_epochs(const SampleSet& samples, ProductMixture& mix, PredictionPass& pass,
                     const GradientConfig& config, PredictionRefinement& out) {
  constexpr int kWarmUpSteps = 20;
  const detail::Periods periods =
      detail::variable_periods({double(samples.width), double(samples.height)});
  const std::size_t batches = minibatches(samples, config.batch);
  out.training_samples = samples.size() - out.samples;
  out.batch_samples = out.training_samples / batches;
  const std::size_t validate_every = std::max<std::size_t>(1, batches / 4);
  ProductMixture best = mix;
  Adam adam(pack(mix));
  std::array<double, kParams> epsilon{};
  Convergence rule;
  rule.best = rule.reference = out.error_final;
  Epochs at;
  std::mt19937_64 draw(config.seed);
  std::vector<std::size_t> order(batches);
  const double start_rmse = prediction_rmse(out.error_final, out.samples);
  report(config, at, rule, out, start_rmse, false);
  bool done = false;
  for (int epoch = 1; !done && epoch <= config.max_epochs; ++epoch) {
    out.epochs = epoch;
    std::iota(order.begin(), order.end(), std::size_t(0));
    std::shuffle(order.begin(), order.end(), draw);
    at.train_error = at.weighed = 0.0;
    at.train_samples = 0;
    for (std::size_t k = 0; k < batches && !done; ++k) {
      const PredictionGradient g = pass(mix, {batches, order[k], Selection::Part::kTraining});
      ++out.passes;
      at.train_error += g.error;
      at.train_samples += g.samples;
      at.weighed += g.weighed * double(g.samples);
      const double warm_up = std::min(1.0, double(adam.t + 1) / kWarmUpSteps);
      const double scale = warm_up * rule.rate_scale;
      if (adam.t == 0) epsilon = adam_epsilons(g);
      adam.step(pack(g), rate_of_parameter(config.rate * scale, config.colour_rate * scale),
                [&epsilon](std::size_t i) { return epsilon[i % kParams]; });
      unpack(adam.theta, mix, periods);
      keep_within_bounds(adam.theta, mix);
      ++out.steps;
      const bool due = (k + 1) % validate_every == 0 || k + 1 == batches;
      const bool converged = due && validate(pass, mix, config, at, rule, best, out);
      done = converged || steps_end(samples, config, at, out);  // converged: the same everywhere
      if (done && !due) validate(pass, mix, config, at, rule, best, out);
    }
  }
  out.epoch_bound = !done;  // the loop ran out of epochs
  out.training_rmse = prediction_rmse(at.train_error, at.train_samples);
  out.weighed = at.train_samples > 0 ? at.weighed / double(at.train_samples) : 1.0;
  out.gradient_seconds = at.elapsed();
  out.gradient_cpu_seconds = double(std::clock() - at.cpu_start) / CLOCKS_PER_SEC;
  report(config, at, rule, out, prediction_rmse(out.error_final, out.samples), true);
  mix = std::move(best);
}

}  // namespace detail

}  // namespace btfgmm
