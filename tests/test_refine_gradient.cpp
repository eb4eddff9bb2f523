// The gradient passes of the fit for the prediction (model/refine.hpp): the analytic gradient
// of the prediction's squared error against finite differences, the refinement never raising
// the error, and the same model bit for bit with one thread and with two.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "btfgmm/model/em.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"
#include "btfgmm/synth/generate.hpp"

namespace btfgmm {
namespace {

// The samples of a generated knit tile of w x w pixels, 7 lights x 4 views.
SampleSet knit_samples(int w) {
  GenerateConfig g;
  g.material = "knit";
  g.size = w;
  g.seed = 5;
  g.lights = DirectionSet::parse("rings:0/1,40/6");
  g.views = DirectionSet::parse("rings:0/1,40/3");
  return make_sample_set(generate(g));
}

// EM's mixture of M components on `s` (a few iterations), its colour means refitted.
ProductMixture em_mixture(const SampleSet& s, std::size_t components) {
  ProductMixture mix = initial_mixture(s, components, 3);
  EmConfig em;
  em.max_iterations = 8;
  em.threads = 1;
  fit_em(s, mix, em);
  refit_colour_means(colour_normal_equations(s, mix, 1), mix);
  return mix;
}

// dE/dtheta by central differences, theta one parameter of component k (kind 0: a_k = log w_k,
// 1: mu_kn, 2: s_kn = log sigma^2_kn).
double finite_difference(const SampleSet& s, const ProductMixture& mix, std::size_t k, int kind,
                         int n, double h) {
  double e[2];
  for (int side = 0; side < 2; ++side) {
    ProductMixture p = mix;
    const double step = side == 0 ? h : -h;
    if (kind == 0) p.weight[k] *= std::exp(step);
    if (kind == 1) p.mean[k][std::size_t(n)] += step;
    if (kind == 2) p.var[k][std::size_t(n)] *= std::exp(step);
    e[side] = prediction_gradient(s, p, 1).error;
  }
  return (e[0] - e[1]) / (2.0 * h);
}

// The analytic gradient (model/refine.hpp, prediction_gradient) agrees with central
// differences of the error to 1e-5 relative, for every kind of parameter; its error is the
// normal equations' count.
TEST(RefineGradient, AgreesWithFiniteDifferences) {
  const SampleSet s = knit_samples(6);
  const ProductMixture mix = em_mixture(s, 5);
  const PredictionGradient g = prediction_gradient(s, mix, 2);
  EXPECT_EQ(g.samples, s.size());
  const double e = prediction_squared_error(colour_normal_equations(s, mix, 1), mix);
  EXPECT_NEAR(g.error, e, 1e-9 * e);
  double worst = 0.0;
  for (std::size_t k = 0; k < mix.size(); ++k) {
    const double a = g.log_weight[k], fa = finite_difference(s, mix, k, 0, 0, 1e-5);
    worst = std::max(worst, std::abs(a - fa) / (std::abs(fa) + 1e-3 * e));
    for (int n = 0; n < kVariables; ++n) {
      const double m = g.mean[k][std::size_t(n)], fm = finite_difference(s, mix, k, 1, n, 1e-5);
      EXPECT_NEAR(m, fm, 1e-5 * std::abs(fm) + 1e-6 * e) << "mean " << k << " " << n;
      worst = std::max(worst, std::abs(m - fm) / (std::abs(fm) + 1e-3 * e));
    }
    for (int n = 0; n < kInputs; ++n) {
      const double v = g.log_var[k][std::size_t(n)], fv = finite_difference(s, mix, k, 2, n, 1e-5);
      EXPECT_NEAR(v, fv, 1e-5 * std::abs(fv) + 1e-6 * e) << "log var " << k << " " << n;
      worst = std::max(worst, std::abs(v - fv) / (std::abs(fv) + 1e-3 * e));
    }
    EXPECT_NEAR(a, fa, 1e-5 * std::abs(fa) + 1e-6 * e) << "log weight " << k;
  }
  std::printf("largest difference: %.2e relative\n", worst);
}

// EM's mixture of 12 components (seed 3) after `iterations` iterations: the start of a refit.
ProductMixture em_mixture(const SampleSet& s, int iterations) {
  ProductMixture em = initial_mixture(s, 12, 3);
  EmConfig config;
  config.max_iterations = iterations;
  fit_em(s, em, config);
  return em;
}

// The gradient passes lower the prediction's error below the colour refit's and never raise
// it, in every round; rounds 0 is the colour refit alone.
TEST(RefineGradient, NeverIncreasesThePredictionError) {
  const SampleSet s = knit_samples(8);
  const ProductMixture em = em_mixture(s, 8);
  ProductMixture colour_only = em;
  const PredictionRefinement c = refine_for_prediction(s, colour_only, 2, GradientConfig{0});
  EXPECT_EQ(c.passes, 0);
  EXPECT_EQ(c.error_final, c.error_colour);
  double previous = c.error_colour;
  for (int rounds : {1, 2, 3}) {
    ProductMixture mix = em;
    GradientConfig g;
    g.rounds = rounds;
    g.steps = 10;
    const PredictionRefinement r = refine_for_prediction(s, mix, 2, g);
    EXPECT_EQ(r.error_colour, c.error_colour);
    EXPECT_LE(r.error_final, previous) << rounds;
    // The error of the mixture returned, counted afresh.
    EXPECT_NEAR(prediction_gradient(s, mix, 1).error, r.error_final, 1e-9 * r.error_final);
    std::printf("rounds %d: RMSE %.4f -> %.4f levels (%d passes)\n", rounds,
                std::sqrt(r.error_colour / double(3 * s.size())),
                std::sqrt(r.error_final / double(3 * s.size())), r.passes);
    previous = r.error_final;
  }
  EXPECT_LT(previous, 0.95 * c.error_colour);
}

// Every sum is reduced in fixed chunks and order: the refined mixture is the same bit for bit
// with one thread and with two.
TEST(RefineGradient, SameModelWithAnyNumberOfThreads) {
  const SampleSet s = knit_samples(8);
  const ProductMixture em = em_mixture(s, 5);
  ProductMixture one = em, two = em;
  refine_for_prediction(s, one, 1);
  refine_for_prediction(s, two, 2);
  EXPECT_EQ(one.weight, two.weight);
  EXPECT_EQ(one.mean, two.mean);
  EXPECT_EQ(one.var, two.var);
  const ColourNormalEquations a = colour_normal_equations(s, em, 1);
  const ColourNormalEquations b = colour_normal_equations(s, em, 2);
  EXPECT_EQ(a.gram, b.gram);
  EXPECT_EQ(a.rhs, b.rhs);
}

}  // namespace
}  // namespace btfgmm
