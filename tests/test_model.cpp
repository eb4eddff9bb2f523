// The model: fast exp, EM (reference and grid paths), prediction, the model file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <utility>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/samples.hpp"
#include "core/fast_exp.hpp"
#include "test_util.hpp"
#if defined(__AVX512F__)
#include "model/em_avx512.hpp"
#endif

#include <zlib.h>
#include <cstring>

namespace btfgmm {
namespace {

TEST(FastExp, RelativeErrorWithinThreeUlp) {
  double worst = 0;
  for (float x = -87.0f; x <= 0.0f; x += 0.000731f) {
    const double exact = std::exp(double(x));
    const double rel = std::abs(double(detail::fast_exp(x)) - exact) / exact;
    worst = std::max(worst, rel);
  }
  EXPECT_LT(worst, 3.0 * 5.96e-8) << "worst relative error " << worst;
  EXPECT_EQ(detail::fast_exp(-200.0f), 0.0f);
  EXPECT_EQ(detail::fast_exp(0.0f), 1.0f);
}

#if defined(__AVX512F__)
TEST(FastExp, SixteenLanesWithinThreeUlp) {
  double worst = 0;
  for (float x0 = -87.0f; x0 <= 0.0f; x0 += 16 * 0.000731f) {
    alignas(64) float in[16], out[16];
    for (int i = 0; i < 16; ++i) in[i] = x0 + float(i) * 0.000731f;
    _mm512_store_ps(out, detail::fast_exp16(_mm512_load_ps(in)));
    for (int i = 0; i < 16; ++i) {
      const double exact = std::exp(double(in[i]));
      worst = std::max(worst, std::abs(double(out[i]) - exact) / exact);
    }
  }
  EXPECT_LT(worst, 3.0 * 5.96e-8) << "worst relative error " << worst;
  alignas(64) float out[16];
  _mm512_store_ps(out, detail::fast_exp16(_mm512_set1_ps(-300.0f)));
  EXPECT_EQ(out[0], 0.0f);
}
#endif

// A known 9-D product mixture, well separated.
ProductMixture known_mixture() {
  ProductMixture t;
  t.weight = {0.5, 0.3, 0.2};
  for (int k = 0; k < 3; ++k) {
    std::array<double, kVariables> mu{}, var{};
    for (int n = 0; n < kVariables; ++n) {
      mu[n] = 10.0 * k * ((n % 3) + 1) + n;  // far apart in every variable
      var[n] = std::pow(0.5 + 0.25 * k + 0.1 * n, 2);
    }
    t.mean.push_back(mu);
    t.var.push_back(var);
  }
  return t;
}

std::vector<double> draw(const ProductMixture& t, std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::discrete_distribution<int> pick(t.weight.begin(), t.weight.end());
  std::normal_distribution<double> g;
  std::vector<double> x(n * kVariables);
  for (std::size_t i = 0; i < n; ++i) {
    const int k = pick(rng);
    for (int v = 0; v < kVariables; ++v)
      x[i * kVariables + v] = t.mean[k][v] + std::sqrt(t.var[k][v]) * g(rng);
  }
  return x;
}

TEST(Em, RecoversAKnownProductMixture) {
  const ProductMixture truth = known_mixture();
  const std::vector<double> x = draw(truth, 20000, 1);
  // Start from the true means shifted by 1.5 deviations, the overall variance, equal weights.
  ProductMixture mix;
  for (int k = 0; k < 3; ++k) {
    std::array<double, kVariables> mu{}, var{};
    for (int n = 0; n < kVariables; ++n) {
      mu[n] = truth.mean[k][n] + 1.5 * std::sqrt(truth.var[k][n]) * ((n + k) % 2 ? 1 : -1);
      var[n] = 200.0;
    }
    mix.weight.push_back(1.0 / 3);
    mix.mean.push_back(mu);
    mix.var.push_back(var);
  }
  EmConfig c;
  c.max_iterations = 60;
  c.variance_floor = 1e-6;  // no floor active
  const EmResult r = fit_em_reference(x, mix, c);
  ASSERT_EQ(mix.size(), 3u);
  for (std::size_t i = 1; i < r.log_likelihood.size(); ++i)
    EXPECT_GE(r.log_likelihood[i], r.log_likelihood[i - 1] - 1e-12) << "iteration " << i + 1;
  // Match each fitted component to the true one with the nearest mean.
  for (int k = 0; k < 3; ++k) {
    std::size_t best = 0;
    double best_d = 1e300;
    for (std::size_t j = 0; j < 3; ++j) {
      double d = 0;
      for (int n = 0; n < kVariables; ++n) d += std::pow(mix.mean[j][n] - truth.mean[k][n], 2);
      if (d < best_d) best_d = d, best = j;
    }
    // Tolerances: weights +-0.02; means within 0.1 deviation; deviations within 5 %
    // (N = 20000, so the standard errors are ~0.01, ~0.02 sigma and ~1 %).
    EXPECT_NEAR(mix.weight[best], truth.weight[k], 0.02);
    for (int n = 0; n < kVariables; ++n) {
      const double sd = std::sqrt(truth.var[k][n]);
      EXPECT_NEAR(mix.mean[best][n], truth.mean[k][n], 0.1 * sd) << "component " << k;
      EXPECT_NEAR(std::sqrt(mix.var[best][n]), sd, 0.05 * sd) << "component " << k;
    }
  }
}

TEST(Em, DropsVanishedComponents) {
  const ProductMixture truth = known_mixture();
  const std::vector<double> x = draw(truth, 3000, 2);
  ProductMixture mix = truth;
  // A fourth component far from every sample.
  mix.weight = {0.3, 0.3, 0.3, 0.1};
  auto far = truth.mean[0];
  for (double& v : far) v += 1e4;
  mix.mean.push_back(far);
  mix.var.push_back(truth.var[0]);
  EmConfig c;
  c.max_iterations = 3;
  const EmResult r = fit_em_reference(x, mix, c);
  EXPECT_EQ(r.dropped, 1u);
  EXPECT_EQ(mix.size(), 3u);
  EXPECT_NEAR(std::accumulate(mix.weight.begin(), mix.weight.end(), 0.0), 1.0, 1e-12);
}

TEST(Em, RejectsNonsenseInput) {
  std::vector<double> x(9 * 10, 0.0);
  ProductMixture empty;
  EXPECT_THROW(fit_em_reference(x, empty, EmConfig{}), Error);
  ProductMixture one = known_mixture();
  EmConfig c;
  c.max_iterations = 0;
  EXPECT_THROW(fit_em_reference(x, one, c), Error);
}

// A small BTF on a grid with smooth structure, without the generator.
Btf small_btf(int w, int h, const DirectionSet& lights, const DirectionSet& views) {
  Btf b(lights, views, w, h, SampleFormat::kLdr8);
  for (std::size_t l = 0; l < lights.size(); ++l)
    for (std::size_t v = 0; v < views.size(); ++v)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const Vec3 L = to_vector(lights[l]), V = to_vector(views[v]);
          const double shade = std::max(0.0, L.z * (0.6 + 0.4 * std::sin(x * 1.3 + L.x * 2)));
          for (int c = 0; c < 3; ++c)
            b.at(l, v, x, y, c) = float(std::round(
                20 + 180 * shade * (0.5 + 0.5 * std::cos(y * 0.9 + c)) + 30 * V.z * (c == 1)));
        }
  return b;
}

std::vector<double> explicit_samples(const SampleSet& s) {
  std::vector<double> x(s.size() * kVariables);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto v = s.sample(i);
    std::copy(v.begin(), v.end(), x.begin() + std::ptrdiff_t(i * kVariables));
  }
  return x;
}

