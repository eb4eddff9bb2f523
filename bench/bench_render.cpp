// bench_render: the time to render a frame of the model (the paper: 800 x 800 at M = 600 in
// 30 s on a CPU), and the component evaluations per second, for a sphere (part of the frame
// covered) and a plane that fills the whole frame (every pixel evaluated: 800 x 800 x 600 =
// 384 million component evaluations). Each figure is the best of --runs runs.
//
//   bench_render [--model FILE] [--size N] [--components M] [--threads T] [--runs R]
//                [--tolerance LEVELS] [--no-full]
//   bench_render --stages OUT.png --model FILE [--size N] [--threads T]
//
// --stages times, once and in a fresh process, each stage of what `btfgmm render FILE -o
// OUT.png` does (the command's defaults: a sphere, light 45,30, camera 60,0): loading the
// model, building the mesh, the geometry pass, the evaluator's set-up, the model, composing,
// writing the PNG; with the time from the process's start to main() (the loader) before them.
// The first run of each stage is what a whole process pays (thread pool, page faults).
//
// Without --model, a model is fitted first (printed with its fit time): a generated 32 x 32
// corduroy, a 16 x 16 tile, 47 x 47 directions (rings of 0, 20, 40, 60, 80 degrees), M
// components, 4 EM iterations. A model fitted on the full 81 x 81 directions has narrower
// components in angle and skips more of them: pass it with --model.
//
// "nominal" evaluations are lit pixels x M (what evaluating every component at every pixel
// costs, the paper's count); "evaluated" are those done after skipping the components whose
// bound proves them negligible (--tolerance, levels; 0 evaluates all of them).
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "bench_clock.hpp"
#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/render/render.hpp"

namespace {

using bench::cpu_now;
using bench::now;

struct Options {
  std::string model;
  int size = 800, threads = 0, runs = 5;
  std::size_t components = 600;
  double tolerance = 0.1;
  bool full = true;    // also with tolerance 0 (every component)
  std::string stages;  // --stages: the PNG to write
};

// Seconds since the process started (its start time from /proc/self/stat, in clock ticks
// after boot, against the boot time), or -1 where that is not known.
double since_process_start() {
  std::FILE* f = std::fopen("/proc/self/stat", "r");
  if (!f) return -1;
  char buf[1024] = {};
  const std::size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  const char* p = std::strrchr(buf, ')');
  if (n == 0 || !p) return -1;
  unsigned long long start = 0;
  int field = 2;  // after ')' comes field 3
  for (const char* q = p + 1; *q && field < 22; ++q)
    if (*q == ' ' && ++field == 22) start = std::strtoull(q + 1, nullptr, 10);
  timespec up{};
  clock_gettime(CLOCK_BOOTTIME, &up);
  return double(up.tv_sec) + 1e-9 * double(up.tv_nsec) -
         double(start) / double(sysconf(_SC_CLK_TCK));
}

// What `btfgmm render MODEL -o OUT.png` does, stage by stage, each once (cold).
void process_stages(const Options& o) {
  const double startup = since_process_start();
  const double c0 = cpu_now();
  double t = now();
  std::vector<std::pair<const char*, double>> st;
  auto lap = [&](const char* name) {
    const double u = now();
    st.emplace_back(name, u - t);
    t = u;
  };
  const std::shared_ptr<const btfgmm::Representation> model = btfgmm::load_representation(o.model);
  lap("load model");
  const btfgmm::Scene defaults = btfgmm::build_scene({});  // the render command's scene
  lap("mesh and camera");
  btfgmm::RenderSettings s;
  s.width = s.height = o.size;
  const btfgmm::ModelFrame& frame = model->frame();
  const btfgmm::SurfaceBuffer sb = btfgmm::rasterize(defaults.mesh, defaults.camera, defaults.light,
                                                     s, frame.width, frame.height);
  lap("geometry");
  const btfgmm::RepresentationEvaluator ev(model, s.tolerance);
  lap("evaluator set-up");
  std::vector<float> rgb(sb.points.size() * 3);
  ev.evaluate(sb.points, rgb, sb.block_start);
  lap("model");
  const btfgmm::Rendering img = btfgmm::compose(sb, rgb, s, frame.format);
  lap("compose");
  btfgmm::write_picture(o.stages, img.width, img.height, img.rgb);
  lap("write PNG");
  double total = 0;
  std::printf("%dx%d, %zu lit pixels, %d threads\n", o.size, o.size, sb.points.size(),
              omp_get_max_threads());
  std::printf("  %-18s %.4f s\n", "start-up to main", startup);
  for (const auto& [name, sec] : st) {
    std::printf("  %-18s %.4f s\n", name, sec);
    total += sec;
  }
  std::printf("  %-18s %.4f s (CPU %.4f s)\n", "main's stages", total, cpu_now() - c0);
}

btfgmm::BtfModel fitted_model(const Options& o) {
  btfgmm::GenerateConfig g;
  g.material = "corduroy";
  g.size = 32;
  g.lights = g.views = btfgmm::DirectionSet::parse("rings:0/1,20/6,40/10,60/14,80/16");
  const btfgmm::Btf full = btfgmm::generate(g);
  btfgmm::Btf tile(full.lights(), full.views(), 16, 16, full.format());
  for (std::size_t l = 0; l < full.lights().size(); ++l)
    for (std::size_t v = 0; v < full.views().size(); ++v)
      for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x)
          for (int c = 0; c < 3; ++c) tile.at(l, v, x, y, c) = full.at(l, v, x, y, c);
  btfgmm::FitConfig c;
  c.components = o.components;
  c.em.max_iterations = 4;
  const double t0 = now();
  btfgmm::BtfModel m = btfgmm::fit_model(tile, c);
  std::printf("fitted a model: 16x16 tile, %zu x %zu directions, M = %zu, 4 iterations, %.1f s\n",
              tile.lights().size(), tile.views().size(), m.mixture.size(), now() - t0);
  return m;
}

