// bench_fit: one EM fit of btfgmm side by side with Armadillo's gmm_diag (the EM behind
// mlpack's diagonal GMM), on the same samples from the same starting parameters, each in a
// child process of its own so that its peak memory is its own. Prints:
//
//  1. btfgmm's fit of the tile's model (x, y wrap around the tile, as every fit's), its
//     decoding, and, for each thread count of --threads, btfgmm beside Armadillo on the plain
//     model of the paper (nothing wraps: EmConfig::tile_wraps off, the model Armadillo fits),
//     so that the two compute the same thing: seconds, ns per sample-component-iteration, mean
//     log-likelihood (equal to about 1e-7), peak memory, and the ratio.
//  2. With --scaling, the thread scaling of btfgmm's fit: for 1, 2, 4, ... and all threads,
//     the time of an iteration (the mean of iterations 2..K), where it goes (the tables of
//     Eq. 2, the E pass, the M-step with the lights' sums), the speed-up over one thread, the
//     efficiency, the serial fraction it implies (Karp and Flatt 1990: e = (1/S - 1/n) /
//     (1 - 1/n)), and the share of the M-step with the lights' sums.
//
//  3. With --refine-epochs E, the refinement for the prediction (model/refine.hpp) after the
//     tile model's EM, E epochs (passes over the training samples in minibatches, with their
//     validations): the seconds of an epoch beside those of an EM iteration, and their ratio.
//
//   bench_fit [--size S] [--tile T] [--components M] [--iterations K] [--threads LIST]
//             [--no-peer] [--scaling] [--save FILE] [--refine-epochs E]
//   bench_fit --decode FILE [--threads N] [--tolerance L]
//
// --threads: a comma-separated list of thread counts for part 1 (0: all cores; default 0).
// Exits with 1 where a plain-model fit's log-likelihood differs from Armadillo's by more than
// 1e-6 (the two no longer fit the same model).
// --save writes the fitted model; --decode times only the decoding of a saved model's whole
// tile (every light and view of it), with decode()'s tolerance L (levels) and with 0.
//
// Samples: a generated corduroy BTF (S x S pixels, 81 x 81 directions), its T x T tile;
// T = 12 gives 944,784 samples.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <omp.h>

#include <algorithm>
#include <armadillo>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench_clock.hpp"
#include "bench_samples.hpp"
#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"