// Fits `components` components for `iterations` iterations by the grid path and by the
// reference path from the same start: L after every iteration equal to 1e-6 relative, the
// weights to `weight_tolerance`, the means to 1e-3 (times sigma with `scaled_means`).
// Returns the largest relative difference of L.
double expect_grid_equals_reference(const DirectionSet& lights, const DirectionSet& views,
                                    std::size_t components, std::uint64_t seed, int iterations,
                                    double weight_tolerance, bool scaled_means) {
  const Btf btf = small_btf(6, 5, lights, views);
  const SampleSet s = make_sample_set(btf);
  ProductMixture a = initial_mixture(s, components, seed), b = a;
  EmConfig c;
  c.max_iterations = iterations;
  const EmResult ra = fit_em(s, a, c);
  const EmResult rb = fit_em_reference(explicit_samples(s), b, c, {}, {6, 5});  // x, y wrap
  EXPECT_EQ(ra.log_likelihood.size(), rb.log_likelihood.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < std::min(ra.log_likelihood.size(), rb.log_likelihood.size()); ++i) {
    EXPECT_NEAR(ra.log_likelihood[i], rb.log_likelihood[i], 1e-6 * std::abs(rb.log_likelihood[i]))
        << "iteration " << i + 1;
    worst = std::max(worst, std::abs(ra.log_likelihood[i] / rb.log_likelihood[i] - 1.0));
  }
  EXPECT_NEAR(ra.final_log_likelihood, rb.final_log_likelihood,
              1e-6 * std::abs(rb.final_log_likelihood));
  EXPECT_EQ(a.size(), b.size());
  for (std::size_t m = 0; m < std::min(a.size(), b.size()); ++m) {
    EXPECT_NEAR(a.weight[m], b.weight[m], weight_tolerance);
    for (int n = 0; n < kVariables; ++n) {
      // x and y on the circle of the tile: a mean at 6 - 1e-12 is the one at 1e-12.
      const double period = n == 0 ? 6.0 : n == 1 ? 5.0 : 0.0;
      const double d = a.mean[m][n] - b.mean[m][n];
      EXPECT_NEAR(period > 0 ? d - period * std::round(d / period) : d, 0.0,
                  1e-3 * (scaled_means ? std::sqrt(b.var[m][n]) : 1.0));
    }
  }
  for (std::size_t i = 1; i < ra.log_likelihood.size(); ++i)
    EXPECT_GE(ra.log_likelihood[i], ra.log_likelihood[i - 1] - 1e-6);
  return worst;
}

