// bench_methods: the speed of the comparison methods (src/methods/).
//
//  1. PCA BTF (Koudelka et al. 2003) fitted to a generated S x S corduroy tile with 81 x 81
//     directions, c = 16 eigen-images, beside numpy's SVD of the same matrix (the tile's
//     images as rows of 3 S^2 values, less their mean image; numpy.linalg.svd with
//     full_matrices=False, run by /usr/bin/python3 on the matrix written to a temporary .npy
//     file). Prints both times, their ratio, and the RMSE of the fitted model beside numpy's
//     optimum for c components (the singular values after the c-th). Then scikit-learn's
//     randomized_svd of c components on the same matrix, the same algorithm as btfgmm's
//     randomized path (10 oversamples, 4 power iterations), its time, ratio and RMSE.
//     btfgmm's time is its whole fit (the mean image, the PCA, the weights refitted to the
//     stored factors); its PCA alone (principal_components) is timed and printed too.
//     --no-full-svd skips numpy's SVD (minutes; then no optimum is printed).
//  2. Decoding every image of the tile (all ni x nv, S x S pixels each) for every method in
//     the registry, at the middle size of its ladder: the model is fitted to the S x S tile,
//     or to a smaller crop of it where the fit would take longer than --fit-budget seconds
//     (estimated from a fit to a 16 x 16 crop; the tile fitted is printed), then decoded at
//     S x S pixels (the tile repeats), best of --runs.
//
//   bench_methods [--size S] [--directions SPEC] [--components C] [--dtype float64|float32]
//                 [--no-peer] [--no-full-svd] [--fit-budget SECONDS] [--runs R] [--threads N]
//                 [--methods a,b,...] [--skip-pca] [--skip-decode]
//
// Defaults: S = 64, ubo81 directions, C = 16, float64, budget 60 s, 3 runs. A quick check:
// bench_methods --size 8 --directions rings:0/1,30/4 --runs 1.
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "bench_clock.hpp"
#include "btfgmm/btfgmm.hpp"
#include "methods/pca.hpp"

namespace {

using bench::cpu_now;
using bench::now;

struct Options {
  int size = 64, threads = 0, runs = 3;
  std::string directions = "ubo81", dtype = "float64";
  std::size_t components = 16;
  double fit_budget = 60.0;
  bool peer = true, full_svd = true, pca = true, decode = true;
  std::vector<std::string> methods;  // empty: all
};

// The method of that name, or null when this build has none.
const btfgmm::MethodInfo* method_named(const std::string& name) {
  for (const btfgmm::MethodInfo& m : btfgmm::all_methods())
    if (m.name == name) return &m;
  return nullptr;
}

btfgmm::Btf generated_tile(const Options& o) {
  btfgmm::GenerateConfig g;
  g.material = "corduroy";
  g.size = o.size;
  g.seed = 1;
  g.lights = g.views = btfgmm::DirectionSet::parse(o.directions);
  return btfgmm::generate(g);
}

// The side x side pixels at the tile's origin.
btfgmm::Btf crop(const btfgmm::Btf& full, int side) {
  btfgmm::Btf t(full.lights(), full.views(), side, side, full.format());
  for (std::size_t l = 0; l < full.lights().size(); ++l)
    for (std::size_t v = 0; v < full.views().size(); ++v)
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x)
          for (int c = 0; c < 3; ++c) t.at(l, v, x, y, c) = full.at(l, v, x, y, c);
  return t;
}

double rmse(const btfgmm::Btf& a, const btfgmm::Btf& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.data().size(); ++i) {
    const double d = double(a.data()[i]) - double(b.data()[i]);
    s += d * d;
  }
  return std::sqrt(s / double(a.data().size()));
}

// ---- 1. PCA BTF beside numpy's SVD ---------------------------------------------------------

