// The GPU back end (docs/GPU.md) on whatever Vulkan device this machine has: in CI, Mesa's
// lavapipe (Vulkan on the CPU), which runs every shader as a GPU would. Where no Vulkan device
// exists the tests skip, except in CI (CI=true), where they fail: the kernels must run there.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/decode.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/predict_gpu.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"
#include "model/refine_internal.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

TEST(Gpu, ChoicesParseAndTheCpuOpensNoDevice) {
  EXPECT_EQ(parse_device_choice("auto"), DeviceChoice::kAuto);
  EXPECT_EQ(parse_device_choice("cpu"), DeviceChoice::kCpu);
  EXPECT_EQ(parse_device_choice("gpu"), DeviceChoice::kGpu);
  EXPECT_FALSE(parse_device_choice("cuda").has_value());
  EXPECT_EQ(device_choice_name(DeviceChoice::kGpu), "gpu");
  EXPECT_EQ(open_compute_device(DeviceChoice::kCpu), nullptr);
}

TEST(Gpu, AutoNeverTakesASoftwareDevice) {
  REQUIRE_DEVICE(device);
  const auto chosen = open_compute_device(DeviceChoice::kAuto);
  if (device->info().software)
    EXPECT_EQ(chosen, nullptr);
  else
    EXPECT_EQ(chosen, device);
  EXPECT_NE(device->info().description().find("Vulkan"), std::string::npos);
}

TEST(Gpu, BuffersKeepWhatIsWrittenAndRefuseMoreThanTheDeviceHolds) {
  REQUIRE_DEVICE(device);
  std::vector<double> values(100000);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = std::sqrt(double(i)) - 7.0;
  const auto b = device->buffer(values.size() * sizeof(double));
  device->upload_values<double>(*b, values);
  std::vector<double> back(values.size());
  device->download_values<double>(*b, back);
  EXPECT_EQ(back, values);
  try {
    device->buffer(std::size_t(device->info().memory_bytes) + 1);
    FAIL() << "a buffer larger than the device was made";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("`device` cpu"), std::string::npos) << e.what();
  }
}

// A small generated tile, M components from seed 3, `iterations` EM iterations on `device`
// (null: the CPU).
struct EmRun {
  ProductMixture mixture;
  EmResult result;
};
EmRun fit_on(const std::shared_ptr<ComputeDevice>& device, int iterations, int size = 8,
             const std::string& views = "spiral:11") {
  const SampleSet s = make_sample_set(test::generated_tile("knit", size, 1, "spiral:13", views));
  EmRun run{initial_mixture(s, 24, 3), {}};
  EmConfig config;
  config.max_iterations = iterations;
  config.device = device;
  run.result = fit_em(s, run.mixture, config);
  return run;
}

double relative(double a, double b) {
  return std::abs(a - b) / std::max(std::abs(b), 1e-300);
}

TEST(Gpu, EmGivesTheCpusLogLikelihoodAtEveryIteration) {
  REQUIRE_DEVICE(device);
  const EmRun cpu = fit_on(nullptr, 8), gpu = fit_on(device, 8);
  ASSERT_EQ(gpu.result.log_likelihood.size(), cpu.result.log_likelihood.size());
  for (std::size_t i = 0; i < cpu.result.log_likelihood.size(); ++i)
    EXPECT_LT(relative(gpu.result.log_likelihood[i], cpu.result.log_likelihood[i]), 1e-5)
        << "iteration " << i + 1 << ": " << gpu.result.log_likelihood[i] << " against "
        << cpu.result.log_likelihood[i];
  EXPECT_LT(relative(gpu.result.final_log_likelihood, cpu.result.final_log_likelihood), 1e-5);
  ASSERT_EQ(gpu.mixture.size(), cpu.mixture.size());
}

// More views than the statistics' shader holds in shared memory at once (kViewTile, 84): a
// block's views are summed in pieces.
TEST(Gpu, ABlockOfMoreViewsThanATileIsSummedInPieces) {
  REQUIRE_DEVICE(device);
  const EmRun cpu = fit_on(nullptr, 3, 4, "spiral:150"), gpu = fit_on(device, 3, 4, "spiral:150");
  ASSERT_EQ(gpu.result.log_likelihood.size(), cpu.result.log_likelihood.size());
  for (std::size_t i = 0; i < cpu.result.log_likelihood.size(); ++i)
    EXPECT_LT(relative(gpu.result.log_likelihood[i], cpu.result.log_likelihood[i]), 1e-5)
        << "iteration " << i + 1;
}