TEST(Em, GridPathEqualsReferencePath) {
  expect_grid_equals_reference(DirectionSet::parse("rings:0/1,30/4,60/6"),
                               DirectionSet::parse("rings:0/1,45/5"), 8, 3, 8, 1e-5, false);
}

// Enough components (10 vectors of 16) and views (groups of four) that the fast path's chunk
// bound and exact skip drop whole vectors of components: still the reference's result.
TEST(Em, GridPathWithSkippingEqualsReferencePath) {
  const double worst = expect_grid_equals_reference(DirectionSet::parse("rings:0/1,30/4,60/6"),
                                                    DirectionSet::parse("rings:0/1,30/4,60/8"), 160,
                                                    5, 6, 1e-6, true);
  std::printf(
      "M = 160, 6 iterations: largest relative difference of L, grid path against the "
      "reference path: %.2e\n",
      worst);
}

// The samples of an 8 x 8 small_btf with 7 lights and 7 views.
SampleSet ring_samples() {
  return make_sample_set(small_btf(8, 8, DirectionSet::parse("rings:0/1,40/6"),
                                   DirectionSet::parse("rings:0/1,40/6")));
}

// EM's timing probe holds the first lights' samples as the whole set holds them, and its
// estimate of an iteration is a positive time (its size checked first, as EM's).
TEST(Em, TheTimingProbeHoldsTheFirstLightsSamples) {
  const SampleSet s = ring_samples();
  const SampleSet p = first_lights(s, 2);
  EXPECT_EQ(p.held_lights(), 2u);
  EXPECT_EQ(p.held_size() * 7, s.held_size() * 2);
  for (std::size_t px = 0; px < s.pixels(); px += 5)
    for (std::size_t l = 0; l < 2; ++l)
      for (std::size_t v = 0; v < s.views; ++v)
        for (int c = 0; c < 3; ++c)
          ASSERT_EQ(p.residual_of(px, l, v, c), s.residual_of(px, l, v, c));
  EXPECT_EQ(p.sample(3 * 7 * 7 + 1 * 7 + 4),
            s.sample(3 * 7 * 7 + 1 * 7 + 4));  // pixel 3, light 1, view 4
  EXPECT_GT(estimate_em_iteration_seconds(s, 40, 1), 0.0);
  EXPECT_THROW(estimate_em_iteration_seconds(s, s.size() + 1, 1), Error);
}

