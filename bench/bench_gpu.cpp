// bench_gpu: EM on the CPU beside EM on the GPU (docs/GPU.md), the same samples from the same
// starting parameters, one after the other in this process: for each, the time of an
// iteration (the mean of iterations 2..K), the E pass alone, ns per sample x component of an
// iteration, and the mean log-likelihood at every iteration with the largest relative
// difference between the two (the GPU sums in another order: at most 1e-5 is the same fit);
// then the refinement for the prediction's passes from EM's final mixture, both ways, and the
// decoding of the tile's every image from it.
//
//   bench_gpu [--size S] [--tile T] [--components M] [--iterations K] [--threads N]
//             [--device gpu|auto] [--no-cpu]
//
// --no-cpu: the GPU's run alone (its times, no comparison).
//
// Samples: a generated corduroy BTF (S x S pixels, 81 x 81 directions), its T x T tile.
// Exits 1 where the two log-likelihoods differ by more than 1e-5 relative, 2 on bad options,
// 3 where no device is found.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "bench_clock.hpp"
#include "bench_samples.hpp"
#include "btfgmm/btfgmm.hpp"
#include "model/em_gpu.hpp"
#include "model/em_tables.hpp"
#include "model/refine_internal.hpp"

namespace {

struct Options {
  int size = 64, tile = 64, iterations = 5, threads = 0;
  std::size_t components = 600;
  std::string device = "gpu";
  bool cpu = true;  // --no-cpu: the GPU's run alone
};

struct Run {
  btfgmm::ProductMixture mixture;
  btfgmm::EmResult result;
  double per_iteration = 0.0, e_pass = 0.0, seconds = 0.0;
};

btfgmm::SampleSet samples(const Options& o) {
  return bench::corduroy_samples(o.size, o.tile);
}

Run run_em(const Options& o, const btfgmm::SampleSet& s,
           const std::shared_ptr<btfgmm::ComputeDevice>& device) {
  btfgmm::ProductMixture mix = btfgmm::initial_mixture(s, o.components, 7);
  btfgmm::EmConfig c;
  c.max_iterations = o.iterations;
  c.threads = o.threads;
  c.device = device;
  const double t0 = bench::now();
  Run r;
  r.result = btfgmm::fit_em(s, mix, c);
  r.seconds = bench::now() - t0;
  const auto& t = r.result.seconds;
  r.per_iteration = t.size() > 1 ? (t.back() - t.front()) / double(t.size() - 1) : t.front();
  r.e_pass = r.result.stages.e_pass / double(std::max(1, r.result.iterations));
  r.mixture = std::move(mix);
  return r;
}

// One E pass on the device from EM's final mixture (components as narrow as EM leaves
// them), `runs` times: where its time goes (em_gpu.hpp, GpuEPass::Seconds), per pass.
void print_stages(const Options& o, const btfgmm::SampleSet& s, const btfgmm::ProductMixture& mix,
                  btfgmm::ComputeDevice& device, double n) {
  namespace d = btfgmm::detail;
  const d::Periods periods = d::tile_periods(s, true);
  const int runs = 3;
  double tables = 0.0;
  d::GpuEPass pass(device, s);
  for (int r = 0; r < runs; ++r) {
    const double t0 = bench::now();
    const d::Tables t = d::make_tables(s, mix, periods, o.threads);
    tables += bench::now() - t0;
    pass.run(t, mix, periods, true);
  }
  const d::GpuEPass::Seconds& g = pass.seconds();
  const double kernels = (g.normaliser + g.statistics) / runs;
  // About 15 operations a sample x component in the normaliser and 35 in the statistics,
  // besides an exp in each (the shaders' loops).
  const double flops = 50.0 * n * double(mix.size());
  std::printf(
      "\nthe GPU's E pass from EM's final mixture (M = %zu), per pass (mean of %d): "
      "tables (CPU) %.4f s, upload %.4f s, normaliser %.4f s, statistics and light sums "
      "%.4f s, downloads and assembly %.4f s; the kernels %.3f ns per sample x component, "
      "about %.0f Gflop/s (50 flops a sample x component)\n",
      mix.size(), runs, tables / runs, g.upload / runs, g.normaliser / runs, g.statistics / runs,
      g.host / runs, kernels / (n * double(mix.size())) * 1e9, flops / kernels * 1e-9);
}

// Seconds a call of `f` takes, the mean of `runs` after one unclocked.
template <class F>
double mean_seconds(int runs, F&& f) {
  f();
  const double t0 = bench::now();
  for (int r = 0; r < runs; ++r) f();
  return (bench::now() - t0) / runs;
}

// The refinement for the prediction's passes from `mix` on the CPU and on the device, side by
// side (docs/GPU.md): a minibatch's gradient (16,384 samples, as the Adam steps take them), a
// validation (the error over the held-out samples) and the colour refit's normal equations
// (its subsample), each the mean of five; the two errors' relative difference (for the normal
// equations, the error they give the mixture, prediction_squared_error).
void print_refinement(const Options& o, const btfgmm::SampleSet& s,
                      const btfgmm::ProductMixture& mix, btfgmm::ComputeDevice& device) {
  namespace d = btfgmm::detail;
  using Part = d::Selection::Part;
  const auto cpu = d::make_prediction_pass(s, mix.size(), o.threads, nullptr);
  const auto gpu = d::make_prediction_pass(s, mix.size(), o.threads, &device);
  const std::size_t batches = std::max<std::size_t>(1, s.size() / 16384);
  const d::Selection batch{batches, 0, Part::kTraining}, held{1, 0, Part::kValidation};
  const std::size_t stride = d::subsample_stride(s.size(), btfgmm::kColourRefitSamples);
  std::printf(
      "\nthe refinement's passes from EM's final mixture (M = %zu), mean of 5:\n"
      "| pass | CPU s | GPU s | CPU s / GPU s | error, relative difference "
      "|\n|---|---|---|---|---|\n",
      mix.size());
  const auto row = [&](const char* name, auto&& on) {
    double e_cpu = 0.0, e_gpu = 0.0;
    const double t_cpu = mean_seconds(5, [&] { e_cpu = on(*cpu); });
    const double t_gpu = mean_seconds(5, [&] { e_gpu = on(*gpu); });
    std::printf("| %s | %.5f | %.5f | %.2f | %.1e |\n", name, t_cpu, t_gpu, t_cpu / t_gpu,
                std::abs(e_gpu - e_cpu) / std::max(std::abs(e_cpu), 1e-300));
    std::fflush(stdout);
  };
  row("a minibatch's gradient", [&](d::PredictionPass& p) { return p(mix, batch).error; });
  row("a validation", [&](d::PredictionPass& p) { return p(mix, held, false).error; });
  row("the colour refit's normal equations", [&](d::PredictionPass& p) {
    return btfgmm::prediction_squared_error(p.normal_equations(mix, stride, nullptr, {}), mix);
  });
}

// Decoding the tile's every image (81 x 81) from `mix` on the CPU (decode's default tolerance,
// and every component) and on the device (every component), each once; the largest difference
// of a decoded value from the CPU's with every component, levels.
void print_decoding(const Options& o, const btfgmm::SampleSet& s, btfgmm::ProductMixture mix,
                    btfgmm::ComputeDevice& device) {
  const btfgmm::Btf full = bench::corduroy_btf(o.size);
  btfgmm::BtfModel model;
  model.lights = full.lights();
  model.views = full.views();
  model.width = model.height = o.tile;
  model.scaling = s.scaling;
  model.mean_brdf = s.mean_brdf;
  model.mixture = std::move(mix);
  const auto timed = [&](auto&& decode) {
    const double t0 = bench::now();
    btfgmm::Btf b = decode();
    return std::pair{bench::now() - t0, std::move(b)};
  };
  const auto& l = model.lights;
  const auto& v = model.views;
  const auto [t_default, skipped] = timed([&] { return decode(model, l, v, o.tile, o.tile); });
  const auto [t_every, every] = timed([&] { return decode(model, l, v, o.tile, o.tile, 0.0); });
  const auto [t_gpu, gpu] = timed([&] { return decode(device, model, l, v, o.tile, o.tile); });
  double worst = 0.0;
  for (std::size_t i = 0; i < every.data().size(); ++i)
    worst = std::max(worst, double(std::abs(gpu.data()[i] - every.data()[i])));
  const double queries = double(l.size() * v.size()) * o.tile * o.tile;
  std::printf(
      "\ndecoding the tile's %zu images from EM's final mixture (M = %zu), once each:\n"
      "| decode | s | ns / (pixel x component) | CPU s / this s |\n|---|---|---|---|\n"
      "| CPU, tolerance 1e-3 (the default) | %.3f | %.3f | 1.00 |\n"
      "| CPU, every component | %.3f | %.3f | %.2f |\n"
      "| GPU, every component | %.3f | %.3f | %.2f |\n"
      "the GPU's values within %.1e level of the CPU's with every component\n",
      l.size() * v.size(), model.mixture.size(), t_default,
      t_default / (queries * double(model.mixture.size())) * 1e9, t_every,
      t_every / (queries * double(model.mixture.size())) * 1e9, t_default / t_every, t_gpu,
      t_gpu / (queries * double(model.mixture.size())) * 1e9, t_default / t_gpu, worst);
  std::fflush(stdout);
}

void print_row(const char* name, const Run& r, double n, std::size_t m) {
  std::printf("| %s | %.4f | %.4f | %.3f | %.3f | %.10f |\n", name, r.per_iteration, r.e_pass,
              r.per_iteration / (n * double(m)) * 1e9, r.seconds, r.result.final_log_likelihood);
  std::fflush(stdout);
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--no-cpu") {
      o.cpu = false;
      --i;
      continue;
    }
    if (i + 1 == argc) return false;
    const std::string v = argv[i + 1];
    if (a == "--size")
      o.size = std::atoi(v.c_str());
    else if (a == "--tile")
      o.tile = std::atoi(v.c_str());
    else if (a == "--components")
      o.components = std::size_t(std::atol(v.c_str()));
    else if (a == "--iterations")
      o.iterations = std::atoi(v.c_str());
    else if (a == "--threads")
      o.threads = std::atoi(v.c_str());
    else if (a == "--device")
      o.device = v;
    else
      return false;
  }
  return o.tile > 0 && o.iterations > 0 && o.components > 0 &&
         btfgmm::parse_device_choice(o.device).has_value();
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) {
    std::fprintf(stderr,
                 "usage: bench_gpu [--size S] [--tile T] [--components M] [--iterations K] "
                 "[--threads N] [--device gpu|auto] [--no-cpu]\n");
    return 2;
  }
  o.size = std::max(o.size, o.tile);
  std::shared_ptr<btfgmm::ComputeDevice> device;
  try {
    device = btfgmm::open_compute_device(*btfgmm::parse_device_choice(o.device));
  } catch (const btfgmm::Error& e) {
    std::fprintf(stderr, "bench_gpu: %s\n", e.what());
    return 3;
  }
  if (!device) {
    std::fprintf(stderr, "bench_gpu: no GPU (device %s)\n", o.device.c_str());
    return 3;
  }
  const btfgmm::SampleSet s = samples(o);
  const double n = double(s.size());
  const int threads = o.threads > 0 ? o.threads : omp_get_max_threads();
  std::printf(
      "EM: %d x %d tile of a generated corduroy BTF, 81 x 81 directions, N = %.0f "
      "samples, M = %zu, %d iterations, the same start\nCPU: %d threads; GPU: %s\n\n",
      o.tile, o.tile, n, o.components, o.iterations, threads, device->info().description().c_str());
  std::printf(
      "| device | s / iteration | E pass s / iteration | ns / (sample x component) | "
      "s in all | final mean log-likelihood |\n|---|---|---|---|---|---|\n");
  const Run gpu = run_em(o, s, device);
  if (!o.cpu) {
    print_row("GPU", gpu, n, o.components);
    print_stages(o, s, gpu.mixture, *device, n);
    print_refinement(o, s, gpu.mixture, *device);
    print_decoding(o, s, gpu.mixture, *device);
    return 0;
  }
  const Run cpu = run_em(o, s, nullptr);
  print_row("CPU", cpu, n, o.components);
  print_row("GPU", gpu, n, o.components);
  double worst = 0.0;
  const auto& a = cpu.result.log_likelihood;
  const auto& b = gpu.result.log_likelihood;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    worst = std::max(worst, std::abs(b[i] - a[i]) / std::abs(a[i]));
  std::printf(
      "\nGPU / CPU: an iteration %.1fx faster, the E pass %.1fx; the log-likelihood at "
      "every iteration within %.2e (relative)\n",
      cpu.per_iteration / gpu.per_iteration, cpu.e_pass / gpu.e_pass, worst);
  print_stages(o, s, cpu.mixture, *device, n);
  print_refinement(o, s, cpu.mixture, *device);
  print_decoding(o, s, cpu.mixture, *device);
  if (worst > 1e-5 || a.size() != b.size()) {
    std::printf("the GPU's log-likelihood differs from the CPU's\n");
    return 1;
  }
  return 0;
}