TEST(Gpu, OneMStepGivesTheCpusParameters) {
  REQUIRE_DEVICE(device);
  const EmRun cpu = fit_on(nullptr, 1), gpu = fit_on(device, 1);
  ASSERT_EQ(gpu.mixture.size(), cpu.mixture.size());
  for (std::size_t m = 0; m < cpu.mixture.size(); ++m) {
    EXPECT_NEAR(gpu.mixture.weight[m], cpu.mixture.weight[m], 1e-5 * cpu.mixture.weight[m] + 1e-9)
        << "component " << m;
    for (int n = 0; n < kVariables; ++n) {
      const double sd = std::sqrt(cpu.mixture.var[m][n]);
      EXPECT_NEAR(gpu.mixture.mean[m][n], cpu.mixture.mean[m][n], 1e-4 * sd)
          << "component " << m << ", variable " << n;
      EXPECT_NEAR(gpu.mixture.var[m][n], cpu.mixture.var[m][n], 1e-4 * cpu.mixture.var[m][n])
          << "component " << m << ", variable " << n;
    }
  }
}

// A small tile's fit with EM on the GPU beside the same fit with EM on the CPU, decoded: the
// largest difference of a decoded value (levels), and the RMS errors of the two against the
// data. `refine`: the default fit, EM then the refinement for the prediction (3 epochs).
struct DecodedPair {
  double worst = 0.0, difference_rms = 0.0, cpu_rmse = 0.0, gpu_rmse = 0.0;
};
DecodedPair fit_both(bool refine) {
  const Btf btf = test::generated_tile("corduroy", 8, 1, "spiral:13", "spiral:11");
  auto fit_with = [&](DeviceChoice choice) {
    FitConfig c = mixture_config(20, 6, 1, 2);
    c.refinement_epochs = 3;
    if (!refine) c.objective = FitObjective::kLikelihood;
    c.device = choice;
    return decode(fit_model(btf, c), btf.lights(), btf.views(), btf.width(), btf.height());
  };
  const Btf cpu = fit_with(DeviceChoice::kCpu), gpu = fit_with(DeviceChoice::kGpu);
  DecodedPair r;
  const double n = double(btf.data().size());
  for (std::size_t i = 0; i < btf.data().size(); ++i) {
    r.worst = std::max(r.worst, double(std::abs(gpu.data()[i] - cpu.data()[i])));
    r.difference_rms += std::pow(double(gpu.data()[i] - cpu.data()[i]), 2) / n;
    r.cpu_rmse += std::pow(double(cpu.data()[i] - btf.data()[i]), 2) / n;
    r.gpu_rmse += std::pow(double(gpu.data()[i] - btf.data()[i]), 2) / n;
  }
  r.difference_rms = std::sqrt(r.difference_rms);
  r.cpu_rmse = std::sqrt(r.cpu_rmse);
  r.gpu_rmse = std::sqrt(r.gpu_rmse);
  return r;
}

// EM alone: the two models decode to within 0.1 level of each other.
TEST(Gpu, EmOnTheGpuDecodesAsTheCpusWithinATenthOfALevel) {
  REQUIRE_DEVICE(device);
  const DecodedPair r = fit_both(false);
  EXPECT_LE(r.worst, 0.1);
  EXPECT_LT(std::abs(r.gpu_rmse / r.cpu_rmse - 1.0), 1e-4);
}

// The default fit, EM and the refinement's Adam steps on the device: the steps start from
// EM's parameters a rounding apart; the error on the data is the CPU's to 1 % and the two
// models decode to within 0.1 level (Adam's epsilon of the colour means keeps their first
// steps from following the rounding's sign: refine_gradient.cpp, adam_epsilons).
TEST(Gpu, TheDefaultFitMeasuresAsTheCpusWithinOnePercent) {
  REQUIRE_DEVICE(device);
  const DecodedPair r = fit_both(true);
  std::printf("RMSE %.4f on the device, %.4f on the CPU; decoded within %.3f level (RMS %.4f)\n",
              r.gpu_rmse, r.cpu_rmse, r.worst, r.difference_rms);
  EXPECT_LT(std::abs(r.gpu_rmse / r.cpu_rmse - 1.0), 0.01)
      << r.gpu_rmse << " against " << r.cpu_rmse;
  EXPECT_LE(r.worst, 0.1);
  EXPECT_LE(r.difference_rms, 0.02);
}