TEST(Em, FinalLogLikelihoodIsThatOfTheReturnedParameters) {
  const SampleSet s = ring_samples();
  ProductMixture a = initial_mixture(s, 40, 9), b = a;
  EmConfig c;
  c.max_iterations = 3;
  const EmResult ra = fit_em(s, a, c);
  EXPECT_DOUBLE_EQ(ra.final_log_likelihood, mean_log_likelihood(s, a));
  EXPECT_GT(ra.final_log_likelihood, ra.log_likelihood.back());  // EM's gain
  EXPECT_NEAR(mean_log_likelihood(s, a), mean_log_likelihood(explicit_samples(s), a, {8, 8}),
              1e-6 * std::abs(ra.final_log_likelihood));
  c.final_log_likelihood = false;
  const EmResult rb = fit_em(s, b, c);
  EXPECT_TRUE(std::isnan(rb.final_log_likelihood));
  EXPECT_EQ(rb.log_likelihood, ra.log_likelihood);
}

// Fits `start` for `iterations` iterations on `one` and on `other` threads and expects the same
// L in every iteration and the same parameters bit for bit; returns both fits' results.
std::pair<EmResult, EmResult> expect_same_fit_on_threads(const SampleSet& s,
                                                         const ProductMixture& start,
                                                         int iterations, int one, int other) {
  ProductMixture a = start, b = start;
  EmConfig c;
  c.max_iterations = iterations;
  c.threads = one;
  const EmResult ra = fit_em(s, a, c);
  c.threads = other;
  const EmResult rb = fit_em(s, b, c);
  EXPECT_EQ(ra.log_likelihood, rb.log_likelihood);
  EXPECT_EQ(a.size(), b.size());
  for (std::size_t m = 0; m < std::min(a.size(), b.size()); ++m) {
    EXPECT_EQ(a.weight[m], b.weight[m]);
    EXPECT_EQ(a.mean[m], b.mean[m]);
    EXPECT_EQ(a.var[m], b.var[m]);
  }
  return {ra, rb};
}

TEST(Em, SameModelWithOneOrTwoThreads) {
  const SampleSet s = ring_samples();
  expect_same_fit_on_threads(s, initial_mixture(s, 12, 9), 5, 1, 2);
}

// A tile of more than 4096 pixels (16 chunks of a light, each flushing its per-view sums
// twice) and lights enough that 1 and 16 threads cut the lights into different batches: the
// same model bit for bit.
TEST(Em, SameModelWhateverTheThreadsAndTheBatchesOfLights) {
  const SampleSet s = make_sample_set(small_btf(66, 66, DirectionSet::parse("rings:0/1,30/4,60/4"),
                                                DirectionSet::parse("rings:0/1,45/3")));
  const auto [ra, rb] = expect_same_fit_on_threads(s, initial_mixture(s, 12, 4), 3, 1, 16);
  EXPECT_EQ(ra.final_log_likelihood, rb.final_log_likelihood);
}

