// The gradient passes of the fit for the prediction (model/refine.hpp): the analytic gradient
// of the prediction's squared error against finite differences, the refinement never raising
// the error, the same model bit for bit with one thread and with two, and a stop ending it.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"
#include "btfgmm/synth/generate.hpp"
#include "model/refine_internal.hpp"

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

// The float pass the Adam steps take agrees with the double pass above: the error to 1e-6
// relative, every derivative within 1e-4 of the gradient's largest of its kind, over a
// subsample (a stride, as the steps take it) and over all samples.
TEST(RefineGradient, FloatPassAgreesWithTheDoublePass) {
  const SampleSet s = knit_samples(8);
  const ProductMixture mix = em_mixture(s, std::size_t(12));
  for (std::size_t stride : {std::size_t(1), std::size_t(7)}) {
    const PredictionGradient d = prediction_gradient(s, mix, 2, stride, PassPrecision::kDouble);
    const PredictionGradient f = prediction_gradient(s, mix, 1, stride, PassPrecision::kFloat);
    EXPECT_EQ(f.samples, d.samples);
    // The same subsample as the colour refit's normal equations (GridWeights::kept).
    const ColourNormalEquations eq = colour_normal_equations(s, mix, 1, stride);
    EXPECT_EQ(d.samples, eq.samples);
    EXPECT_NEAR(d.error, prediction_squared_error(eq, mix), 1e-9 * d.error);
    EXPECT_NEAR(f.error, d.error, 1e-6 * d.error);
    double top[3] = {0, 0, 0}, worst[3] = {0, 0, 0};  // a, mu, s
    for (std::size_t k = 0; k < mix.size(); ++k) {
      top[0] = std::max(top[0], std::abs(d.log_weight[k]));
      for (double g : d.mean[k]) top[1] = std::max(top[1], std::abs(g));
      for (double g : d.log_var[k]) top[2] = std::max(top[2], std::abs(g));
    }
    for (std::size_t k = 0; k < mix.size(); ++k) {
      worst[0] = std::max(worst[0], std::abs(f.log_weight[k] - d.log_weight[k]) / top[0]);
      for (int n = 0; n < kVariables; ++n)
        worst[1] = std::max(
            worst[1], std::abs(f.mean[k][std::size_t(n)] - d.mean[k][std::size_t(n)]) / top[1]);
      for (int n = 0; n < kInputs; ++n)
        worst[2] = std::max(
            worst[2],
            std::abs(f.log_var[k][std::size_t(n)] - d.log_var[k][std::size_t(n)]) / top[2]);
    }
    for (double w : worst) EXPECT_LT(w, 1e-4) << "stride " << stride;
    std::printf("stride %zu: float against double %.1e %.1e %.1e (a, mu, s)\n", stride, worst[0],
                worst[1], worst[2]);
  }
}

// The float pass skips the chunks of components negligible for a sample (model/refine_pass.hpp)
// and still agrees with the double pass, which weighs every component of every sample: on a
// 16 x 16 tile with 64 components of sigma = 0.32 pixels in x and y, most components are
// negligible at any pixel (below e^-(log M + 17.5) of its largest weight), so the pass skips
// most of them; the error agrees to 1e-6 relative and every derivative to 1e-4 of the
// largest of its kind, as without skipping.
TEST(RefineGradient, FloatPassSkipsNegligibleComponentsWithinTheTolerance) {
  const SampleSet s = knit_samples(16);
  ProductMixture mix = em_mixture(s, std::size_t(64));
  for (auto& var : mix.var) var[0] = var[1] = 0.1;
  const PredictionGradient d = prediction_gradient(s, mix, 1, 1, PassPrecision::kDouble);
  const PredictionGradient f = prediction_gradient(s, mix, 2, 1, PassPrecision::kFloat);
  EXPECT_EQ(d.weighed, 1.0);
  EXPECT_LT(f.weighed, 0.6);
  EXPECT_GT(f.weighed, 0.0);
  EXPECT_NEAR(f.error, d.error, 1e-6 * d.error);
  double top = 0.0, worst = 0.0;
  for (std::size_t k = 0; k < mix.size(); ++k)
    for (int n = 0; n < kVariables; ++n) top = std::max(top, std::abs(d.mean[k][std::size_t(n)]));
  for (std::size_t k = 0; k < mix.size(); ++k)
    for (int n = 0; n < kVariables; ++n)
      worst = std::max(worst, std::abs(f.mean[k][std::size_t(n)] - d.mean[k][std::size_t(n)]));
  EXPECT_LT(worst, 1e-4 * top);
  std::printf("weighed %.3f of the components; float against double %.1e (mu)\n", f.weighed,
              worst / top);
}