void scene(const char* name, const btfgmm::BtfModel& model, const btfgmm::Mesh& mesh,
           const btfgmm::Camera& camera, const Options& o, double tolerance) {
  btfgmm::RenderSettings s;
  s.width = s.height = o.size;
  s.repeat = 4;
  s.tolerance = tolerance;
  const btfgmm::Light light = btfgmm::Light::directional({45, 30});
  const btfgmm::ModelEvaluator ev(model, tolerance);
  double geometry = 1e30, shading = 1e30, compose = 1e30, cpu = 1e30;
  btfgmm::EvaluationStats st;
  for (int r = 0; r < o.runs; ++r) {
    const double c0 = cpu_now();
    double t = now();
    const btfgmm::SurfaceBuffer sb =
        btfgmm::rasterize(mesh, camera, light, s, model.width, model.height);
    geometry = std::min(geometry, now() - t);
    std::vector<float> rgb(sb.points.size() * 3);
    t = now();
    st = ev.evaluate(sb.points, rgb, sb.block_start);
    shading = std::min(shading, now() - t);
    t = now();
    const btfgmm::Rendering img = btfgmm::compose(sb, rgb, s, model.format);
    compose = std::min(compose, now() - t);
    cpu = std::min(cpu, cpu_now() - c0);
    if (img.width != o.size) std::abort();
  }
  const double total = geometry + shading + compose;
  std::printf(
      "%-7s %dx%d  M = %zu  tolerance %-5g  lit pixels %7llu (%3.0f%%)  geometry %.4f s  "
      "model %.4f s  compose %.4f s  total %.4f s (CPU %.4f s) | nominal %5.0f M evals, "
      "%5.2f G/s | evaluated %5.0f M (%3.0f%%), %5.2f G/s\n",
      name, o.size, o.size, model.mixture.size(), tolerance,
      static_cast<unsigned long long>(st.points),
      100.0 * double(st.points) / (double(o.size) * o.size), geometry, shading, compose, total, cpu,
      double(st.nominal) * 1e-6, double(st.nominal) * 1e-9 / total, double(st.evaluated) * 1e-6,
      100.0 * double(st.evaluated) / double(std::max<std::uint64_t>(st.nominal, 1)),
      double(st.evaluated) * 1e-9 / shading);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_render: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--model")
      o.model = next();
    else if (a == "--size")
      o.size = std::atoi(next().c_str());
    else if (a == "--components")
      o.components = std::size_t(std::atol(next().c_str()));
    else if (a == "--threads")
      o.threads = std::atoi(next().c_str());
    else if (a == "--runs")
      o.runs = std::max(1, std::atoi(next().c_str()));
    else if (a == "--tolerance")
      o.tolerance = std::atof(next().c_str());
    else if (a == "--no-full")
      o.full = false;
    else if (a == "--stages")
      o.stages = next();
    else {
      std::fprintf(stderr,
                   "usage: bench_render [--model FILE] [--size N] [--components M] [--threads T] "
                   "[--runs R] [--tolerance LEVELS] [--no-full]\n"
                   "       bench_render --stages OUT.png --model FILE [--size N] [--threads T]\n");
      return 2;
    }
  }
  if (o.threads > 0) omp_set_num_threads(o.threads);
  try {
    if (!o.stages.empty()) {
      if (o.model.empty()) throw std::runtime_error("--stages needs --model");
      process_stages(o);
      return 0;
    }
    const btfgmm::BtfModel model = o.model.empty() ? fitted_model(o) : btfgmm::load_model(o.model);
    std::printf("model: %s, %dx%d tile, %zu x %zu directions, M = %zu; %d threads\n",
                o.model.empty() ? "(fitted above)" : o.model.c_str(), model.width, model.height,
                model.lights.size(), model.views.size(), model.mixture.size(),
                omp_get_max_threads());
    const btfgmm::Mesh sphere = btfgmm::make_sphere();
    const btfgmm::Camera orbit = btfgmm::Camera::orbit({60, 0}, sphere.radius());
    // The plane seen from 30 degrees, close enough to fill the frame.
    const btfgmm::Mesh plane = btfgmm::make_plane(8);
    btfgmm::Camera close;
    close.eye = btfgmm::to_vector({30, 200});
    close.eye = {1.4 * close.eye.x, 1.4 * close.eye.y, 1.4 * close.eye.z};
    close.target = {0, 0, 0};
    close.fov_deg = 40;
    for (double tol : {o.tolerance, 0.0}) {
      if (tol == 0.0 && !o.full && o.tolerance != 0.0) break;
      scene("sphere", model, sphere, orbit, o, tol);
      scene("plane", model, plane, close, o, tol);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_render: %s\n", e.what());
    return 1;
  }
  return 0;
}