// With tile_wraps off the grid path fits the paper's plain model (what bench_fit compares with
// Armadillo): the reference path with nothing wrapped, L to 1e-6 relative in every iteration.
TEST(Em, PlainModelEqualsTheUnwrappedReferencePath) {
  const Btf btf = small_btf(6, 5, DirectionSet::parse("rings:0/1,30/4,60/6"),
                            DirectionSet::parse("rings:0/1,45/5"));
  const SampleSet s = make_sample_set(btf);
  ProductMixture a = initial_mixture(s, 8, 3), b = a;
  EmConfig c;
  c.max_iterations = 6;
  c.tile_wraps = false;
  const EmResult ra = fit_em(s, a, c);
  const EmResult rb = fit_em_reference(explicit_samples(s), b, c);  // nothing wraps
  ASSERT_EQ(ra.log_likelihood.size(), rb.log_likelihood.size());
  for (std::size_t i = 0; i < ra.log_likelihood.size(); ++i)
    EXPECT_NEAR(ra.log_likelihood[i], rb.log_likelihood[i], 1e-6 * std::abs(rb.log_likelihood[i]))
        << "iteration " << i + 1;
  EXPECT_NEAR(mean_log_likelihood(s, a, 0, false), mean_log_likelihood(explicit_samples(s), a),
              1e-6 * std::abs(rb.final_log_likelihood));
  // The wrapped fit is another model: its L differs.
  ProductMixture w = initial_mixture(s, 8, 3);
  c.tile_wraps = true;
  EXPECT_NE(fit_em(s, w, c).log_likelihood.back(), ra.log_likelihood.back());
}

TEST(Samples, MeanBrdfAndResidualsAreExact) {
  const DirectionSet lights = DirectionSet::parse("rings:0/1,30/3");
  const Btf btf = small_btf(4, 3, lights, lights);
  const SampleSet s = make_sample_set(btf);
  ASSERT_EQ(s.size(), 12u * 16u);
  for (std::size_t l = 0; l < 4; ++l)
    for (std::size_t v = 0; v < 4; ++v)
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        for (int y = 0; y < 3; ++y)
          for (int x = 0; x < 4; ++x) sum += btf.at(l, v, x, y, c);
        EXPECT_NEAR(s.mean_brdf[(l * 4 + v) * 3 + c], sum / 12, 1e-4);
        const std::size_t p = 2 * 4 + 1;  // x = 1, y = 2
        EXPECT_NEAR(s.residual_of(p, l, v, c) + s.mean_brdf[(l * 4 + v) * 3 + c],
                    btf.at(l, v, 1, 2, c), 1e-4);
      }
  // The 30-degree ring of 3 is 60 degrees apart, nearer than the 30 degrees to the pole? No:
  // the nearest neighbour of each ring direction is the pole at 30 degrees.
  EXPECT_NEAR(s.scaling.unit[2], 30.0 * std::numbers::pi / 180, 1e-12);
}

// A hand-made 2-component model over a small direction set.
BtfModel two_component_model() {
  BtfModel m;
  m.lights = DirectionSet::parse("rings:0/1,40/4");
  m.views = DirectionSet::parse("rings:0/1,40/4");
  m.width = 4;
  m.height = 4;
  m.origin = {.x = 0, .y = 0, .width = 4, .height = 4};
  m.scaling.unit = {1, 1, 0.5, 0.5, 0.5, 0.5, 1, 1, 1};
  m.mean_brdf.resize(5 * 5 * 3);
  for (std::size_t i = 0; i < m.mean_brdf.size(); ++i) m.mean_brdf[i] = float(10 + i % 17);
  m.mixture.weight = {0.25, 0.75};
  m.mixture.mean = {{1, 2, 0.1, -0.2, 0.3, 0.0, 5, -3, 2},
                    {2.5, 0.5, -0.4, 0.5, -0.1, 0.2, -4, 6, 1}};
  m.mixture.var = {{1, 2, 0.5, 0.6, 0.7, 0.8, 3, 3, 3}, {1.5, 0.8, 0.9, 0.4, 0.6, 0.5, 2, 2, 2}};
  m.settings.components = 2;
  return m;
}

