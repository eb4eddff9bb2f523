// The GPU back end (docs/GPU.md) on whatever Vulkan device this machine has: in CI, Mesa's
// lavapipe (Vulkan on the CPU), which runs every shader as a GPU would. Where no Vulkan device
// exists the tests skip, except in CI (CI=true), where they fail: the kernels must run there.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/model/decode.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/samples.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

bool in_ci() {
  const char* ci = std::getenv("CI");
  return ci && std::string(ci) == "true";
}

// The device `device gpu` opens (a hardware GPU, else lavapipe); null after a skip, or a
// failure in CI.
std::shared_ptr<ComputeDevice> test_device() {
  try {
    return open_compute_device(DeviceChoice::kGpu);
  } catch (const Error& e) {
    if (in_ci()) ADD_FAILURE() << "CI runs the GPU kernels on lavapipe: " << e.what();
    return nullptr;
  }
}

#define REQUIRE_DEVICE(name)                                                \
  const std::shared_ptr<ComputeDevice> name = test_device();                \
  if (!name) {                                                              \
    if (!in_ci()) GTEST_SKIP() << "no Vulkan device (mesa-vulkan-drivers)"; \
    return;                                                                 \
  }

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
  double worst = 0.0, cpu_rmse = 0.0, gpu_rmse = 0.0;
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
    r.cpu_rmse += std::pow(double(cpu.data()[i] - btf.data()[i]), 2) / n;
    r.gpu_rmse += std::pow(double(gpu.data()[i] - btf.data()[i]), 2) / n;
  }
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

// The default fit: the refinement's Adam steps start from EM's parameters a rounding apart and
// carry the difference on (0.22 level at most on this tile); the error on the data is the
// CPU's to 1 %.
TEST(Gpu, TheDefaultFitMeasuresAsTheCpusWithinOnePercent) {
  REQUIRE_DEVICE(device);
  const DecodedPair r = fit_both(true);
  EXPECT_LT(std::abs(r.gpu_rmse / r.cpu_rmse - 1.0), 0.01)
      << r.gpu_rmse << " against " << r.cpu_rmse;
  EXPECT_LE(r.worst, 0.5);
}

TEST(Gpu, TheSameDeviceGivesTheSameModelRunAfterRun) {
  REQUIRE_DEVICE(device);
  const EmRun a = fit_on(device, 3), b = fit_on(device, 3);
  EXPECT_EQ(a.result.log_likelihood, b.result.log_likelihood);
  EXPECT_EQ(a.mixture.mean, b.mixture.mean);
  EXPECT_EQ(a.mixture.var, b.mixture.var);
  EXPECT_EQ(a.mixture.weight, b.mixture.weight);
}

}  // namespace
}  // namespace btfgmm