// EM's mixture of 12 components (seed 3) after `iterations` iterations: the start of a refit.
ProductMixture em_mixture(const SampleSet& s, int iterations) {
  ProductMixture em = initial_mixture(s, 12, 3);
  EmConfig config;
  config.max_iterations = iterations;
  fit_em(s, em, config);
  return em;
}

// Refining never leaves the validation error above EM's: the colour refit alone, a few steps,
// many, and steps at a rate far too large to descend (each stage is kept only where it lowers
// the validation error); the error reported is that of the mixture returned, counted afresh.
TEST(RefineGradient, NeverRaisesTheValidationErrorAboveEms) {
  const SampleSet s = knit_samples(8);
  const ProductMixture em = em_mixture(s, 8);
  const auto [em_error, held_out] = validation_error(s, em, 1);
  EXPECT_GT(held_out, s.size() / kValidationEvery / 2);
  EXPECT_LT(held_out, s.size() / kValidationEvery * 2);
  ProductMixture colour_only = em;
  GradientConfig no_steps;
  no_steps.gradient = false;
  const PredictionRefinement c = refine_for_prediction(s, colour_only, 2, no_steps);
  EXPECT_EQ(c.steps, 0);
  EXPECT_EQ(c.error_em, em_error);
  EXPECT_LE(c.error_colour, c.error_em);
  EXPECT_EQ(c.error_final, c.error_colour);
  for (const auto& [steps, rate] :
       {std::pair{10, 0.02}, std::pair{200, 0.02}, std::pair{30, 50.0}}) {
    ProductMixture mix = em;
    GradientConfig g;
    g.steps = steps;
    g.rate = rate;
    g.colour_rate = 100 * rate;
    const PredictionRefinement r = refine_for_prediction(s, mix, 2, g);
    EXPECT_EQ(r.error_em, em_error);
    EXPECT_LE(r.error_final, r.error_colour) << steps << " " << rate;
    EXPECT_LE(r.error_final, r.error_em) << steps << " " << rate;
    EXPECT_EQ(validation_error(s, mix, 1).first, r.error_final) << steps << " " << rate;
    std::printf("%d steps at rate %g: validation RMSE %.4f (EM) -> %.4f levels, training %.4f\n",
                steps, rate, prediction_rmse(r.error_em, r.samples),
                prediction_rmse(r.error_final, r.samples), r.training_rmse);
    if (steps >= 200) {
      EXPECT_LT(r.error_final, 0.95 * c.error_colour) << steps;
    }
  }
}

// The minibatches of an epoch and the validation set split the tile: every sample is in
// exactly one of them, the validation set is about 1 in kValidationEvery of the samples, and
// each minibatch about as large as the others.
TEST(RefineGradient, MinibatchesAndValidationSplitTheTile) {
  const SampleSet s = knit_samples(16);
  const std::size_t pairs = s.lights * s.views, batches = 7;
  std::vector<std::size_t> size(batches, 0);
  std::size_t held_out = 0;
  for (std::size_t p = 0; p < s.pixels(); ++p)
    for (std::size_t j = 0; j < pairs; ++j) {
      int in = 0;
      const detail::Selection validation{1, 0, detail::Selection::Part::kValidation};
      if (validation.takes(p, j, pairs)) ++in, ++held_out;
      for (std::size_t b = 0; b < batches; ++b)
        if (detail::Selection{batches, b, detail::Selection::Part::kTraining}.takes(p, j, pairs))
          ++in, ++size[b];
      EXPECT_EQ(in, 1) << p << " " << j;
    }
  EXPECT_NEAR(double(held_out) / double(s.size()), 1.0 / kValidationEvery, 0.01);
  for (std::size_t b = 0; b < batches; ++b)
    EXPECT_NEAR(double(size[b]), double(s.size() - held_out) / batches,
                0.1 * double(s.size()) / batches);
  EXPECT_EQ(validation_error(s, em_mixture(s, std::size_t(4)), 2).second, held_out);
}