// M components from seed 3 after `iterations` EM iterations on the CPU.
ProductMixture em_on_the_cpu(const SampleSet& s, std::size_t m, int iterations) {
  ProductMixture mix = initial_mixture(s, m, 3);
  EmConfig em;
  em.max_iterations = iterations;
  fit_em(s, mix, em);
  return mix;
}

// The largest difference of each kind of derivative (a, mu, s) of `f` from `d`'s, against the
// largest of its kind in `d`.
std::array<double, 3> gradient_difference(const PredictionGradient& f,
                                          const PredictionGradient& d) {
  std::array<double, 3> top{0, 0, 0}, worst{0, 0, 0};
  for (std::size_t k = 0; k < d.log_weight.size(); ++k) {
    top[0] = std::max(top[0], std::abs(d.log_weight[k]));
    for (double g : d.mean[k]) top[1] = std::max(top[1], std::abs(g));
    for (double g : d.log_var[k]) top[2] = std::max(top[2], std::abs(g));
  }
  for (std::size_t k = 0; k < d.log_weight.size(); ++k) {
    worst[0] = std::max(worst[0], std::abs(f.log_weight[k] - d.log_weight[k]) / top[0]);
    for (std::size_t n = 0; n < d.mean[k].size(); ++n)
      worst[1] = std::max(worst[1], std::abs(f.mean[k][n] - d.mean[k][n]) / top[1]);
    for (std::size_t n = 0; n < d.log_var[k].size(); ++n)
      worst[2] = std::max(worst[2], std::abs(f.log_var[k][n] - d.log_var[k][n]) / top[2]);
  }
  return worst;
}

// The refinement's pass on the device (model/refine_gpu.hpp) beside the CPU's: against the
// double pass that weighs every component (prediction_gradient) over every sample and a
// stride, and against the CPU's float pass over a minibatch and the held-out samples; the
// error to 1e-5 relative, every derivative within 1e-4 of the largest of its kind. 70 views:
// more than the statistics' shader holds in shared memory at once (kSlotTile, 64).
TEST(Gpu, TheRefinementsPassGivesTheCpusErrorAndGradient) {
  REQUIRE_DEVICE(device);
  const SampleSet s = make_sample_set(test::generated_tile("knit", 6, 1, "spiral:13", "spiral:70"));
  const ProductMixture mix = em_on_the_cpu(s, 24, 4);
  const auto gpu = detail::make_prediction_pass(s, mix.size(), 2, device.get());
  const auto cpu = detail::make_prediction_pass(s, mix.size(), 2, nullptr);
  using Part = detail::Selection::Part;
  for (std::size_t stride : {std::size_t(1), std::size_t(7)}) {
    const PredictionGradient d = prediction_gradient(s, mix, 2, stride, PassPrecision::kDouble);
    const PredictionGradient g = (*gpu)(mix, {stride, 0, Part::kAll});
    EXPECT_EQ(g.samples, d.samples);
    EXPECT_LT(relative(g.error, d.error), 1e-5) << "stride " << stride;
    const std::array<double, 3> w = gradient_difference(g, d);
    for (double x : w) EXPECT_LT(x, 1e-4) << "stride " << stride;
    std::printf(
        "stride %zu: the device against the double pass: error %.1e, %.1e %.1e %.1e "
        "(a, mu, s)\n",
        stride, relative(g.error, d.error), w[0], w[1], w[2]);
  }
  for (const detail::Selection part :
       {detail::Selection{5, 2, Part::kTraining}, detail::Selection{1, 0, Part::kValidation}}) {
    const PredictionGradient c = (*cpu)(mix, part), g = (*gpu)(mix, part);
    EXPECT_EQ(g.samples, c.samples);
    EXPECT_GT(g.samples, 0u);
    EXPECT_LT(relative(g.error, c.error), 1e-5);
    for (double w : gradient_difference(g, c)) EXPECT_LT(w, 1e-4);
    const PredictionGradient e = (*gpu)(mix, part, false);
    EXPECT_EQ(e.error, g.error);
    EXPECT_TRUE(e.log_weight.empty());
  }
}