// Eq. (8)-(11) by hand: W_m proportional to w_m prod_{n<6} N(x_n | mu, sigma), x and y
// wrapped (the image of the mean nearest to the point).
std::array<double, 3> by_hand(const BtfModel& m, double x, double y, Direction l, Direction v,
                              std::array<double, 3> mean) {
  const OnionSlice ol = to_onion_slice(l), ov = to_onion_slice(v);
  const double in[6] = {x, y, ol.alpha / 0.5, ol.beta / 0.5, ov.alpha / 0.5, ov.beta / 0.5};
  double w[2];
  for (int k = 0; k < 2; ++k) {
    w[k] = m.mixture.weight[k];
    for (int n = 0; n < 6; ++n) {
      double d = in[n] - m.mixture.mean[k][n];
      // x and y wrap around the tile: the nearest image of the mean.
      const double period = n == 0 ? m.width : n == 1 ? m.height : 0;
      while (period > 0 && d > period / 2) d -= period;
      while (period > 0 && d < -period / 2) d += period;
      w[k] *= std::exp(-0.5 * d * d / m.mixture.var[k][n]) /
              std::sqrt(2 * std::numbers::pi * m.mixture.var[k][n]);
    }
  }
  std::array<double, 3> rgb{};
  for (int c = 0; c < 3; ++c)
    rgb[c] = (w[0] * m.mixture.mean[0][6 + c] + w[1] * m.mixture.mean[1][6 + c]) / (w[0] + w[1]) +
             mean[c];
  return rgb;
}

TEST(Predict, EqualsHandComputedTwoComponentModel) {
  const BtfModel m = two_component_model();
  // A measured pair: light 2 = (40, 90), view 0 = (0, 0); the mean BRDF is stored.
  {
    const auto got = predict(m, Query{.x = 1.5, .y = 2.25, .light = {40, 90}, .view = {0, 0}});
    const float* mb = &m.mean_brdf[(2 * 5 + 0) * 3];
    const auto want = by_hand(m, 1.5, 2.25, {40, 90}, {0, 0}, {mb[0], mb[1], mb[2]});
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-4);
  }
  // Unmeasured: light (40, 45) is halfway between lights 1 (40, 0) and 2 (40, 90) on the
  // ring, so its mean BRDF is their average. x wraps: 5.5 is 1.5 of the 4-pixel tile.
  {
    const auto got = predict(m, Query{.x = 5.5, .y = -1.0, .light = {40, 45}, .view = {40, 180}});
    const float* a = &m.mean_brdf[(1 * 5 + 3) * 3];
    const float* b = &m.mean_brdf[(2 * 5 + 3) * 3];
    const auto want = by_hand(m, 1.5, 3.0, {40, 45}, {40, 180},
                              {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])});
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-4);
  }
  EXPECT_THROW(predict(m, Query{0, 0, {95, 0}, {0, 0}}), Error);
  EXPECT_THROW(predict(m, Query{0, 0, {NAN, 0}, {0, 0}}), Error);
}

// decode() of the model's 5 x 5 directions on a 6 x 5 tile against predict() at every pixel
// of every step-th light and view.
void expect_decode_equals_predict(const BtfModel& m, std::size_t step, double tolerance) {
  const Btf d = decode(m, m.lights, m.views, 6, 5);
  std::vector<Query> queries;
  for (std::size_t l = 0; l < 5; l += step)
    for (std::size_t v = 0; v < 5; v += step)
      for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 6; ++x)
          queries.push_back({double(x), double(y), m.lights[l], m.views[v]});
  std::vector<float> rgb(queries.size() * 3);
  predict(m, queries, rgb);
  std::size_t i = 0;
  for (std::size_t l = 0; l < 5; l += step)
    for (std::size_t v = 0; v < 5; v += step)
      for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 6; ++x, ++i)
          for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(d.at(l, v, x, y, c), rgb[i * 3 + std::size_t(c)], tolerance);
}

TEST(Predict, DecodeEqualsPointPredictions) {
  expect_decode_equals_predict(two_component_model(), 1, 1e-3);
}

// Components narrow in x and y: over a block of pixels their log weights span far more than
// float's range, so decode takes each pixel's own maximum (the two-pass path).
TEST(Predict, DecodeOfNarrowComponentsEqualsPointPredictions) {
  BtfModel m = two_component_model();
  for (auto& v : m.mixture.var) v[0] = v[1] = 0.02;
  expect_decode_equals_predict(m, 2, 2e-3);
}