// The tile's images as rows, less their mean image, as a float32 .npy file.
void write_centred_npy(const btfgmm::Btf& tile, const std::filesystem::path& path) {
  const std::size_t rows = tile.image_count(), cols = tile.image_floats();
  std::vector<double> mean(cols, 0.0);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t k = 0; k < cols; ++k) mean[k] += tile.data()[i * cols + k];
  for (double& m : mean) m /= double(rows);
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" +
                       std::to_string(rows) + ", " + std::to_string(cols) + "), }";
  while ((10 + header.size() + 1) % 64) header += ' ';
  header += '\n';
  std::ofstream out(path, std::ios::binary);
  const unsigned char magic[8] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0};
  out.write(reinterpret_cast<const char*>(magic), 8);
  const std::uint16_t len = std::uint16_t(header.size());
  const unsigned char len_le[2] = {static_cast<unsigned char>(len & 0xff),
                                   static_cast<unsigned char>(len >> 8)};
  out.write(reinterpret_cast<const char*>(len_le), 2);
  out << header;
  std::vector<float> row(cols);
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::size_t k = 0; k < cols; ++k) row[k] = float(tile.data()[i * cols + k] - mean[k]);
    out.write(reinterpret_cast<const char*>(row.data()), std::streamsize(cols * sizeof(float)));
  }
}

struct NumpyResult {
  bool ok = false;
  // numpy's SVD; seconds < 0 where --no-full-svd skipped it.
  double seconds = -1, optimum_rmse = 0;
  std::string version;
  // scikit-learn's randomized_svd of c components (4 power iterations, as btfgmm's), the same
  // algorithm as btfgmm's for a tile this size; seconds < 0 where scikit-learn is missing.
  double randomized_seconds = -1, randomized_rmse = 0;
};

// numpy.linalg.svd(full_matrices=False) of the matrix in `npy` (unless --no-full-svd), then
// scikit-learn's randomized_svd, each timed in Python itself.
NumpyResult numpy_svd(const std::filesystem::path& npy, const Options& o) {
  const std::string script =
      "import sys, time, numpy as np\n"
      "a = np.load(sys.argv[1]).astype(sys.argv[2])\n"
      "c = int(sys.argv[3])\n"
      "if sys.argv[4] == '1':\n"
      "    t = time.perf_counter()\n"
      "    u, s, vt = np.linalg.svd(a, full_matrices=False)\n"
      "    t = time.perf_counter() - t\n"
      "    print(t, np.sqrt(np.sum(s[c:].astype(np.float64) ** 2) / a.size), np.__version__)\n"
      "else:\n"
      "    print(-1, 0, np.__version__)\n"
      "try:\n"
      "    from sklearn.utils.extmath import randomized_svd\n"
      "    t = time.perf_counter()\n"
      "    u, s, vt = randomized_svd(a, c, n_oversamples=10, n_iter=4, random_state=0)\n"
      "    t = time.perf_counter() - t\n"
      "    e = np.sum(a.astype(np.float64) ** 2) - np.sum(s.astype(np.float64) ** 2)\n"
      "    print(t, np.sqrt(max(e, 0) / a.size))\n"
      "except ImportError:\n"
      "    print(-1, 0)\n";
  const std::filesystem::path py = npy.string() + ".py";
  std::ofstream(py) << script;
  const std::string cmd = "/usr/bin/python3 " + py.string() + " " + npy.string() + " " + o.dtype +
                          " " + std::to_string(o.components) + (o.full_svd ? " 1" : " 0");
  NumpyResult r;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    char version[64] = {0};
    r.ok = std::fscanf(p, "%lf %lf %63s", &r.seconds, &r.optimum_rmse, version) == 3;
    r.version = version;
    if (r.ok && std::fscanf(p, "%lf %lf", &r.randomized_seconds, &r.randomized_rmse) != 2)
      r.randomized_seconds = -1;
    r.ok = pclose(p) == 0 && r.ok;
  }
  std::filesystem::remove(py);
  return r;
}

struct OurPca {
  bool ok = false;
  double seconds = 0, cpu = 0, rmse = 0;
  double pca_seconds = 0, pca_cpu = 0;  // principal_components alone
};