// The components a tile supports for the fit for the prediction, and the refusal of more
// before any work.
TEST(RefineGradient, MoreComponentsThanTheTileSupportsAreRefused) {
  EXPECT_EQ(supported_components(625 * 6561), 625u * 6561 * 19 / 20 / kSamplesPerComponent);
  GenerateConfig gc;
  gc.material = "knit";
  gc.size = 4;
  gc.lights = DirectionSet::parse("rings:0/1,40/6");
  gc.views = DirectionSet::parse("rings:0/1,40/3");
  const Btf tile = generate(gc);  // 16 pixels x 7 x 4 directions: 448 samples
  FitConfig c;
  c.components = supported_components(448) + 1;
  c.objective = FitObjective::kPrediction;
  try {
    fit_model(tile, c);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("support at most"), std::string::npos) << e.what();
  }
  c.objective = FitObjective::kLikelihood;  // the paper's EM takes them
  c.em.max_iterations = 1;
  EXPECT_EQ(fit_model(tile, c).mixture.size(), c.components);
}

// Every sum is reduced in fixed chunks and order: the refined mixture is the same bit for bit
// with one thread and with two.
TEST(RefineGradient, SameModelWithAnyNumberOfThreads) {
  const SampleSet s = knit_samples(8);
  const ProductMixture em = em_mixture(s, 5);
  ProductMixture one = em, two = em;
  GradientConfig g;
  g.steps = 60;
  refine_for_prediction(s, one, 1, g);
  refine_for_prediction(s, two, 2, g);
  EXPECT_EQ(one.weight, two.weight);
  EXPECT_EQ(one.mean, two.mean);
  EXPECT_EQ(one.var, two.var);
  const ColourNormalEquations a = colour_normal_equations(s, em, 1);
  const ColourNormalEquations b = colour_normal_equations(s, em, 2);
  EXPECT_EQ(a.gram, b.gram);
  EXPECT_EQ(a.rhs, b.rhs);
}

// The float pass over many chunks with enough components for whole vectors: the same bits
// with one, two and three threads (each thread's buffers are aligned alike, so the vector
// sums run in the same order whichever thread takes a chunk).
TEST(RefineGradient, FloatPassIsTheSameWithAnyNumberOfThreads) {
  const SampleSet s = knit_samples(16);  // 256 pixels: 8 chunks
  const ProductMixture mix = em_mixture(s, std::size_t(72));
  const PredictionGradient one = prediction_gradient(s, mix, 1, 3, PassPrecision::kFloat);
  for (int threads : {2, 3}) {
    const PredictionGradient more = prediction_gradient(s, mix, threads, 3, PassPrecision::kFloat);
    EXPECT_EQ(one.error, more.error) << threads;
    EXPECT_EQ(one.log_weight, more.log_weight) << threads;
    EXPECT_EQ(one.mean, more.mean) << threads;
    EXPECT_EQ(one.log_var, more.log_var) << threads;
  }
}

// A stop set after step 5 ends the steps there: the refinement is that of 5 steps, bit for
// bit (the same passes, the lowest error among them kept, the same colour refit), and says
// it stopped.
TEST(RefineGradient, StopEndsTheStepsWithTheBestMet) {
  const SampleSet s = knit_samples(8);
  const ProductMixture em = em_mixture(s, 5);
  ProductMixture stopped = em, five = em;
  std::atomic<bool> stop{false};
  GradientConfig asked;
  asked.steps = 50;
  asked.stop = &stop;
  asked.progress = [&stop](const GradientProgress& p) {
    if (p.step == 5) stop.store(true);
  };
  const PredictionRefinement a = refine_for_prediction(s, stopped, 2, asked);
  EXPECT_TRUE(a.stopped);
  EXPECT_EQ(a.steps, 5);
  EXPECT_LE(a.error_final, a.error_colour);
  GradientConfig g;
  g.steps = 5;
  const PredictionRefinement b = refine_for_prediction(s, five, 2, g);
  EXPECT_FALSE(b.stopped);
  EXPECT_EQ(b.steps, 5);
  EXPECT_EQ(a.error_final, b.error_final);
  EXPECT_EQ(stopped.weight, five.weight);
  EXPECT_EQ(stopped.mean, five.mean);
  EXPECT_EQ(stopped.var, five.var);
}

}  // namespace
}  // namespace btfgmm
