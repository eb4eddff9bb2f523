// Gradient passes on the prediction's squared error (Eq. 8-11) over every parameter of the
// mixture (the weights, the means and variances of the six inputs, the colour means), Adam
// steps, each round closed by the closed-form colour refit (refine.cpp); docs/ALGORITHM.md,
// "Fitting for the prediction".
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "btfgmm/model/refine.hpp"
#include "core/fast_exp.hpp"
#include "model/grid_weights.hpp"
#include "model/mixture_internal.hpp"
#include "model/refine_internal.hpp"

namespace btfgmm {

namespace {

template <class Real>
Real exp_of(Real x) {
  if constexpr (std::is_same_v<Real, float>)
    return detail::fast_exp(x);
  else
    return std::exp(x);
}

// One thread's sums over a chunk of pixels (GradientPass::kChunkPixels): g_im per light and
// per view, dE/dmu_m,6+c (3 rows of M), dE/da_m and dE/dmu, dE/ds of x and y (5 rows of M,
// from each pixel's own sum `pixel`), the error and the samples; `w` the weights of the sample
// at hand.
template <class Real>
struct PassSums {
  std::vector<Real> light, view, colour, pixel;
  std::vector<double> position;
  double error = 0.0;
  std::size_t samples = 0;
  PassSums(std::size_t lights, std::size_t views, std::size_t m)
      : light(lights * m),
        view(views * m),
        colour(3 * m),
        pixel(m),
        position(5 * m),
        w_storage_(m + kAlign / sizeof(Real)) {}
  // The weights of the sample at hand, at an address aligned to kAlign bytes in every
  // thread: the vectorised sums over them then run in the same order whichever thread takes a
  // chunk (a loop peeled to an alignment would otherwise depend on the buffer's address).
  Real* w() {
    const auto at = reinterpret_cast<std::uintptr_t>(w_storage_.data());
    return w_storage_.data() + ((kAlign - at % kAlign) % kAlign) / sizeof(Real);
  }

 private:
  static constexpr std::size_t kAlign = 64;
  std::vector<Real> w_storage_;
};

// A gradient pass of the prediction's squared error (prediction_gradient, model/refine.hpp)
// over the samples of a stride, its tables and sums kept from one pass to the next (the
// Adam steps make one pass each). Every weight and per-chunk sum in `Real`, the totals in
// double.
template <class Real>
class GradientPass {
 public:
  // Pixels a chunk holds: the chunks, and so the order of every sum, are the same for any
  // number of threads.
  static constexpr std::size_t kChunkPixels = 32;

  GradientPass(const SampleSet& s, std::size_t m, int threads, std::size_t stride)
      : s_(s),
        m_(m),
        threads_(threads > 0 ? threads : omp_get_max_threads()),
        stride_(std::max<std::size_t>(stride, 1)),
        pixel_(s.pixels() * m),
        light_(s.lights * m),
        view_(s.views * m),
        colour_(3 * m),
        position_(5 * m),
        mean_(4 * m),
        total_light_(s.lights * m),
        total_view_(s.views * m),
        total_colour_(3 * m),
        sums_(std::size_t(threads_), PassSums<Real>(s.lights, s.views, m)) {}

  PredictionGradient operator()(const ProductMixture& mix) {
    set_tables(mix);
    sum_over_chunks();
    return gradient(mix);
  }

 private:
  void set_tables(const ProductMixture& mix) {
    detail::exponent_parts(s_, mix, pixel_.data(), light_.data(), view_.data());
    for (std::size_t k = 0; k < m_; ++k) {
      for (std::size_t c = 0; c < 3; ++c) colour_[c * m_ + k] = Real(mix.mean[k][6 + c]);
      for (std::size_t n = 0; n < 2; ++n) {
        mean_[n * m_ + k] = mix.mean[k][n];
        mean_[(2 + n) * m_ + k] = mix.var[k][n];
      }
    }
    std::fill(position_.begin(), position_.end(), 0.0);
    std::fill(total_light_.begin(), total_light_.end(), 0.0);
    std::fill(total_view_.begin(), total_view_.end(), 0.0);
    std::fill(total_colour_.begin(), total_colour_.end(), 0.0);
    error_ = 0.0;
    samples_ = 0;
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
    const Real base = e0 * y0 + e1 * y1 + e2 * y2;
    Real *pixel = acc.pixel.data(), *light = &acc.light[l * m], *view = &acc.view[v * m];
    Real *c0 = &acc.colour[0], *c1 = &acc.colour[m], *c2 = &acc.colour[2 * m];
#pragma omp simd
    for (std::size_t k = 0; k < m; ++k) {
      const Real w2 = Real(-2) * w[k];
      const Real g = w2 * (e0 * mu0[k] + e1 * mu1[k] + e2 * mu2[k] - base);
      pixel[k] += g;
      light[k] += g;
      view[k] += g;
      c0[k] += w2 * e0;
      c1[k] += w2 * e1;
      c2[k] += w2 * e2;
    }
  }

