// Gradient passes on the prediction's squared error (Eq. 8-11) over every parameter of the
// mixture (the weights, the means and variances of the six inputs, the colour means), Adam
// steps, each round closed by the closed-form colour refit (refine.cpp); docs/ALGORITHM.md,
// "Fitting for the prediction".
#include <algorithm>
#include <cmath>
#include <vector>

#include "btfgmm/model/refine.hpp"
#include "model/grid_weights.hpp"
#include "model/mixture_internal.hpp"
#include "model/refine_internal.hpp"

namespace btfgmm {

namespace {

// One chunk's sums of g_im per light and per view, of dE/dmu_m,6+c, and of the error; the sums
// per pixel go straight into the totals (a pixel belongs to one chunk).
struct ChunkSums {
  std::vector<double> light, view, colour;
  double error = 0.0;
  ChunkSums(std::size_t lights, std::size_t views, std::size_t m)
      : light(lights * m, 0.0), view(views * m, 0.0), colour(m * 3, 0.0) {}
};

// One sample's part: its error, and g_m = dE/dt_m for each kept component (Eq. 8-9).
void add_sample(const detail::SampleWeights& s, const ProductMixture& mix, double* pixel,
                ChunkSums& acc) {
  const std::size_t m = mix.size();
  double yhat[3] = {0, 0, 0};
  for (std::size_t a = 0; a < s.component.size(); ++a)
    for (int c = 0; c < 3; ++c) yhat[c] += s.weight[a] * mix.mean[s.component[a]][6 + c];
  double e[3];
  for (int c = 0; c < 3; ++c) {
    e[c] = double(s.residual[c]) - yhat[c];
    acc.error += e[c] * e[c];
  }
  double* light = &acc.light[s.light * m];
  double* view = &acc.view[s.view * m];
  for (std::size_t a = 0; a < s.component.size(); ++a) {
    const std::size_t k = s.component[a];
    const auto& mu = mix.mean[k];
    const double w2 = -2.0 * s.weight[a];
    double g = 0.0;
    for (int c = 0; c < 3; ++c) {
      g += e[c] * (mu[std::size_t(6 + c)] - yhat[c]);
      acc.colour[k * 3 + std::size_t(c)] += w2 * e[c];
    }
    g *= w2;
    pixel[k] += g;
    light[k] += g;
    view[k] += g;
  }
}

// d t / d mu and d t / d s of one input: the term -s/2 - d^2 / (2 sigma^2) of Eq. (10).
void add_input_gradient(double g, double x, std::size_t k, int n, const ProductMixture& mix,
                        double period, PredictionGradient& out) {
  const double var = mix.var[k][std::size_t(n)];
  const double d = detail::wrapped_difference(x - mix.mean[k][std::size_t(n)], period);
  out.mean[k][std::size_t(n)] += g * d / var;
  out.log_var[k][std::size_t(n)] += 0.5 * g * (d * d / var - 1.0);
}

}  // namespace

PredictionGradient prediction_gradient(const SampleSet& samples, const ProductMixture& mix,
                                       int threads, std::size_t stride) {
  const std::size_t m = mix.size();
  const detail::GridWeights grid(samples, mix, std::max<std::size_t>(stride, 1));
  PredictionGradient out;
  out.samples = grid.samples();
  std::vector<double> pixel(samples.pixels() * m, 0.0);
  ChunkSums total(samples.lights, samples.views, m);
  grid.reduce_in_chunks(
      threads, [&samples, m] { return ChunkSums(samples.lights, samples.views, m); },
      [&](const detail::SampleWeights& s, ChunkSums& acc) {
        add_sample(s, mix, &pixel[s.pixel * m], acc);
      },
      [&total](ChunkSums& acc) {
        for (std::size_t i = 0; i < acc.light.size(); ++i) total.light[i] += acc.light[i];
        for (std::size_t i = 0; i < acc.view.size(); ++i) total.view[i] += acc.view[i];
        for (std::size_t i = 0; i < acc.colour.size(); ++i) total.colour[i] += acc.colour[i];
        total.error += acc.error;
        std::fill(acc.light.begin(), acc.light.end(), 0.0);
        std::fill(acc.view.begin(), acc.view.end(), 0.0);
        std::fill(acc.colour.begin(), acc.colour.end(), 0.0);
        acc.error = 0.0;
      });
  out.error = total.error;
  out.log_weight.assign(m, 0.0);
  out.mean.assign(m, {});
  out.log_var.assign(m, {});
  const detail::Periods periods =
      detail::variable_periods({double(samples.width), double(samples.height)});
  const std::size_t width = std::size_t(samples.width);
  for (std::size_t k = 0; k < m; ++k) {
    for (std::size_t p = 0; p < samples.pixels(); ++p) {
      const double g = pixel[p * m + k];
      out.log_weight[k] += g;
      add_input_gradient(g, double(p % width), k, 0, mix, periods[0], out);
      add_input_gradient(g, double(p / width), k, 1, mix, periods[1], out);
    }
    for (std::size_t l = samples.first_light; l < samples.light_end(); ++l)
      for (int j = 0; j < 2; ++j)
        add_input_gradient(total.light[l * m + k], samples.light_ab[l][std::size_t(j)], k, 2 + j,
                           mix, 0.0, out);
    for (std::size_t v = 0; v < samples.views; ++v)
      for (int j = 0; j < 2; ++j)
        add_input_gradient(total.view[v * m + k], samples.view_ab[v][std::size_t(j)], k, 4 + j, mix,
                           0.0, out);
    for (int c = 0; c < 3; ++c)
      out.mean[k][std::size_t(6 + c)] = total.colour[k * 3 + std::size_t(c)];
  }
  return out;
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

// One round of Adam steps (Kingma & Ba 2015, beta 0.9, 0.999) from `mix`, the rate scaled by
// a factor from 0.1 that grows by 1.2 after a step that lowers the error; a step that raises
// it is undone and the factor halved. Leaves in `mix` the parameters of the lowest error
// met and returns that error.
double adam_round(const SampleSet& samples, ProductMixture& mix, int threads, std::size_t stride,
                  const GradientConfig& config, int& passes) {
  const detail::Periods periods =
      detail::variable_periods({double(samples.width), double(samples.height)});
  ProductMixture best = mix;
  PredictionGradient best_gradient;
  double best_error = INFINITY, scale = 0.1;
  std::vector<double> m1(mix.size() * kParams, 0.0), m2(m1.size(), 0.0);
  int t = 0;
  for (int step = 0; step <= config.steps; ++step) {
    PredictionGradient g = prediction_gradient(samples, mix, threads, stride);
    ++passes;
    if (g.error < best_error) {
      best = mix;
      best_error = g.error;
      best_gradient = std::move(g);
      scale = std::min(1.0, scale * 1.2);
    } else {  // undo the step, halve the rate, restart the moments
      mix = best;
      scale *= 0.5;
      std::fill(m1.begin(), m1.end(), 0.0);
      std::fill(m2.begin(), m2.end(), 0.0);
      t = 0;
    }
    if (step == config.steps) break;
    ++t;
    std::vector<double> th = pack(mix);
    const std::vector<double> grad = pack(best_gradient);
    const double c1 = 1.0 - std::pow(0.9, t), c2 = 1.0 - std::pow(0.999, t);
    for (std::size_t i = 0; i < th.size(); ++i) {
      m1[i] = 0.9 * m1[i] + 0.1 * grad[i];
      m2[i] = 0.999 * m2[i] + 0.001 * grad[i] * grad[i];
      const std::size_t j = i % kParams;
      const double rate = (j >= 7 && j < 10 ? config.colour_rate : config.rate) * scale;
      th[i] -= rate * (m1[i] / c1) / (std::sqrt(m2[i] / c2) + 1e-300);
    }
    unpack(th, mix, periods);
  }
  mix = std::move(best);
  return best_error;
}

}  // namespace

namespace detail {

double gradient_rounds(const SampleSet& samples, ProductMixture& mix, int threads,
                       std::size_t stride, const GradientConfig& config, double error,
                       int& passes) {
  const std::size_t pass_stride =
      std::max<std::size_t>(1, samples.size() / std::max<std::size_t>(config.samples, 1));
  for (int r = 0; r < config.rounds; ++r) {
    ProductMixture trial = mix;
    adam_round(samples, trial, threads, pass_stride, config, passes);
    const ColourRefit refit =
        refit_colour_means(colour_normal_equations(samples, trial, threads, stride), trial);
    if (!(refit.error_after < error)) break;
    error = refit.error_after;
    mix = std::move(trial);
  }
  return error;
}

}  // namespace detail

}  // namespace btfgmm