// btfgmm's whole pca-btf fit (the mean image, the PCA, the weights refitted to the stored
// factors) and the RMSE of its model, then the PCA alone as the fit runs it.
OurPca fit_ours(const btfgmm::Btf& tile, const Options& o) {
  OurPca r;
  const btfgmm::MethodInfo* pca = method_named("pca-btf");
  if (!pca) {
    std::printf("pca-btf not built\n");
    return r;
  }
  btfgmm::FitOptions s;
  s.components = o.components;
  s.threads = o.threads;
  const double t0 = now(), c0 = cpu_now();
  const auto model = pca->fit(tile, s);
  r.seconds = now() - t0;
  r.cpu = cpu_now() - c0;
  r.rmse = rmse(tile, model->decode(tile.lights(), tile.views(), tile.width(), tile.height(),
                                    btfgmm::kDecodeTolerance));
  std::printf("btfgmm pca-btf fit: %.3f s (CPU %.3f s, %d threads), %s, RMSE %.4f levels\n",
              r.seconds, r.cpu, omp_get_max_threads(), model->size_text().c_str(), r.rmse);
  btfgmm::detail::PcaSettings ps;
  ps.seed = s.seed;
  const double t1 = now(), c1 = cpu_now();
  const btfgmm::detail::Pca p = btfgmm::detail::principal_components(
      tile.data(), tile.image_count(), tile.image_floats(), o.components, ps);
  r.pca_seconds = now() - t1;
  r.pca_cpu = cpu_now() - c1;
  std::printf(
      "btfgmm's PCA alone (principal_components: the mean image, the %s SVD, the centred "
      "data's energy, the projections): %.3f s (CPU %.3f s)\n",
      p.randomized ? "randomized" : "Gram", r.pca_seconds, r.pca_cpu);
  r.ok = true;
  return r;
}

void bench_pca(const btfgmm::Btf& tile, const Options& o) {
  std::printf("## PCA BTF: %d x %d tile, %zu x %zu directions (a %zu x %zu matrix), c = %zu\n\n",
              tile.width(), tile.height(), tile.lights().size(), tile.views().size(),
              tile.image_count(), tile.image_floats(), o.components);
  const OurPca ours = fit_ours(tile, o);
  std::fflush(stdout);
  if (!o.peer) return;
  const std::filesystem::path npy = std::filesystem::temp_directory_path() /
                                    ("bench_methods_" + std::to_string(::getpid()) + ".npy");
  write_centred_npy(tile, npy);
  const NumpyResult np = numpy_svd(npy, o);
  std::filesystem::remove(npy);
  if (!np.ok) {
    std::printf("numpy: /usr/bin/python3 with numpy did not run\n\n");
    return;
  }
  if (np.seconds >= 0) {
    std::printf(
        "numpy %s linalg.svd (%s, full_matrices=False): %.3f s; the optimum RMSE of %zu "
        "components: %.4f levels\n",
        np.version.c_str(), o.dtype.c_str(), np.seconds, o.components, np.optimum_rmse);
    if (ours.ok)
      std::printf("numpy's time / btfgmm's: %.1fx (above 1: btfgmm faster)\n",
                  np.seconds / ours.seconds);
  }
  if (np.randomized_seconds >= 0) {
    std::printf(
        "scikit-learn randomized_svd (%s, %zu components, 10 oversamples, 4 power iterations): "
        "%.3f s, RMSE %.4f levels\n",
        o.dtype.c_str(), o.components, np.randomized_seconds, np.randomized_rmse);
    if (ours.ok)
      std::printf(
          "scikit-learn's time / btfgmm's: %.2fx the whole fit, %.2fx the PCA alone (above 1: "
          "btfgmm faster)\n",
          np.randomized_seconds / ours.seconds, np.randomized_seconds / ours.pca_seconds);
  }
  std::printf("\n");
}

// ---- 2. decoding every image, per method ---------------------------------------------------

struct Fitted {
  std::unique_ptr<btfgmm::Representation> model;
  int side = 0;
  double seconds = 0;
};

// The setting fitted to the largest crop (side halving from the tile's) whose fit is estimated
// (from a 16 x 16 crop, linear in the pixels) within the budget.
Fitted fit_within_budget(const btfgmm::MethodInfo& m, const btfgmm::FitOptions& s,
                         const btfgmm::Btf& tile, const Options& o) {
  Fitted f;
  auto fit_at = [&](int side) {
    const double t0 = now();
    f.model = side == tile.width() ? m.fit(tile, s) : m.fit(crop(tile, side), s);
    f.seconds = now() - t0;
    f.side = side;
  };
  const int small = std::min(16, tile.width());
  fit_at(small);
  const double per_pixel = f.seconds / (double(small) * small);
  int side = tile.width();
  while (side > small && per_pixel * double(side) * side > o.fit_budget) side /= 2;
  if (side > small) fit_at(side);
  return f;
}