  // Pixel p's samples of the stride (GridWeights::kept), then its sum of g_m as dE/da_m and,
  // through the terms of x and y in t_m (Eq. 10), dE/dmu and dE/ds of x and y.
  void add_pixel(std::size_t p, PassSums<Real>& acc) const {
    std::fill(acc.pixel.begin(), acc.pixel.end(), Real(0));
    const std::size_t first = s_.first_light * s_.views, end = s_.light_end() * s_.views;
    for (std::size_t j = first + (stride_ - (p + first) % stride_) % stride_; j < end; j += stride_)
      add_sample(p, j / s_.views, j % s_.views, acc);
    const detail::Periods periods = detail::variable_periods({double(s_.width), double(s_.height)});
    const double x[2] = {double(p % std::size_t(s_.width)), double(p / std::size_t(s_.width))};
    double* out = acc.position.data();
    for (std::size_t k = 0; k < m_; ++k) {
      const double g = double(acc.pixel[k]);
      out[k] += g;
      for (std::size_t n = 0; n < 2; ++n) {
        const double var = mean_[(2 + n) * m_ + k];
        const double d = detail::wrapped_difference(x[n] - mean_[n * m_ + k], periods[n]);
        out[(1 + n) * m_ + k] += g * d / var;
        out[(3 + n) * m_ + k] += 0.5 * g * (d * d / var - 1.0);
      }
    }
  }

  // Every chunk's sums, added to the totals in chunk order and cleared.
  void sum_over_chunks() {
    const std::size_t pixels = s_.pixels();
    const std::ptrdiff_t chunks = std::ptrdiff_t((pixels + kChunkPixels - 1) / kChunkPixels);
#pragma omp parallel num_threads(threads_)
    {
      PassSums<Real>& acc = sums_[std::size_t(omp_get_thread_num())];
#pragma omp for ordered schedule(dynamic, 1)
      for (std::ptrdiff_t c = 0; c < chunks; ++c) {
        const std::size_t chunk_end = std::min(pixels, std::size_t(c + 1) * kChunkPixels);
        for (std::size_t p = std::size_t(c) * kChunkPixels; p < chunk_end; ++p) add_pixel(p, acc);
#pragma omp ordered
        add_and_clear(acc);
      }
    }
  }

  void add_and_clear(PassSums<Real>& acc) {
    add_and_clear(acc.light, total_light_);
    add_and_clear(acc.view, total_view_);
    add_and_clear(acc.colour, total_colour_);
    for (std::size_t i = 0; i < acc.position.size(); ++i) {
      position_[i] += acc.position[i];
      acc.position[i] = 0.0;
    }
    error_ += acc.error;
    samples_ += acc.samples;
    acc.error = 0.0;
    acc.samples = 0;
  }
  static void add_and_clear(std::vector<Real>& from, std::vector<double>& to) {
    for (std::size_t i = 0; i < from.size(); ++i) {
      to[i] += double(from[i]);
      from[i] = Real(0);
    }
  }

  // d t / d mu and d t / d s of an angle: the term -s/2 - d^2 / (2 sigma^2) of Eq. (10).
  static void add_angle_gradient(double g, double x, std::size_t k, std::size_t n,
                                 const ProductMixture& mix, PredictionGradient& out) {
    const double var = mix.var[k][n];
    const double d = x - mix.mean[k][n];
    out.mean[k][n] += g * d / var;
    out.log_var[k][n] += 0.5 * g * (d * d / var - 1.0);
  }