TEST(ModelFile, RoundTripIsBitExact) {
  const BtfModel m = two_component_model();
  const auto bytes = serialize_model(m);
  const BtfModel back = deserialize_model(bytes, "mem");
  EXPECT_EQ(serialize_model(back), bytes);
  for (std::size_t k = 0; k < 2; ++k)
    for (int n = 0; n < kVariables; ++n)
      EXPECT_EQ(float(back.mixture.mean[k][n]), float(m.mixture.mean[k][n]));
  EXPECT_EQ(back.mean_brdf, m.mean_brdf);
  EXPECT_EQ(back.lights, m.lights);
  // f16 halves the parameters.
  BtfModel h = m;
  h.precision = Precision::kF16;
  const auto hb = serialize_model(h);
  EXPECT_LT(hb.size(), bytes.size());
  EXPECT_EQ(serialize_model(deserialize_model(hb, "mem")), hb);
}

// A parameter beyond a 16-bit float's range would be written as infinity (or a deviation as
// zero): the file would not read back, so it is refused before a byte is written.
TEST(ModelFile, AMixtureOutsideF16sRangeIsRefusedAndKeptInF32) {
  BtfModel m = two_component_model();
  m.mixture.mean[1][6] = 68659.0;  // a cancelling colour mean, as the colour refit can leave
  m.precision = Precision::kF16;
  const std::string why = test::error_of([&] { serialize_model(m); });
  EXPECT_NE(why.find("cannot be stored as f16: component 1's mean of r is 68659"),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("store it as compact (the default) or f32"), std::string::npos) << why;
  m.precision = Precision::kF32;
  EXPECT_EQ(deserialize_model(serialize_model(m), "mem").mixture.mean[1][6], 68659.0);
  m.precision = Precision::kF16;
  m.mixture.mean[1][6] = 65504.0;  // the largest a half holds
  EXPECT_EQ(deserialize_model(serialize_model(m), "mem").mixture.mean[1][6], 65504.0);
  m.mixture.var[0][2] = 1e-18;  // a deviation of 1e-9 rounds to a half's zero
  EXPECT_NE(test::error_of([&] {
              serialize_model(m);
            }).find("component 0's deviation in alpha_i is 1e-09"),
            std::string::npos);
}

TEST(ModelFile, EveryTruncatedPrefixIsRejected) {
  const auto bytes = serialize_model(two_component_model());
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + std::ptrdiff_t(n));
    EXPECT_THROW(deserialize_model(cut, "cut.btfgmm"), Error) << "prefix " << n;
  }
}

TEST(ModelFile, EverySingleByteCorruptionIsRejected) {
  const auto bytes = serialize_model(two_component_model());
  for (std::size_t i = 0; i < bytes.size(); ++i)
    for (std::uint8_t flip : {std::uint8_t(0x01), std::uint8_t(0x80), std::uint8_t(0xFF)}) {
      auto bad = bytes;
      bad[i] ^= flip;
      EXPECT_THROW(deserialize_model(bad, "bad.btfgmm"), Error) << "byte " << i;
    }
}

TEST(ModelFile, NewerVersionPngAndEmptyGiveTheirMessages) {
  auto bytes = serialize_model(two_component_model());
  bytes[8] = kModelFormatVersion + 1;  // a newer version, with a valid checksum
  const auto crc = std::uint32_t(crc32(0L, bytes.data(), uInt(bytes.size() - 4)));
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  try {
    deserialize_model(bytes, "new.btfgmm");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("newer"), std::string::npos) << e.what();
  }
  const std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0};
  try {
    deserialize_model(png, "pic.btfgmm");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("PNG"), std::string::npos) << e.what();
  }
  EXPECT_THROW(deserialize_model({}, "empty.btfgmm"), Error);
}