// The normal equations of the colour means' refit on the device (refine_normal.comp) beside
// the CPU's (colour_normal_equations): the same samples, G and b within 1e-5 of their largest
// entry, the energy to 1e-9 relative; more components than one 64 x 64 block of G, and more
// slots (36 pixels x 13 lights x 150 views) than lavapipe runs of a loop nest's inner loops.
TEST(Gpu, TheColourRefitsNormalEquationsAreTheCpus) {
  REQUIRE_DEVICE(device);
  const SampleSet s =
      make_sample_set(test::generated_tile("knit", 6, 1, "spiral:13", "spiral:150"));
  const ProductMixture mix = em_on_the_cpu(s, 70, 3);
  const auto gpu = detail::make_prediction_pass(s, mix.size(), 2, device.get());
  for (std::size_t stride : {std::size_t(1), std::size_t(3)}) {
    const ColourNormalEquations c = colour_normal_equations(s, mix, 2, stride, true);
    const ColourNormalEquations g = gpu->normal_equations(mix, stride, nullptr, {});
    ASSERT_EQ(g.components, c.components);
    EXPECT_EQ(g.samples, c.samples);
    double top_gram = 0, top_rhs = 0, worst_gram = 0, worst_rhs = 0;
    for (double x : c.gram) top_gram = std::max(top_gram, std::abs(x));
    for (double x : c.rhs) top_rhs = std::max(top_rhs, std::abs(x));
    for (std::size_t i = 0; i < c.gram.size(); ++i)
      worst_gram = std::max(worst_gram, std::abs(g.gram[i] - c.gram[i]) / top_gram);
    for (std::size_t i = 0; i < c.rhs.size(); ++i)
      worst_rhs = std::max(worst_rhs, std::abs(g.rhs[i] - c.rhs[i]) / top_rhs);
    EXPECT_LT(worst_gram, 1e-5) << "stride " << stride;
    EXPECT_LT(worst_rhs, 1e-5) << "stride " << stride;
    for (std::size_t ch = 0; ch < 3; ++ch) EXPECT_LT(relative(g.energy[ch], c.energy[ch]), 1e-9);
    std::printf("stride %zu: G within %.1e, b within %.1e of their largest\n", stride, worst_gram,
                worst_rhs);
  }
}

// lavapipe ends a loop nest after 65,535 iterations, silently: the colour refit's sums over
// 16 x 16 pixels x 81 x 81 directions (82,944 iterations of 16 samples) are refused there,
// naming the CPU, where a hardware GPU sums them.
TEST(Gpu, ASoftwareDeviceRefusesALoopItWouldCut) {
  REQUIRE_DEVICE(device);
  if (!device->info().software) GTEST_SKIP() << "a hardware GPU runs loops of any length";
  const SampleSet s =
      make_sample_set(test::generated_tile("knit", 16, 1, "spiral:81", "spiral:81"));
  const ProductMixture mix = initial_mixture(s, 8, 3);
  const auto gpu = detail::make_prediction_pass(s, mix.size(), 2, device.get());
  try {
    gpu->normal_equations(mix, 1, nullptr, {});
    FAIL() << "a loop lavapipe would cut was run";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("`device` cpu"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(gpu->normal_equations(mix, 40, nullptr, {}));
}

// The default fit on the device (EM and the refinement's steps there) twice: the same model,
// also where the second states the refinement's plan first (timed on the pass it then refines
// with).
TEST(Gpu, TheRefinementOnTheDeviceIsTheSameRunAfterRun) {
  REQUIRE_DEVICE(device);
  const Btf btf = test::generated_tile("corduroy", 8, 1, "spiral:13", "spiral:11");
  auto fit = [&](const FitObserver* watch) {
    FitConfig c = mixture_config(20, 4, 1, 2);
    c.refinement_epochs = 2;
    c.device = DeviceChoice::kGpu;
    return decode(fit_model(btf, c, {}, nullptr, {}, nullptr, watch), btf.lights(), btf.views(),
                  btf.width(), btf.height());
  };
  std::optional<RefinementEstimate> plan;
  FitObserver planned;
  planned.refinement_planned = [&](const RefinementEstimate& e) { plan = e; };
  const Btf a = fit(nullptr), b = fit(&planned);
  ASSERT_TRUE(plan);
  EXPECT_GT(plan->step_seconds, 0.0);
  EXPECT_TRUE(std::equal(a.data().begin(), a.data().end(), b.data().begin(), b.data().end()));
}

TEST(Gpu, TheSameDeviceGivesTheSameModelRunAfterRun) {
  REQUIRE_DEVICE(device);
  const EmRun a = fit_on(device, 3), b = fit_on(device, 3);
  EXPECT_EQ(a.result.log_likelihood, b.result.log_likelihood);
  EXPECT_EQ(a.mixture.mean, b.mixture.mean);
  EXPECT_EQ(a.mixture.var, b.mixture.var);
  EXPECT_EQ(a.mixture.weight, b.mixture.weight);
}

// ---- Decoding and eval on the device (model/predict_gpu.hpp) -------------------------------

// A small tile's model: EM alone, 20 components.
BtfModel small_model(const Btf& btf) {
  FitConfig c = mixture_config(20, 4, 1, 2);
  c.objective = FitObjective::kLikelihood;
  c.device = DeviceChoice::kCpu;
  return fit_model(btf, c);
}

double largest_difference(std::span<const float> a, std::span<const float> b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, double(std::abs(a[i] - b[i])));
  return worst;
}

// Queries anywhere: positions off the pixel centres, outside the tile and negative (the tile
// repeats), directions off the measured ones.
std::vector<Query> random_queries(std::size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-20.0, 30.0), theta(0.0, 85.0), phi(-180.0, 360.0);
  std::vector<Query> q(n);
  for (Query& x : q) x = {pos(rng), pos(rng), {theta(rng), phi(rng)}, {theta(rng), phi(rng)}};
  return q;
}

