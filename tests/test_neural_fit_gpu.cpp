// The neural BTF's fit on a compute device (src/methods/neural_network_gpu.cpp, shaders/
// neural_gradient.comp and neural_weight_gradient.comp) beside the CPU's: the squared error and
// its gradient within float rounding of squared_error_gradient(), the same numbers at every run
// on one device, a fit that decodes as the CPU's fit does; in CI on lavapipe.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/methods/neural_btf.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/provenance.hpp"
#include "core/random.hpp"
#include "methods/neural_network.hpp"
#include "methods/neural_network_gpu.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

using detail::NetworkShape;

std::vector<float> uniform_floats(std::size_t n, std::uint64_t seed, double lo, double hi) {
  detail::SplitMix64 draw(seed);
  std::vector<float> v(n);
  for (float& x : v) x = float(draw.uniform(lo, hi));
  return v;
}

// The largest |a - b| over the largest |b|: 0 where they agree.
double relative_difference(std::span<const float> a, std::span<const float> b) {
  double worst = 0.0, largest = 1e-30;
  for (std::size_t i = 0; i < a.size(); ++i) {
    worst = std::max(worst, std::abs(double(a[i]) - double(b[i])));
    largest = std::max(largest, std::abs(double(b[i])));
  }
  return worst / largest;
}

struct Batch {
  std::vector<float> theta, inputs, targets;
};

Batch random_batch(const NetworkShape& shape, std::size_t samples, std::uint64_t seed) {
  return {.theta = detail::initial_parameters(shape, seed),
          .inputs = uniform_floats(samples * detail::input_size(shape), seed + 1, -1.0, 1.0),
          .targets = uniform_floats(samples * detail::kNetworkOutputs, seed + 2, 0.0, 2.0)};
}

TEST(NeuralFitGpu, GradientIsTheCpusWithinFloatRounding) {
  REQUIRE_DEVICE(device);
  // Shapes of one to three hidden layers, batches below, at and past a run of 64 samples.
  for (const auto& [shape, samples] : {std::pair{NetworkShape{3, 7, 1}, std::size_t(5)},
                                       std::pair{NetworkShape{4, 16, 2}, std::size_t(300)},
                                       std::pair{NetworkShape{2, 9, 3}, std::size_t(64)}}) {
    const Batch b = random_batch(shape, samples, 11 + samples);
    const detail::SquaredErrorGradient cpu =
        detail::squared_error_gradient(shape, b.theta, b.inputs, b.targets, 1);
    detail::NetworkGradientPass pass(*device, shape, 512);
    pass.set_parameters(b.theta);
    const detail::SquaredErrorGradient gpu = pass.gradient(b.inputs, b.targets);
    const double parameters = relative_difference(gpu.parameters, cpu.parameters);
    const double latents = relative_difference(gpu.latents, cpu.latents);
    std::printf(
        "L %zu, %zu x %zu, %zu samples: E %.6g (CPU %.6g), dE/dtheta within %.1e, "
        "dE/dz within %.1e of the largest\n",
        shape.latent, shape.depth, shape.width, samples, gpu.error, cpu.error, parameters, latents);
    EXPECT_NEAR(gpu.error, cpu.error, 1e-5 * cpu.error);
    EXPECT_LE(parameters, 1e-5);
    EXPECT_LE(latents, 1e-5);
    ASSERT_EQ(gpu.latents.size(), cpu.latents.size());
    EXPECT_NEAR(pass.squared_error(b.inputs, b.targets), cpu.error, 1e-5 * cpu.error);
    // The same numbers bit for bit at the next run.
    const detail::SquaredErrorGradient again = pass.gradient(b.inputs, b.targets);
    EXPECT_EQ(again.parameters, gpu.parameters);
    EXPECT_EQ(again.latents, gpu.latents);
    EXPECT_EQ(again.error, gpu.error);
  }
}

FitOptions small_fit(const std::string& device) {
  FitOptions s = test::small_neural_options(3);
  s.device = device;
  return s;
}

// The whole fit on the device: Adam's steps and the validation there, the file the same at every
// run, its decode the CPU fit's to well under a level, its provenance naming the device.
TEST(NeuralFitGpu, FitDecodesAsTheCpusAndRepeatsItself) {
  REQUIRE_DEVICE(device);
  const Btf tile = test::generated_tile("knit", 8, 1, "rings:0/1,30/4,60/6", "rings:0/1,45/5");
  const MethodInfo& neural = find_method("neural");
  const auto cpu = fit_and_record(neural, tile, small_fit("cpu"), {});
  const auto gpu = fit_and_record(neural, tile, small_fit("gpu"), {});
  const auto again = fit_and_record(neural, tile, small_fit("gpu"), {});
  EXPECT_EQ(gpu->payload(), again->payload());
  const Btf a = cpu->decode(tile.lights(), tile.views(), 8, 8, 0.0);
  const Btf g = gpu->decode(tile.lights(), tile.views(), 8, 8, 0.0);
  double worst = 0.0, squares = 0.0;
  for (std::size_t i = 0; i < a.data().size(); ++i) {
    const double d = double(a.data()[i]) - double(g.data()[i]);
    worst = std::max(worst, std::abs(d));
    squares += d * d;
  }
  const double rms = std::sqrt(squares / double(a.data().size()));
  std::printf("the device's fit decodes within %.2e level of the CPU's (RMS %.2e; the files %s)\n",
              worst, rms, gpu->payload() == cpu->payload() ? "the same" : "differ");
  EXPECT_LE(rms, 0.05);
  EXPECT_LE(worst, 1.0);
  const auto& settings = gpu->provenance().fit.settings;
  const auto named = std::find_if(settings.begin(), settings.end(),
                                  [](const auto& s) { return s.first == kDeviceSetting; });
  ASSERT_NE(named, settings.end());
  EXPECT_EQ(named->second, device->info().description());
  for (const auto& [name, value] : cpu->provenance().fit.settings) EXPECT_NE(name, kDeviceSetting);
}

// A network whose gradient loops lavapipe would cut is refused there, naming the CPU.
TEST(NeuralFitGpu, AGradientPastASoftwareDevicesLoopsIsRefused) {
  REQUIRE_DEVICE(device);
  if (!device->info().software) GTEST_SKIP() << "a hardware GPU runs loops of any length";
  const std::string message = test::error_of([&] {
    detail::NetworkGradientPass(*device, NetworkShape{8, 256, 2}, 4096);
  });
  EXPECT_NE(message.find("--device cpu"), std::string::npos) << message;
}

}  // namespace
}  // namespace btfgmm