// A model file of format version 1 committed in tests/data: it must keep loading and decoding
// to the same numbers, with no provenance; written again (version 5) it holds the same payload
// after its method tag and empty provenance, and reads back to the same model.
TEST(ModelFile, GoldenVersion1FileKeepsDecoding) {
  const std::filesystem::path path = std::filesystem::path(BTFGMM_TEST_DATA) / "golden_v1.btfgmm";
  const BtfModel m = load_model(path);
  EXPECT_EQ(m.mixture.size(), 2u);
  EXPECT_EQ(m.origin.x, 2);
  EXPECT_EQ(m.origin.y, 3);
  EXPECT_EQ(m.settings.seed, 42u);
  EXPECT_EQ(m.settings.log_likelihood, -12.5);
  std::ifstream in(path, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  const std::vector<std::uint8_t> v1_payload(bytes.begin() + 24, bytes.end() - 4);
  EXPECT_EQ(mixture_payload(m), v1_payload);
  EXPECT_FALSE(m.provenance.recorded);
  const auto v3 = serialize_model(m);
  EXPECT_EQ(v3[8], kModelFormatVersion);
  EXPECT_EQ(serialize_model(deserialize_model(v3, "v3")), v3);
  EXPECT_EQ(std::vector<std::uint8_t>(v3.begin() + 34, v3.end() - 4), v1_payload);
  const Query queries[] = {{.x = 1.5, .y = 2.25, .light = {40, 90}, .view = {0, 0}},
                           {.x = 5.5, .y = -1.0, .light = {40, 45}, .view = {40, 180}},
                           {.x = 0, .y = 0, .light = {0, 0}, .view = {0, 0}},
                           {.x = 3.9, .y = 3.9, .light = {80, 300}, .view = {20, 10}}};
  // The predictions of the spatial Gaussians wrapped around the 4 x 4 tile (the file is read
  // as it was written; the model it holds is now evaluated wrapped). Unwrapped, queries 1-3
  // gave {20.8143978, 14.6856012, 20.2015991}, {9.66214371, 13.8378563, 13.6291275} and
  // {16.4682293, 27.3173828, 20.7432938}: each moved by exactly the change of Eq. (8)'s colour
  // between the plain and the minimum-image x, y terms, computed apart in numpy; query 0 lies
  // within half a tile of both means and is unchanged.
  const float expected[4][3] = {{25.6619873f, 23.8380127f, 26.9624424f},
                                {17.8068428f, 17.6931572f, 19.8674278f},
                                {7.49780703f, 16.0021935f, 13.3886452f},
                                {16.3953438f, 27.3902683f, 20.7351952f}};
  for (int i = 0; i < 4; ++i) {
    const auto rgb = predict(m, queries[i]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], expected[i][c], 1e-4) << "query " << i;
  }
}

TEST(ModelFile, SaveIsAtomicAndLoadNamesTheFile) {
  const auto dir = std::filesystem::temp_directory_path() / "btfgmm_model_save";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const BtfModel m = two_component_model();
  save_model(m, dir / "a.btfgmm");
  EXPECT_EQ(serialize_model(load_model(dir / "a.btfgmm")), serialize_model(m));
  // Nothing but the model is left in the folder.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir),
                          std::filesystem::directory_iterator()),
            1);
  EXPECT_THROW(save_model(m, dir / "missing" / "a.btfgmm"), Error);
  try {
    load_model(dir / "nope.btfgmm");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nope.btfgmm"), std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

TEST(CompressionRatio, PaperFigureForKnittedWool) {
  // 25 x 25 tile, 81 x 81 directions, M = 600: 12,301,875 / (43,200 + 19,683) = 195.6.
  BtfModel m;
  m.lights = m.views = DirectionSet::ubo81();
  m.width = m.height = 25;
  m.mixture.resize(600);
  EXPECT_NEAR(m.compression_ratio_paper(), 195.6, 0.05);
  EXPECT_NEAR(m.compression_ratio_file(100000), 123.01875, 1e-9);
}

}  // namespace
}  // namespace btfgmm
