// bench_kernels: Google Benchmark timings of the kernels behind fit, decode and render, each
// reported per unit of work (items = sample x component pairs, predictions x components,
// exp calls), so that the figures compare with bench_fit's ns per pair.
//
//   bench_kernels [--benchmark_filter=REGEX] [--benchmark_repetitions=N] ...
//
// Data: a generated corduroy BTF (81 x 81 directions), an 8 x 8 tile (419,904 samples),
// M = 600 from the same seeded start as bench_fit.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"
#include "btfgmm/render/render.hpp"
#include "core/fast_exp.hpp"

namespace {

constexpr int kTile = 8;
constexpr std::size_t kComponents = 600;

const btfgmm::SampleSet& samples() {
  static const btfgmm::SampleSet s = [] {
    btfgmm::GenerateConfig g;
    g.material = "corduroy";
    g.size = kTile;
    g.seed = 1;
    return btfgmm::make_sample_set(btfgmm::generate(g));
  }();
  return s;
}

// The mixture after `iterations` EM iterations from bench_fit's start.
btfgmm::ProductMixture fitted(int iterations) {
  btfgmm::ProductMixture mix = btfgmm::initial_mixture(samples(), kComponents, 7);
  if (iterations > 0) {
    btfgmm::EmConfig c;
    c.max_iterations = iterations;
    c.final_log_likelihood = false;
    btfgmm::fit_em(samples(), mix, c);
  }
  return mix;
}

const btfgmm::BtfModel& model() {
  static const btfgmm::BtfModel m = [] {
    btfgmm::BtfModel b;
    b.lights = b.views = btfgmm::DirectionSet::ubo81();
    b.width = b.height = kTile;
    b.scaling = samples().scaling;
    b.mean_brdf = samples().mean_brdf;
    b.mixture = fitted(10);
    return b;
  }();
  return m;
}

// The vectorisable exp of the float kernels, over values in [-30, 0].
void BM_FastExp(benchmark::State& state) {
  std::vector<float> x(4096), y(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = -30.0f * float(i) / float(x.size());
  for (auto _ : state) {
#pragma omp simd
    for (std::size_t i = 0; i < x.size(); ++i) y[i] = btfgmm::detail::fast_exp(x[i]);
    benchmark::DoNotOptimize(y.data());
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(x.size()));
}
BENCHMARK(BM_FastExp);

// One E pass (log-likelihood only) of the mixture after range(0) iterations: the skip makes
// later iterations cheaper. Items: sample x component pairs.
void BM_EPass(benchmark::State& state) {
  const btfgmm::ProductMixture mix = fitted(int(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(btfgmm::mean_log_likelihood(samples(), mix));
  state.SetItemsProcessed(std::int64_t(state.iterations()) *
                          std::int64_t(samples().size() * mix.size()));
}
BENCHMARK(BM_EPass)->Arg(0)->Arg(10)->Unit(benchmark::kMillisecond)->UseRealTime();

// One EM iteration (E pass with statistics, M-step) from the mixture after range(0)
// iterations. Items: sample x component pairs.
void BM_EmIteration(benchmark::State& state) {
  const btfgmm::ProductMixture start = fitted(int(state.range(0)));
  btfgmm::EmConfig c;
  c.max_iterations = 1;
  c.final_log_likelihood = false;
  for (auto _ : state) {
    btfgmm::ProductMixture mix = start;
    btfgmm::fit_em(samples(), mix, c);
    benchmark::DoNotOptimize(mix.weight.data());
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) *
                          std::int64_t(samples().size() * start.size()));
}
BENCHMARK(BM_EmIteration)->Arg(0)->Arg(10)->Unit(benchmark::kMillisecond)->UseRealTime();

// One gradient pass of the fit for the prediction (prediction_gradient) over every 10th
// sample (about 42,000, as the Adam steps take about 40,000), in float (range(0) 0, what the
// steps use) or in double (1), of the mixture after 10 EM iterations. Items: sample x component
// pairs, to compare with an EM iteration's.
void BM_GradientPass(benchmark::State& state) {
  const btfgmm::ProductMixture mix = fitted(10);
  const auto precision =
      state.range(0) == 0 ? btfgmm::PassPrecision::kFloat : btfgmm::PassPrecision::kDouble;
  std::size_t pairs = 0;
  for (auto _ : state) {
    const btfgmm::PredictionGradient g =
        btfgmm::prediction_gradient(samples(), mix, 0, 10, precision);
    benchmark::DoNotOptimize(g.error);
    pairs += g.samples * mix.size();
  }
  state.SetItemsProcessed(std::int64_t(pairs));
}
BENCHMARK(BM_GradientPass)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// decode() of the whole tile at the tolerance range(0) / 1000 levels. Items: predictions x
// components.
void BM_Decode(benchmark::State& state) {
  const btfgmm::BtfModel& m = model();
  const double tolerance = double(state.range(0)) / 1000.0;
  for (auto _ : state) {
    const btfgmm::Btf d = btfgmm::decode(m, m.lights, m.views, kTile, kTile, tolerance);
    benchmark::DoNotOptimize(d.data().data());
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) *
                          std::int64_t(samples().size() * m.mixture.size()));
}
BENCHMARK(BM_Decode)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// The renderer's model kernel on 256 x 256 points of a plane seen from above, the tile
// repeated 4 times across (blocks of 16 x 16 screen pixels), tolerance 0.1 levels. Items:
// points x components.
void BM_RenderKernel(benchmark::State& state) {
  const btfgmm::ModelEvaluator evaluator(model(), 0.1);
  std::vector<btfgmm::SurfacePoint> points;
  std::vector<std::uint32_t> groups;
  for (int by = 0; by < 16; ++by)
    for (int bx = 0; bx < 16; ++bx) {
      groups.push_back(std::uint32_t(points.size()));
      for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
          btfgmm::SurfacePoint p;
          p.x = float(bx * 16 + x) * 0.125f;
          p.y = float(by * 16 + y) * 0.125f;
          p.light = {0.5f, 0.0f, std::sqrt(0.75f)};
          p.view = {0.0f, 0.0f, 1.0f};
          points.push_back(p);
        }
    }
  groups.push_back(std::uint32_t(points.size()));
  std::vector<float> rgb(points.size() * 3);
  for (auto _ : state) {
    evaluator.evaluate(points, rgb, groups);
    benchmark::DoNotOptimize(rgb.data());
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) *
                          std::int64_t(points.size() * evaluator.components()));
}
BENCHMARK(BM_RenderKernel)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