namespace {

struct Options {
  int size = 32, tile = 12, iterations = 5;
  std::vector<int> threads{0};
  std::size_t components = 600;
  bool peer = true, scaling = false;
  int refine_epochs = 0;
  std::string save, decode;
  double tolerance = btfgmm::kDecodeTolerance;
};

struct Result {
  double seconds = 0, log_likelihood = 0, cpu_seconds = 0, decode_seconds = 0;
  double fit_cpu_seconds = 0, decode_cpu_seconds = 0;  // CPU time of all threads
  double per_iteration = 0;                            // mean of iterations 2..K
  double per_epoch = 0, validation_rmse = 0;           // of the refinement (--refine-epochs)
  double weighed = 1;        // the share of the samples' components its steps weighed
  double cpu_per_epoch = 0;  // CPU seconds (all threads) of an epoch
  double refit_subsample = 0, refit_whole = 0;  // the colour refit's sums: seconds
  std::size_t refit_samples = 0, training_samples = 0;
  btfgmm::EmStageSeconds stages;
  long peak_kib = 0;
  int threads = 0;
  bool ok = false;
};

btfgmm::SampleSet samples(const Options& o) {
  return bench::corduroy_samples(o.size, o.tile);
}

using bench::cpu_now;
using bench::now;

int resolved(int threads) {
  return threads > 0 ? threads : omp_get_max_threads();
}

// The mean time of iterations 2..K (all of them where K = 1): the first iteration from a
// random start is the densest.
double per_iteration(const btfgmm::EmResult& r) {
  const std::size_t k = r.seconds.size();
  if (k == 0) return 0.0;
  if (k == 1) return r.seconds[0];
  return (r.seconds[k - 1] - r.seconds[0]) / double(k - 1);
}

// The decoding of the whole tile from the fitted model (T x T x 81 x 81 predictions), timed
// into `out`; the model saved where --save asks.
void decode_and_save(const Options& o, const btfgmm::SampleSet& s,
                     const btfgmm::ProductMixture& mix, Result& out) {
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
}

// The refinement for the prediction of EM's mixture, --refine-epochs epochs: the seconds of
// an epoch (its steps and validations, not the colour refits around them).
void refine(const Options& o, int threads, const btfgmm::SampleSet& s, btfgmm::ProductMixture& mix,
            Result& out) {
  // The normal equations of the colour refit on its subsample and on every training sample.
  const std::size_t stride = std::max<std::size_t>(1, s.size() / btfgmm::kColourRefitSamples);
  double t0 = now();
  out.refit_samples = btfgmm::colour_normal_equations(s, mix, threads, stride, true).samples;
  out.refit_subsample = now() - t0;
  t0 = now();
  out.training_samples = btfgmm::colour_normal_equations(s, mix, threads, 1, true).samples;
  out.refit_whole = now() - t0;
  btfgmm::GradientConfig g;
  g.steps = btfgmm::kMaxRefineSteps;
  g.max_epochs = o.refine_epochs;
  g.seconds = btfgmm::kMaxRefineSeconds;
  const btfgmm::PredictionRefinement r = btfgmm::refine_for_prediction(s, mix, threads, g);
  out.per_epoch = r.gradient_seconds / std::max(1, r.epochs);
  out.cpu_per_epoch = r.gradient_cpu_seconds / std::max(1, r.epochs);
  out.validation_rmse = btfgmm::prediction_rmse(r.error_final, r.samples);
  out.weighed = r.weighed;
}

// btfgmm's fit on `threads` threads; `tile_wraps` off fits the plain model, as Armadillo.
Result run_ours(const Options& o, int threads, bool tile_wraps, bool decode) {
  const btfgmm::SampleSet s = samples(o);
  btfgmm::ProductMixture mix = btfgmm::initial_mixture(s, o.components, 7);
  btfgmm::EmConfig c;
  c.max_iterations = o.iterations;
  c.threads = threads;
  c.tile_wraps = tile_wraps;
  // Armadillo keeps every component: the plain model's fit drops none either.
  if (!tile_wraps) c.min_component_samples = 0.0;
  // As for Armadillo: K iterations timed, the log-likelihood of the result computed after.
  c.final_log_likelihood = false;
  const double t0 = now(), c0 = cpu_now();
  const btfgmm::EmResult r = btfgmm::fit_em(s, mix, c);
  Result out;
  out.seconds = now() - t0;
  out.fit_cpu_seconds = cpu_now() - c0;
  out.per_iteration = per_iteration(r);
  out.stages = r.stages;
  out.threads = resolved(threads);
  out.log_likelihood = btfgmm::mean_log_likelihood(s, mix, threads, tile_wraps);
  out.ok = true;
  if (decode && o.refine_epochs > 0) refine(o, threads, s, mix, out);
  if (decode) decode_and_save(o, s, mix, out);
  return out;
}

// Decoding a saved model's whole tile, with the tolerance and with every component.
int run_decode(const Options& o) {
  const btfgmm::BtfModel model = btfgmm::load_model(o.decode);
  if (o.threads.front() > 0) omp_set_num_threads(o.threads.front());
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

// Armadillo's gmm_diag on `threads` threads (its E and M steps are OpenMP loops).
Result run_armadillo(const Options& o, int threads) {
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
  omp_set_num_threads(resolved(threads));
  const double t0 = now(), c0 = cpu_now();
  // keep_existing: start from the parameters above; no k-means; o.iterations EM iterations;
  // the same variance floor as btfgmm.
  const bool ok = g.learn(data, arma::uword(mix.size()), arma::eucl_dist, arma::keep_existing, 0,
                          arma::uword(o.iterations), btfgmm::kVarianceFloor, false);
  Result out;
  out.seconds = now() - t0;
  out.fit_cpu_seconds = cpu_now() - c0;
  out.log_likelihood = g.avg_log_p(data);
  out.threads = resolved(threads);
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

// The largest difference of the mean log-likelihoods of the plain model's fits by btfgmm and
// by Armadillo that counts as the same fit.
constexpr double kSameModel = 1e-6;

void print_row(const char* name, const Result& r, double pairs) {
  std::printf("| %s | %d | %.2f | %.2f | %.3f | %.8f | %.0f MiB |\n", name, r.threads, r.seconds,
              r.fit_cpu_seconds, r.seconds / pairs * 1e9, r.log_likelihood, r.peak_kib / 1024.0);
  std::fflush(stdout);
}

// Part 1: the tile's fit and its decoding, then each thread count's plain-model fits side by side.
bool run_comparison(const Options& o, double n, double pairs) {
  std::printf(
      "| implementation | threads | seconds | CPU seconds (all threads) | ns / (sample x "
      "component x iteration) | mean log-likelihood | peak memory |\n"
      "|---|---|---|---|---|---|---|\n");
  const Result ours = in_child([&] { return run_ours(o, o.threads.front(), true, true); });
  print_row("btfgmm fit_em, the tile's model (x, y wrap)", ours, pairs);
  bool ok = ours.ok;
  std::vector<int> done;
  for (const int threads : o.threads) {
    if (!o.peer || std::find(done.begin(), done.end(), resolved(threads)) != done.end()) continue;
    done.push_back(resolved(threads));
    const Result plain = in_child([&] { return run_ours(o, threads, false, false); });
    print_row("btfgmm fit_em, the plain model", plain, pairs);
    const Result peer = in_child([&] { return run_armadillo(o, threads); });
    const std::string name = "Armadillo " + arma::arma_version::as_string() + " gmm_diag";
    print_row(name.c_str(), peer, pairs);
    std::printf("|  | %d | ratio %.1fx | CPU ratio %.1fx | | log-likelihood difference %.2e | |\n",
                plain.threads, peer.seconds / plain.seconds,
                peer.fit_cpu_seconds / plain.fit_cpu_seconds,
                plain.log_likelihood - peer.log_likelihood);
    // The same model from the same start: the two must agree (Eq. 3 to float rounding).
    const bool same = std::abs(plain.log_likelihood - peer.log_likelihood) <= kSameModel;
    if (!same) std::printf("the plain model's log-likelihood differs from Armadillo's\n");
    ok = ok && plain.ok && peer.ok && same;
  }
  if (o.refine_epochs > 0)
    std::printf(
        "\nrefinement for the prediction: an epoch (every training sample once, with its "
        "validations) %.3f s beside an EM iteration %.3f s: ratio %.2f; validation RMSE %.3f "
        "levels after %d epochs; its steps weighed %.1f %% of the samples' components\n",
        ours.per_epoch, ours.per_iteration, ours.per_epoch / ours.per_iteration,
        ours.validation_rmse, o.refine_epochs, 100.0 * ours.weighed);
  if (o.refine_epochs > 0)
    std::printf(
        "in CPU seconds (all threads): an epoch %.3f s beside an EM iteration %.3f s (the fit's "
        "%d iterations' mean): ratio %.2f\n",
        ours.cpu_per_epoch, ours.fit_cpu_seconds / o.iterations, o.iterations,
        ours.cpu_per_epoch / (ours.fit_cpu_seconds / o.iterations));
  if (o.refine_epochs > 0)
    std::printf(
        "the colour refit's normal equations: %zu samples (its subsample) %.3f s, every "
        "training sample (%zu) %.3f s: %.2f and %.2f EM iterations\n",
        ours.refit_samples, ours.refit_subsample, ours.training_samples, ours.refit_whole,
        ours.refit_subsample / ours.per_iteration, ours.refit_whole / ours.per_iteration);
  std::printf(
      "\nbtfgmm decode of the whole tile: %.0f predictions with M = %zu in %.2f s (CPU %.2f s; "
      "%.2f ns per prediction x component)\n",
      n, o.components, ours.decode_seconds, ours.decode_cpu_seconds,
      ours.decode_seconds / (n * double(o.components)) * 1e9);
  return ok;
}

// 1, 2, 4, ... threads and all of them.
std::vector<int> thread_ladder() {
  std::vector<int> out;
  const int all = omp_get_max_threads();
  for (int t = 1; t < all; t *= 2) out.push_back(t);
  out.push_back(all);
  return out;
}

// Part 2: the thread scaling of the tile's fit.
bool run_scaling(const Options& o) {
  std::printf(
      "\n## Thread scaling (the tile's model; s / iteration: the mean of iterations 2..%d; the "
      "stages: the mean of all)\n\n"
      "| threads | s (all %d) | s / iteration | tables | E pass | M-step and sums | speed-up | "
      "efficiency | serial fraction (Karp-Flatt) | M-step and sums' share |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n",
      o.iterations, o.iterations);
  double one = 0.0;
  bool ok = true;
  for (const int t : thread_ladder()) {
    const Result r = in_child([&] { return run_ours(o, t, true, false); });
    ok = ok && r.ok;
    const double k = double(o.iterations);
    if (t == 1) one = r.per_iteration;
    const double speedup = one / r.per_iteration;
    const double serial = t > 1 ? (1.0 / speedup - 1.0 / t) / (1.0 - 1.0 / t) : 0.0;
    std::printf("| %d | %.3f | %.4f | %.4f | %.4f | %.4f | %.2f | %.0f %% | %.3f | %.1f %% |\n", t,
                r.seconds, r.per_iteration, r.stages.tables / k, r.stages.e_pass / k,
                r.stages.m_step / k, speedup, 100.0 * speedup / t, serial,
                100.0 * r.stages.m_step / (r.stages.tables + r.stages.e_pass + r.stages.m_step));
    std::fflush(stdout);
  }
  return ok;
}

std::vector<int> parse_list(const char* s) {
  std::vector<int> out;
  for (const char* p = s; *p;) {
    char* end = nullptr;
    out.push_back(int(std::strtol(p, &end, 10)));
    if (end == p) return {};
    p = *end == ',' ? end + 1 : end;
  }
  return out;
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    auto next = [&] { return has ? std::atol(argv[++i]) : 0L; };
    if (a == "--size")
      o.size = int(next());
    else if (a == "--tile")
      o.tile = int(next());
    else if (a == "--components")
      o.components = std::size_t(next());
    else if (a == "--iterations")
      o.iterations = int(next());
    else if (a == "--threads" && has)
      o.threads = parse_list(argv[++i]);
    else if (a == "--no-peer")
      o.peer = false;
    else if (a == "--scaling")
      o.scaling = true;
    else if (a == "--save" && has)
      o.save = argv[++i];
    else if (a == "--decode" && has)
      o.decode = argv[++i];
    else if (a == "--refine-epochs")
      o.refine_epochs = int(next());
    else if (a == "--tolerance" && has)
      o.tolerance = std::atof(argv[++i]);
    else
      return false;
  }
  return !o.threads.empty() && o.iterations > 0 && o.tile > 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) {
    std::fprintf(stderr,
                 "usage: bench_fit [--size S] [--tile T] [--components M] [--iterations K] "
                 "[--threads N,N,...] [--no-peer] [--scaling] [--save FILE] [--refine-epochs E]\n"
                 "       bench_fit --decode FILE [--threads N] [--tolerance L]\n");
    return 2;
  }
  if (!o.decode.empty()) return run_decode(o);
  if (o.tile > o.size) o.size = o.tile;
  const double n = double(o.tile) * o.tile * 81 * 81;
  const double pairs = n * double(o.components) * o.iterations;
  std::printf(
      "EM fit: %d x %d tile of a generated corduroy BTF, 81 x 81 directions, N = %.0f "
      "samples, M = %zu, %d iterations, same starting parameters\n\n",
      o.tile, o.tile, n, o.components, o.iterations);
  bool ok = run_comparison(o, n, pairs);
  if (o.scaling) ok = run_scaling(o) && ok;
  if (!ok) std::printf("a run failed\n");
  return ok ? 0 : 1;
}
