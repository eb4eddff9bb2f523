// The neural BTF's network on a compute device (src/methods/neural_btf_gpu.cpp,
// shaders/neural_forward.comp) beside the CPU's: eval anywhere, decode at the tile's size and
// larger, within float rounding; in CI on lavapipe (a test that would skip for want of a
// device fails there).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/methods/neural_btf.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/synth/generate.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

// A neural BTF fitted to a generated 8 x 8 knit (L = 4, 2 x 16, two epochs).
std::unique_ptr<Representation> small_neural(const Btf& tile) {
  return fit_and_record(find_method("neural"), tile, test::small_neural_options(2), {});
}

Btf small_tile() {
  return test::generated_tile("knit", 8, 1, "rings:0/1,30/4,60/6", "rings:0/1,45/5");
}

double largest_difference(std::span<const float> a, std::span<const float> b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(double(a[i] - b[i])));
  return worst;
}

// Queries at whole and fractional positions, measured and unmeasured directions.
std::vector<Query> mixed_queries() {
  std::vector<Query> q;
  for (int i = 0; i < 300; ++i)
    q.push_back({.x = 0.37 * i - 5.0,
                 .y = 0.21 * i,
                 .light = {.theta_deg = double(i % 80), .phi_deg = 13.0 * i},
                 .view = {.theta_deg = double((7 * i) % 85), .phi_deg = 29.0 * i}});
  return q;
}

TEST(NeuralGpu, EvalIsTheCpusWithinFloatRounding) {
  REQUIRE_DEVICE(device);
  const auto model = small_neural(small_tile());
  const std::vector<Query> q = mixed_queries();
  std::vector<float> cpu(q.size() * 3), gpu(q.size() * 3);
  model->predict(q, cpu);
  ASSERT_TRUE(model->compute_on(device));
  model->predict(q, gpu);
  const double worst = largest_difference(gpu, cpu);
  std::printf("300 queries: within %.2e level of the CPU's\n", worst);
  EXPECT_LE(worst, 1e-3);
  // A query's answer is the same alone or among others, on the device too.
  std::vector<float> one(3);
  model->predict(std::span(q).subspan(17, 1), one);
  EXPECT_TRUE(std::equal(one.begin(), one.end(), gpu.begin() + 17 * 3));
  ASSERT_TRUE(model->compute_on(nullptr));
  std::vector<float> again(q.size() * 3);
  model->predict(q, again);
  EXPECT_EQ(again, cpu);
}

TEST(NeuralGpu, DecodeIsTheCpusAtTheTileAndLarger) {
  REQUIRE_DEVICE(device);
  const Btf tile = small_tile();
  const auto model = small_neural(tile);
  const DirectionSet lights({tile.lights()[0], tile.lights()[5], {33.0, 71.0}});
  const DirectionSet views({tile.views()[2], {61.0, 200.0}});
  for (const auto& [w, h] : {std::pair{8, 8}, std::pair{13, 6}}) {
    const Btf cpu = model->decode(lights, views, w, h, 0.0);
    model->compute_on(device);
    const Btf gpu = model->decode(lights, views, w, h, 0.0);
    model->compute_on(nullptr);
    const double worst = largest_difference(gpu.data(), cpu.data());
    std::printf("6 images of %d x %d: within %.2e level of the CPU's\n", w, h, worst);
    EXPECT_LE(worst, 1e-3);
    EXPECT_EQ(gpu.origin(), cpu.origin());
  }
}

// A network whose loops lavapipe would cut (65,535 iterations a workgroup's loop nest) is
// refused there, naming the CPU, not computed wrong.
TEST(NeuralGpu, ANetworkPastASoftwareDevicesLoopsIsRefused) {
  REQUIRE_DEVICE(device);
  if (!device->info().software) GTEST_SKIP() << "a hardware GPU runs loops of any length";
  const Btf tile = small_tile();
  FitOptions s;
  s.method = "neural";
  s.components = 2;
  s.width = 256;
  s.depth = 2;
  s.iterations = 1;
  const auto wide = fit_and_record(find_method("neural"), tile, s, {});
  wide->compute_on(device);
  std::vector<float> rgb(3);
  const std::vector<Query> q = mixed_queries();
  EXPECT_NE(test::error_of([&] { wide->predict(std::span(q).first(1), rgb); }).find("--device cpu"),
            std::string::npos);
}

}  // namespace
}  // namespace btfgmm
