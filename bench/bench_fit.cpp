// bench_fit: one EM fit of btfgmm side by side with Armadillo's gmm_diag (the EM behind
// mlpack's diagonal GMM), on the same samples from the same starting parameters, each in a
// child process of its own so that its peak memory is its own. Prints one table: seconds,
// ns per sample-component-iteration, mean log-likelihood, peak memory, and the ratio.
//
//   bench_fit [--size S] [--tile T] [--components M] [--iterations K] [--threads N]
//             [--no-peer] [--save FILE]
//   bench_fit --decode FILE [--threads N] [--tolerance L]
//
// --save writes the fitted model; --decode times only the decoding of a saved model's whole
// tile (every light and view of it), with decode()'s tolerance L (levels) and with 0.
//
// Samples: a generated corduroy BTF (S x S pixels, 81 x 81 directions), its T x T tile;
// T = 12 gives 944,784 samples.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <omp.h>

#include <armadillo>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>

#include "bench_clock.hpp"
#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/samples.hpp"

namespace {

struct Options {
  int size = 32, tile = 12, iterations = 5, threads = 0;
  std::size_t components = 600;
  bool peer = true;
  std::string save, decode;
  double tolerance = btfgmm::kDecodeTolerance;
};

struct Result {
  double seconds = 0, log_likelihood = 0, cpu_seconds = 0, decode_seconds = 0;
  double fit_cpu_seconds = 0, decode_cpu_seconds = 0;  // CPU time of all threads
  long peak_kib = 0;
  bool ok = false;
};

btfgmm::SampleSet samples(const Options& o) {
  btfgmm::GenerateConfig g;
  g.material = "corduroy";
  g.size = o.size;
  g.seed = 1;
  const btfgmm::Btf full = btfgmm::generate(g);
  if (o.tile == o.size) return btfgmm::make_sample_set(full);  // no copy of the whole BTF
  btfgmm::Btf tile(full.lights(), full.views(), o.tile, o.tile, full.format());
  for (std::size_t l = 0; l < full.lights().size(); ++l)
    for (std::size_t v = 0; v < full.views().size(); ++v)
      for (int y = 0; y < o.tile; ++y)
        for (int x = 0; x < o.tile; ++x)
          for (int c = 0; c < 3; ++c) tile.at(l, v, x, y, c) = full.at(l, v, x, y, c);
  return btfgmm::make_sample_set(tile);
}

using bench::cpu_now;
using bench::now;

Result run_ours(const Options& o) {
  const btfgmm::SampleSet s = samples(o);
  btfgmm::ProductMixture mix = btfgmm::initial_mixture(s, o.components, 7);
  btfgmm::EmConfig c;
  c.max_iterations = o.iterations;
  c.threads = o.threads;
  // As for Armadillo: K iterations timed, the log-likelihood of the result computed after.
  c.final_log_likelihood = false;
  const double t0 = now(), c0 = cpu_now();
  btfgmm::fit_em(s, mix, c);
  Result out;
  out.seconds = now() - t0;
  out.fit_cpu_seconds = cpu_now() - c0;
  out.log_likelihood = btfgmm::mean_log_likelihood(s, mix, o.threads);
  out.ok = true;
  // Decoding the whole tile from the fitted model (T x T x 81 x 81 predictions).
  btfgmm::BtfModel model;
  model.lights = model.views = btfgmm::DirectionSet::ubo81();
  model.width = model.height = o.tile;
  model.scaling = s.scaling;
  model.mean_brdf = s.mean_brdf;
  model.mixture = mix;
  const double t1 = now(), c1 = cpu_now();
  const btfgmm::Btf decoded = btfgmm::decode(model, model.lights, model.views, o.tile, o.tile);
  out.decode_seconds = now() - t1;
  out.decode_cpu_seconds = cpu_now() - c1;
  if (decoded.data().empty()) out.ok = false;
  if (!o.save.empty()) btfgmm::save_model(model, o.save);
  return out;
}

// Decoding a saved model's whole tile, with the tolerance and with every component.
int run_decode(const Options& o) {
  const btfgmm::BtfModel model = btfgmm::load_model(o.decode);
  if (o.threads > 0) omp_set_num_threads(o.threads);
  const double n =
      double(model.width) * model.height * double(model.lights.size()) * double(model.views.size());
  std::printf("decode %s: %d x %d tile, %zu x %zu directions, %.0f predictions, M = %zu\n\n",
              o.decode.c_str(), model.width, model.height, model.lights.size(), model.views.size(),
              n, model.mixture.size());
  std::printf(
      "| tolerance (levels) | seconds | CPU seconds | ns per prediction x component |\n"
      "|---|---|---|---|\n");
  for (const double tol : {o.tolerance, 0.0}) {
    const double t0 = now(), c0 = cpu_now();
    const btfgmm::Btf d =
        btfgmm::decode(model, model.lights, model.views, model.width, model.height, tol);
    const double s = now() - t0, c = cpu_now() - c0;
    std::printf("| %g | %.2f | %.2f | %.3f |\n", tol, s, c,
                s / (n * double(model.mixture.size())) * 1e9);
    std::fflush(stdout);
    if (d.data().empty()) return 1;
  }
  return 0;
}

Result run_armadillo(const Options& o) {
  const btfgmm::SampleSet s = samples(o);
  const btfgmm::ProductMixture mix = btfgmm::initial_mixture(s, o.components, 7);
  arma::mat data(btfgmm::kVariables, s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto x = s.sample(i);
    for (int n = 0; n < btfgmm::kVariables; ++n) data(arma::uword(n), i) = x[std::size_t(n)];
  }
  arma::mat means(btfgmm::kVariables, mix.size()), dcovs(btfgmm::kVariables, mix.size());
  arma::rowvec hefts(mix.size());
  for (std::size_t m = 0; m < mix.size(); ++m) {
    hefts(m) = mix.weight[m];
    for (int n = 0; n < btfgmm::kVariables; ++n) {
      means(arma::uword(n), m) = mix.mean[m][std::size_t(n)];
      dcovs(arma::uword(n), m) = mix.var[m][std::size_t(n)];
    }
  }
  arma::gmm_diag g;
  g.set_params(means, dcovs, hefts);
  const double t0 = now(), c0 = cpu_now();
  // keep_existing: start from the parameters above; no k-means; o.iterations EM iterations;
  // the same variance floor as btfgmm.
  const bool ok = g.learn(data, arma::uword(mix.size()), arma::eucl_dist, arma::keep_existing, 0,
                          arma::uword(o.iterations), btfgmm::kVarianceFloor, false);
  Result out;
  out.seconds = now() - t0;
  out.fit_cpu_seconds = cpu_now() - c0;
  out.log_likelihood = g.avg_log_p(data);
  out.ok = ok;
  return out;
}

// Runs f in a child process; its peak resident memory comes from wait4.
template <class F>
Result in_child(F f) {
  int fd[2];
  if (pipe(fd) != 0) std::exit(1);
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    const Result r = f();
    if (write(fd[1], &r, sizeof r) != sizeof r) _exit(1);
    _exit(0);
  }
  close(fd[1]);
  Result r;
  if (read(fd[0], &r, sizeof r) != sizeof r) r.ok = false;
  close(fd[0]);
  int status = 0;
  struct rusage ru {};
  wait4(pid, &status, 0, &ru);
  r.peak_kib = ru.ru_maxrss;
  r.cpu_seconds = double(ru.ru_utime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&] { return i + 1 < argc ? std::atol(argv[++i]) : 0L; };
    if (a == "--size")
      o.size = int(next());
    else if (a == "--tile")
      o.tile = int(next());
    else if (a == "--components")
      o.components = std::size_t(next());
    else if (a == "--iterations")
      o.iterations = int(next());
    else if (a == "--threads")
      o.threads = int(next());
    else if (a == "--no-peer")
      o.peer = false;
    else if (a == "--save" && i + 1 < argc)
      o.save = argv[++i];
    else if (a == "--decode" && i + 1 < argc)
      o.decode = argv[++i];
    else if (a == "--tolerance" && i + 1 < argc)
      o.tolerance = std::atof(argv[++i]);
    else {
      std::fprintf(stderr,
                   "usage: bench_fit [--size S] [--tile T] [--components M] [--iterations K] "
                   "[--threads N] [--no-peer] [--save FILE]\n       bench_fit --decode FILE "
                   "[--threads N] [--tolerance L]\n");
      return 2;
    }
  }
  if (!o.decode.empty()) return run_decode(o);
  if (o.tile > o.size) o.size = o.tile;
  const double n = double(o.tile) * o.tile * 81 * 81;
  const double pairs = n * double(o.components) * o.iterations;
  std::printf(
      "EM fit: %d x %d tile of a generated corduroy BTF, 81 x 81 directions, N = %.0f "
      "samples, M = %zu, %d iterations, same starting parameters\n\n",
      o.tile, o.tile, n, o.components, o.iterations);
  std::printf(
      "| implementation | seconds | CPU seconds (all threads) | ns / (sample x component x "
      "iteration) | mean log-likelihood | peak memory |\n|---|---|---|---|---|---|\n");
  const Result ours = in_child([&] { return run_ours(o); });
  const double predictions = n;
  std::printf("| btfgmm fit_em | %.2f | %.2f | %.3f | %.6f | %.0f MiB |\n", ours.seconds,
              ours.fit_cpu_seconds, ours.seconds / pairs * 1e9, ours.log_likelihood,
              ours.peak_kib / 1024.0);
  std::fflush(stdout);
  std::printf(
      "\nbtfgmm decode of the whole tile: %.0f predictions with M = %zu in %.2f s (CPU %.2f s; "
      "%.2f ns per prediction x component)\n",
      predictions, o.components, ours.decode_seconds, ours.decode_cpu_seconds,
      ours.decode_seconds / (predictions * double(o.components)) * 1e9);
  if (o.peer) {
    const Result peer = in_child([&] { return run_armadillo(o); });
    std::printf("| Armadillo %s gmm_diag | %.2f | %.2f | %.3f | %.6f | %.0f MiB |\n",
                arma::arma_version::as_string().c_str(), peer.seconds, peer.fit_cpu_seconds,
                peer.seconds / pairs * 1e9, peer.log_likelihood, peer.peak_kib / 1024.0);
    std::printf(
        "\nbtfgmm is %.1fx faster than Armadillo per sample x component x iteration in wall "
        "time, %.1fx in CPU time (log-likelihood difference %.2e)\n",
        peer.seconds / ours.seconds, peer.fit_cpu_seconds / ours.fit_cpu_seconds,
        ours.log_likelihood - peer.log_likelihood);
  }
  return ours.ok ? 0 : 1;
}