  PredictionGradient gradient(const ProductMixture& mix) const {
    PredictionGradient out;
    out.samples = samples_;
    out.error = error_;
    out.log_weight.assign(m_, 0.0);
    out.mean.assign(m_, {});
    out.log_var.assign(m_, {});
    for (std::size_t k = 0; k < m_; ++k) {
      out.log_weight[k] = position_[k];
      for (std::size_t n = 0; n < 2; ++n) {
        out.mean[k][n] = position_[(1 + n) * m_ + k];
        out.log_var[k][n] = position_[(3 + n) * m_ + k];
      }
      for (std::size_t l = s_.first_light; l < s_.light_end(); ++l)
        for (std::size_t j = 0; j < 2; ++j)
          add_angle_gradient(total_light_[l * m_ + k], s_.light_ab[l][j], k, 2 + j, mix, out);
      for (std::size_t v = 0; v < s_.views; ++v)
        for (std::size_t j = 0; j < 2; ++j)
          add_angle_gradient(total_view_[v * m_ + k], s_.view_ab[v][j], k, 4 + j, mix, out);
      for (std::size_t c = 0; c < 3; ++c) out.mean[k][6 + c] = total_colour_[c * m_ + k];
    }
    return out;
  }

  const SampleSet& s_;
  std::size_t m_;
  int threads_;
  std::size_t stride_;
  std::vector<Real> pixel_, light_, view_, colour_;  // the exponents' parts, mu_m,6+c
  std::vector<double> position_;  // dE/da_m, dE/dmu_m0, dE/dmu_m1, dE/ds_m0, dE/ds_m1
  std::vector<double> mean_;      // mu_m0, mu_m1, sigma^2_m0, sigma^2_m1
  std::vector<double> total_light_, total_view_, total_colour_;
  double error_ = 0.0;
  std::size_t samples_ = 0;
  std::vector<PassSums<Real>> sums_;  // one per thread
};

}  // namespace

PredictionGradient prediction_gradient(const SampleSet& samples, const ProductMixture& mix,
                                       int threads, std::size_t stride, PassPrecision precision) {
  if (precision == PassPrecision::kFloat)
    return GradientPass<float>(samples, mix.size(), threads, stride)(mix);
  return GradientPass<double>(samples, mix.size(), threads, stride)(mix);
}

namespace {

// The parameters as one vector, 16 a component: a_m, mu_m0..8, s_m0..5.
constexpr std::size_t kParams = 1 + kVariables + kInputs;

std::vector<double> pack(const ProductMixture& mix) {
  std::vector<double> th(mix.size() * kParams);
  for (std::size_t k = 0; k < mix.size(); ++k) {
    double* t = &th[k * kParams];
    t[0] = std::log(mix.weight[k]);
    for (int n = 0; n < kVariables; ++n) t[1 + n] = mix.mean[k][std::size_t(n)];
    for (int n = 0; n < kInputs; ++n) t[1 + kVariables + n] = std::log(mix.var[k][std::size_t(n)]);
  }
  return th;
}

std::vector<double> pack(const PredictionGradient& g) {
  std::vector<double> th(g.log_weight.size() * kParams);
  for (std::size_t k = 0; k < g.log_weight.size(); ++k) {
    double* t = &th[k * kParams];
    t[0] = g.log_weight[k];
    for (int n = 0; n < kVariables; ++n) t[1 + n] = g.mean[k][std::size_t(n)];
    for (int n = 0; n < kInputs; ++n) t[1 + kVariables + n] = g.log_var[k][std::size_t(n)];
  }
  return th;
}

// The mixture of a parameter vector: w the softmax of a, the input means of x and y wrapped
// into the tile, the variances kept where EM keeps them (bounded_variance).
void unpack(const std::vector<double>& th, ProductMixture& mix, const detail::Periods& periods) {
  double top = -INFINITY, sum = 0.0;
  for (std::size_t k = 0; k < mix.size(); ++k) top = std::max(top, th[k * kParams]);
  for (std::size_t k = 0; k < mix.size(); ++k) sum += std::exp(th[k * kParams] - top);
  for (std::size_t k = 0; k < mix.size(); ++k) {
    const double* t = &th[k * kParams];
    mix.weight[k] = std::exp(t[0] - top) / sum;
    for (int n = 0; n < kVariables; ++n)
      mix.mean[k][std::size_t(n)] = detail::wrap_into_period(t[1 + n], periods[std::size_t(n)]);
    for (int n = 0; n < kInputs; ++n)
      mix.var[k][std::size_t(n)] = detail::bounded_variance(
          std::exp(t[1 + kVariables + n]), kVarianceFloor, periods[std::size_t(n)]);
  }
}

// The log variances of the parameter vector set to those of the mixture unpacked from it,
// which bounded_variance kept within EM's floor and ceiling: a step past a bound is projected
// back onto it, so that the next step away from the bound moves the variance at once.
void keep_within_bounds(std::vector<double>& theta, const ProductMixture& mix) {
  for (std::size_t k = 0; k < mix.size(); ++k)
    for (int n = 0; n < kInputs; ++n)
      theta[k * kParams + 1 + kVariables + std::size_t(n)] = std::log(mix.var[k][std::size_t(n)]);
}

// One round of Adam steps (Kingma & Ba 2015: beta 0.9, 0.999, bias-corrected moments) from
// `mix` at a constant rate, warmed up linearly over the first kWarmUpSteps steps. The steps
// go on from the parameters they reached, also after a step that raised the error (on a
// subsample the error is noisy: undoing such steps and restarting the moments stalled the
// descent, docs/ALGORITHM.md); the parameters of the lowest error met are the round's result.
// Leaves them in `mix` and returns their error.
// Stops after the step where config.stop is set (out.stopped).
double adam_round(const SampleSet& samples, ProductMixture& mix, int threads, std::size_t stride,
                  const GradientConfig& config, int round, PredictionRefinement& out) {
  constexpr int kWarmUpSteps = 20;
  const detail::Periods periods =
      detail::variable_periods({double(samples.width), double(samples.height)});
  ProductMixture best = mix;
  double best_error = INFINITY;
  std::vector<double> theta = pack(mix), m1(theta.size(), 0.0), m2(theta.size(), 0.0);
  GradientPass<float> pass(samples, mix.size(), threads, stride);
  for (int t = 1; t <= config.steps + 1; ++t) {
    const PredictionGradient g = pass(mix);
    ++out.passes;
    if (g.error < best_error) {
      best = mix;
      best_error = g.error;
    }
    if (config.progress)
      config.progress({round, t - 1, config.steps, prediction_rmse(best_error, g.samples)});
    if (t > config.steps) break;
    if (config.stop && config.stop->load()) {
      out.stopped = true;
      break;
    }
    ++out.steps;
    const std::vector<double> grad = pack(g);
    const double warm_up = std::min(1.0, double(t) / kWarmUpSteps);
    const double c1 = 1.0 - std::pow(0.9, t), c2 = 1.0 - std::pow(0.999, t);
    for (std::size_t i = 0; i < theta.size(); ++i) {
      m1[i] = 0.9 * m1[i] + 0.1 * grad[i];
      m2[i] = 0.999 * m2[i] + 0.001 * grad[i] * grad[i];
      const std::size_t j = i % kParams;
      const double rate = (j >= 7 && j < 10 ? config.colour_rate : config.rate) * warm_up;
      theta[i] -= rate * (m1[i] / c1) / (std::sqrt(m2[i] / c2) + 1e-300);
    }
    unpack(theta, mix, periods);
    keep_within_bounds(theta, mix);
  }
  mix = std::move(best);
  return best_error;
}

}  // namespace

namespace detail {

double gradient_rounds(const SampleSet& samples, ProductMixture& mix, int threads,
                       std::size_t stride, const GradientConfig& config, double error,
                       PredictionRefinement& out) {
  const std::size_t pass_stride = detail::subsample_stride(samples.size(), config.samples);
  for (int r = 0; r < config.rounds; ++r) {
    ProductMixture trial = mix;
    adam_round(samples, trial, threads, pass_stride, config, r + 1, out);
    const ColourRefit refit =
        refit_colour_means(colour_normal_equations(samples, trial, threads, stride), trial);
    if (!(refit.error_after < error)) break;
    error = refit.error_after;
    mix = std::move(trial);
    if (out.stopped) break;
  }
  return error;
}

}  // namespace detail

}  // namespace btfgmm