// eval's queries on the device beside predict()'s double sums: the float sums of Eq. (8)
// (lavapipe: within 1.6e-5 level).
TEST(Gpu, ItsPredictionsAreTheCpusWithinAThousandthOfALevel) {
  REQUIRE_DEVICE(device);
  const BtfModel model =
      small_model(test::generated_tile("corduroy", 8, 1, "spiral:13", "spiral:11"));
  const std::vector<Query> q = random_queries(500);
  std::vector<float> cpu(q.size() * 3), gpu(q.size() * 3);
  predict(model, q, cpu);
  predict(*device, model, q, gpu);
  const double worst = largest_difference(gpu, cpu);
  std::printf("500 queries: within %.2e level of the CPU's\n", worst);
  EXPECT_LE(worst, 1e-3);
  EXPECT_THROW(predict(*device, model, std::vector<Query>{{0, 0, {95, 0}, {0, 0}}}, gpu), Error);
}

// decode on the device beside decode() on the CPU with every component (tolerance 0): the
// tile repeated over an image of another size, directions measured and not, the queries in
// runs of 1,000 and in one run the same.
TEST(Gpu, ItsDecodingIsTheCpusEveryComponentWeighed) {
  REQUIRE_DEVICE(device);
  const Btf btf = test::generated_tile("corduroy", 8, 1, "spiral:13", "spiral:11");
  const BtfModel model = small_model(btf);
  const DirectionSet lights({btf.lights()[0], btf.lights()[5], {33.0, 71.0}});
  const DirectionSet views({btf.views()[2], {61.0, 200.0}});
  const Btf cpu = decode(model, lights, views, 11, 6, 0.0);
  const Btf gpu = decode(*device, model, lights, views, 11, 6, 1000);
  const double worst = largest_difference(gpu.data(), cpu.data());
  std::printf("6 images of 11 x 6: within %.2e level of the CPU's\n", worst);
  EXPECT_LE(worst, 1e-3);
  const Btf one_run = decode(*device, model, lights, views, 11, 6);
  EXPECT_TRUE(std::equal(gpu.data().begin(), gpu.data().end(), one_run.data().begin(),
                         one_run.data().end()));
}

// Only the mixture has kernels for a device; the others keep computing on the CPU.
TEST(Gpu, TheMixtureComputesOnTheDeviceItIsGiven) {
  REQUIRE_DEVICE(device);
  const Btf btf = test::generated_tile("corduroy", 8, 1, "spiral:13", "spiral:11");
  GaussianMixture gm(small_model(btf));
  const std::vector<Query> q = random_queries(40);
  std::vector<float> cpu(q.size() * 3), gpu(q.size() * 3);
  gm.predict(q, cpu);
  EXPECT_TRUE(gm.compute_on(device));
  gm.predict(q, gpu);
  EXPECT_NE(cpu, gpu);  // float sums, not predict()'s double ones
  EXPECT_LE(largest_difference(gpu, cpu), 1e-3);
  EXPECT_TRUE(gm.compute_on(nullptr));
  gm.predict(q, gpu);
  EXPECT_EQ(cpu, gpu);
  FitOptions s;
  s.components = 2;
  const auto pca = fit_and_record(find_method("pca-btf"), btf, s, {});
  EXPECT_FALSE(pca->compute_on(device));
  EXPECT_TRUE(pca->compute_on(nullptr));
}

}  // namespace
}  // namespace btfgmm