void bench_decode(const btfgmm::Btf& tile, const Options& o) {
  const int n = tile.width();
  std::printf(
      "## Decoding all %zu images of %d x %d pixels, each method at its ladder's middle "
      "size (best of %d)\n\n",
      tile.image_count(), n, n, o.runs);
  std::printf(
      "| method | size | fitted to | fit s | decode s | CPU s | Mpixel-images / s | "
      "C.R. file |\n|---|---|---|---|---|---|---|---|\n");
  for (const btfgmm::MethodInfo& m : btfgmm::all_methods()) {
    if (!o.methods.empty() &&
        std::find(o.methods.begin(), o.methods.end(), m.name) == o.methods.end())
      continue;
    const auto ladder = m.ladder(btfgmm::ModelFrame::of(tile));
    if (ladder.empty()) continue;
    btfgmm::FitOptions s = ladder[ladder.size() / 2];
    s.threads = o.threads;
    Fitted f;
    try {
      f = fit_within_budget(m, s, tile, o);
    } catch (const btfgmm::Error& e) {
      std::printf("| %s | %s | refused: %s | | | | | |\n", std::string(m.name).c_str(),
                  btfgmm::settings_text(s).c_str(), e.what());
      continue;
    }
    double best = 1e300, best_cpu = 0;
    for (int r = 0; r < o.runs; ++r) {
      const double t0 = now(), c0 = cpu_now();
      const btfgmm::Btf d =
          f.model->decode(tile.lights(), tile.views(), n, n, btfgmm::kDecodeTolerance);
      const double t = now() - t0;
      if (t < best) best = t, best_cpu = cpu_now() - c0;
    }
    const double bytes = double(btfgmm::representation_file_bytes(*f.model).size());
    std::printf("| %s | %s | %d x %d | %.2f | %.3f | %.3f | %.1f | 1:%.1f |\n",
                std::string(m.name).c_str(), f.model->size_text().c_str(), f.side, f.side,
                f.seconds, best, best_cpu, double(n) * n * double(tile.image_count()) / best / 1e6,
                f.model->file_ratio(std::uint64_t(bytes)));
    std::fflush(stdout);
  }
  std::printf("\n");
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_methods [--size S] [--directions SPEC] [--components C] [--dtype "
               "float64|float32] [--no-peer] [--no-full-svd] [--fit-budget SECONDS] [--runs R] "
               "[--threads N] "
               "[--methods a,b,...] [--skip-pca] [--skip-decode]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--size" && has)
      o.size = std::atoi(argv[++i]);
    else if (a == "--directions" && has)
      o.directions = argv[++i];
    else if (a == "--components" && has)
      o.components = std::size_t(std::atol(argv[++i]));
    else if (a == "--dtype" && has)
      o.dtype = argv[++i];
    else if (a == "--fit-budget" && has)
      o.fit_budget = std::atof(argv[++i]);
    else if (a == "--runs" && has)
      o.runs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--threads" && has)
      o.threads = std::atoi(argv[++i]);
    else if (a == "--no-peer")
      o.peer = false;
    else if (a == "--no-full-svd")
      o.full_svd = false;
    else if (a == "--skip-pca")
      o.pca = false;
    else if (a == "--skip-decode")
      o.decode = false;
    else if (a == "--methods" && has) {
      std::string list = argv[++i];
      for (std::size_t at = 0; at <= list.size();) {
        const std::size_t comma = std::min(list.find(',', at), list.size());
        if (comma > at) o.methods.push_back(list.substr(at, comma - at));
        at = comma + 1;
      }
    } else
      return usage();
  }
  if (o.size < 1 || (o.dtype != "float64" && o.dtype != "float32")) return usage();
  if (o.threads > 0) omp_set_num_threads(o.threads);
  try {
    const double t0 = now();
    const btfgmm::Btf tile = generated_tile(o);
    std::printf("generated a %d x %d corduroy tile, %zu x %zu directions, in %.1f s\n\n", o.size,
                o.size, tile.lights().size(), tile.views().size(), now() - t0);
    if (o.pca) bench_pca(tile, o);
    if (o.decode) bench_decode(tile, o);
  } catch (const btfgmm::Error& e) {
    std::fprintf(stderr, "bench_methods: %s\n", e.what());
    return 1;
  }
  return 0;
}
