// EM on the sample grid, Eq. (3)-(7), organised for speed (docs/ALGORITHM.md, "The grid path").
//
// For component m and sample (pixel p, light l, view v), log w_m F(x | m) splits into
//   S[p][m]  (log w_m, the normalisation, and the x, y terms: depends on the pixel only)
// + L[l][m]  (the alpha_i, beta_i terms: the light only)
// + V[v][m]  (the alpha_v, beta_v terms: the view only)
// + the three colour terms (the sample itself).
// The tables are built once per iteration (em_tables.cpp); a block is one (pixel, light) pair
// and its nv views, whose responsibilities are folded at once into the statistics:
//   per view:        sum q                      (the view angles follow from these)
//   per component:   sum q, sum q dx, q dx^2, q dy, q dy^2 (the pixel's minimum-image
//                    distances), sum q d, sum q d^2 with d = colour - previous mean.
// Each light's pixels are cut into chunks, as many as the tile's size gives (chunk_count),
// whose statistics are reduced in chunk order to the light's 1 + 19 M numbers; the lights'
// are added in light order, over every process of a distributed sample set
// (docs/SCALING.md). So the result is the same for any number of threads and processes. The
// threads share the (light, chunk) pairs of several lights at a time (light_batch), so that
// they have many more pieces of work than there are threads, and meet twice per batch.
//
// Per iteration: the tables (make_tables), the E pass (e_pass: Eq. 2-4, the group passes of
// em_group_pass.hpp; light_statistics), the lights combined (combine), the M-step (Eq. 5-7,
// m_step in mixture.cpp) and the stop test.
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <optional>
#include <span>

#include "btfgmm/core/communicator.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/samples.hpp"
#include "core/flush_denormals.hpp"
#include "model/em_gpu.hpp"
#include "model/em_group_pass.hpp"
#include "model/em_light_statistics.hpp"
#include "model/em_tables.hpp"
#include "model/mixture_internal.hpp"
#include "model/responsibilities.hpp"

namespace btfgmm {
namespace {

using detail::kGroup;
using detail::kPerComponent;
using detail::Periods;
using detail::Tables;
using detail::Workspace;

// The block's views in colour order (view_order), or their own, into `views`.
[[gnu::always_inline]] inline std::uint32_t* block_views(const SampleSet& s,
                                                         const std::vector<std::uint8_t>& order,
                                                         std::size_t p, std::size_t l,
                                                         std::uint32_t* views) {
  const std::size_t nv = s.views;
  if (order.empty())
    for (std::size_t v = 0; v < nv; ++v) views[v] = std::uint32_t(v);
  else
    for (std::size_t v = 0; v < nv; ++v) views[v] = order[s.index(p, l, v)];
  return views;
}

// One (pixel, light) block: its S + L row, then its views in groups (em_group_pass.hpp).
// Adds the samples' terms of L to ll; with `stats`, their statistics to the block's
// accumulators of w (cleared here).
[[gnu::always_inline]] inline void block_pass(const SampleSet& s, const Tables& t,
                                              const std::vector<std::uint8_t>& order, std::size_t p,
                                              std::size_t l, Workspace& w, bool stats, double& ll) {
  const std::size_t st = t.stride, nv = s.views;
  const float* srow = &t.s[p * st];
  const float* lrow = &t.l[l * st];
#pragma omp simd
  for (std::size_t m = 0; m < st; ++m) w.sl[m] = srow[m] + lrow[m];
  s.block_residuals(p, l, w.residual.data());
  if (stats) {
    std::fill(w.a0.begin(), w.a0.end(), 0.0f);
    std::fill(w.a1.begin(), w.a1.end(), 0.0f);
    std::fill(w.a2.begin(), w.a2.end(), 0.0f);
  }
  const std::uint32_t* views = block_views(s, order, p, l, w.view_list.data());
  std::size_t v = 0;
#if defined(__AVX512F__)
  v = detail::block_pass_avx512(t, nv, views, w, stats, ll);
#endif
  for (; v + kGroup <= nv; v += kGroup) ll += detail::group_pass<kGroup>(t, views + v, w, stats);
  for (; v < nv; ++v) ll += detail::group_pass<1>(t, views + v, w, stats);
}

// The statistics of one chunk of pixels of one light (double), reduced in chunk order: sum q
// (q), the sums of q dx, q dx^2, q dy, q dy^2 (xy, 4 x stride; dx, dy the pixel's minimum-image
// distance to the component's mean), sum q per view (qv, nv x stride), sum q d and q d^2 of
// the colours (c1, c2, 3 x stride), and the samples' terms of L (ll).
// Zeroed (and sized, the first time) by the thread that fills them, so that their pages are
// that thread's; qv is only sized, its first flush (flush_views) writes it whole.
struct ChunkStats {
  std::vector<double> q, xy, qv, c1, c2;
  double ll = 0.0;
  void reset(std::size_t views, std::size_t st) {
    q.assign(st, 0.0);
    xy.assign(4 * st, 0.0);
    qv.resize(views * st);
    c1.assign(3 * st, 0.0);
    c2.assign(3 * st, 0.0);
    ll = 0.0;
  }
};

// Per view, float holds the sums of at most this many pixels' responsibilities (each at most
// 1, so a sum of at most 256, whose float rounding is below 2^-16 of it) before they go to
// double: a chunk of up to 256 pixels goes to double once.
constexpr std::size_t kViewFlush = 256;

// A light's pixels are cut into chunks of about kChunkPixels, at most kMaxChunks of them: a
// function of the tile alone, so that the summation order is. Few chunks keep the per-view
// sums' cost (nv x stride per chunk and light) small beside the blocks' on small tiles.
constexpr std::size_t kChunkPixels = 256;
constexpr std::size_t kMaxChunks = 16;
std::size_t chunk_count(std::size_t pixels) {
  return std::clamp<std::size_t>((pixels + kChunkPixels - 1) / kChunkPixels, 1, kMaxChunks);
}

// The (light, chunk) pairs the threads share between two meetings: whole lights, at least 64
// pairs or eight per thread, within a memory bound for their statistics (kBatchBytes, at least
// one pair per thread), the lights shared evenly among the batches. It changes when the threads
// meet, never what is summed in which order.
constexpr double kBatchBytes = 256.0 * 1024 * 1024;
std::size_t light_batch(const SampleSet& s, std::size_t stride, std::size_t chunks, int threads) {
  const double pair_bytes = double((s.views + 11) * stride * sizeof(double));
  const auto fits = std::size_t(kBatchBytes / pair_bytes);
  const auto wanted = std::max<std::size_t>(64, 8 * std::size_t(threads));
  const std::size_t pairs = std::max(std::min(wanted, fits), std::size_t(threads));
  const std::size_t held = s.held_lights();
  const std::size_t most = std::clamp<std::size_t>((pairs + chunks - 1) / chunks, 1, held);
  const std::size_t batches = (held + most - 1) / most;
  return (held + batches - 1) / batches;
}

// The block's accumulators (float) into the chunk's statistics (double): sum q, and with the
// pixel's distances dx, dy (stride each) the spatial sums.
[[gnu::always_inline]] inline void add_block_statistics(const Tables& t, const double* dx,
                                                        const double* dy, const Workspace& w,
                                                        ChunkStats& cs) {
  const std::size_t st = t.stride;
  const float* __restrict a0 = w.a0.data();
  double* __restrict q = cs.q.data();
  double* __restrict x1 = cs.xy.data();
  double* __restrict x2 = x1 + st;
  double* __restrict y1 = x1 + 2 * st;
  double* __restrict y2 = x1 + 3 * st;
#pragma omp simd
  for (std::size_t m = 0; m < st; ++m) {
    const double qm = double(a0[m]);
    q[m] += qm;
    x1[m] += qm * dx[m];
    x2[m] += qm * dx[m] * dx[m];
    y1[m] += qm * dy[m];
    y2[m] += qm * dy[m] * dy[m];
  }
  const float* __restrict a1 = w.a1.data();
  const float* __restrict a2 = w.a2.data();
  double* __restrict c1 = cs.c1.data();
  double* __restrict c2 = cs.c2.data();
#pragma omp simd
  for (std::size_t k = 0; k < 3 * st; ++k) {
    c1[k] += double(a1[k]);
    c2[k] += double(a2[k]);
  }
}

// The per-view sums of the workspace (float) into the chunk's (double), and cleared.
// The first flush of a chunk writes the chunk's sums (0 + x = x, so no zeroing is needed).
void flush_views(Workspace& w, ChunkStats& cs, bool first) {
  double* __restrict to = cs.qv.data();
  float* __restrict from = w.qv.data();
  const std::size_t n = w.qv.size();
  if (first) {
#pragma omp simd
    for (std::size_t k = 0; k < n; ++k) to[k] = double(from[k]);
  } else {
#pragma omp simd
    for (std::size_t k = 0; k < n; ++k) to[k] += double(from[k]);
  }
  std::fill(from, from + n, 0.0f);
}

// The pixels of chunk c (of `chunks`) of light l: one (pixel, light) block each. Adds the sum
// of their samples' terms of L to cs.ll; with `stats`, folds the responsibilities into cs.
void chunk_pass(const SampleSet& s, const Tables& t, const std::vector<std::uint8_t>& order,
                std::size_t l, std::size_t c, std::size_t chunks, Workspace& w, bool stats,
                ChunkStats& cs) {
  const std::size_t pixels = s.pixels(), st = t.stride, width = std::size_t(s.width);
  const std::size_t first = c * pixels / chunks, last = (c + 1) * pixels / chunks;
  if (stats) std::fill(w.qv.begin(), w.qv.end(), 0.0f);
  for (std::size_t p = first; p < last; ++p) {
    block_pass(s, t, order, p, l, w, stats, cs.ll);
    if (!stats) continue;
    add_block_statistics(t, &t.dx[(p % width) * st], &t.dy[(p / width) * st], w, cs);
    if ((p - first + 1) % kViewFlush == 0 || p + 1 == last)
      flush_views(w, cs, p - first < kViewFlush);
  }
}

// The chunks' statistics added in chunk order into the first: 0 + c0 + c1 + ... = c0 + c1 + ...
// in floating point, so no zeroed sum is needed.
ChunkStats& reduce_chunks(std::span<ChunkStats> chunks) {
  ChunkStats& sum = chunks.front();
  auto add = [](std::vector<double>& to, const std::vector<double>& from) {
    double* __restrict a = to.data();
    const double* __restrict b = from.data();
#pragma omp simd
    for (std::size_t k = 0; k < to.size(); ++k) a[k] += b[k];
  };
  for (const ChunkStats& c : chunks.subspan(1)) {
    add(sum.q, c.q);
    add(sum.xy, c.xy);
    add(sum.qv, c.qv);
    add(sum.c1, c.c1);
    add(sum.c2, c.c2);
    sum.ll += c.ll;
  }
  return sum;
}

// The shifted sums of a view angle (n = 4: alpha_v, 5: beta_v; neither wraps) of every table
// column over the views, from the per-view sums qv (nv x stride): s1 += sum_v qv (a_v - mu),
// s2 += sum_v qv (a_v - mu)^2, views in order.
void view_angle_sums(const SampleSet& s, const Tables& t, const ProductMixture& mix, int n,
                     const double* qv, double* __restrict s1, double* __restrict s2) {
  const std::size_t st = t.stride;
  std::vector<double> mu(st, 0.0);
  for (std::size_t k = 0; k < t.m; ++k) mu[k] = mix.mean[t.order[k]][std::size_t(n)];
  for (std::size_t v = 0; v < s.views; ++v) {
    const double a = s.view_ab[v][std::size_t(n - 4)];
    const double* __restrict q = qv + v * st;
#pragma omp simd
    for (std::size_t k = 0; k < st; ++k) {
      const double d = a - mu[k];
      s1[k] += q[k] * d;
      s2[k] += q[k] * d * d;
    }
  }
}

// What one light contributes to the sufficient statistics of the M-step, from its chunks'
// (reduced in chunk order, into the first) and the view angles' sums from its per-view sums
// (em_light_statistics.hpp).
std::vector<double> light_statistics(const SampleSet& s, const Tables& t, const ProductMixture& mix,
                                     std::size_t l, std::span<ChunkStats> chunks,
                                     const Periods& periods) {
  const std::size_t st = t.stride;
  const ChunkStats& sum = reduce_chunks(chunks);
  std::vector<double> views(4 * st, 0.0);  // alpha_v: s1, s2; beta_v: s1, s2
  view_angle_sums(s, t, mix, 4, sum.qv.data(), &views[0], &views[st]);
  view_angle_sums(s, t, mix, 5, sum.qv.data(), &views[2 * st], &views[3 * st]);
  const detail::ColumnSums sums{sum.ll,       sum.q.data(),  sum.xy.data(),
                                views.data(), sum.c1.data(), sum.c2.data()};
  return detail::light_statistics(s, t, mix, l, sums, periods);
}

// L's terms of one light alone (the E pass without statistics): its chunks' in chunk order.
std::vector<double> light_log_likelihood(std::span<const ChunkStats> chunks) {
  double ll = 0.0;
  for (const ChunkStats& c : chunks) ll += c.ll;
  return {ll};
}

// What the threads of the E pass share: the problem, how it is cut (chunk_count, light_batch),
// the statistics of a batch's (light, chunk) pairs, the lights' results, the first failure.
struct EPass {
  const SampleSet& s;
  const Tables& t;
  const ProductMixture& mix;
  const std::vector<std::uint8_t>& order;
  const Periods& periods;
  const bool stats;
  const std::size_t chunks, batch;
  std::vector<ChunkStats> pairs;            // batch x chunks, light-major
  std::vector<std::vector<double>> lights;  // per light held
  std::exception_ptr failure;
  std::atomic<bool> failed{false};

  EPass(const SampleSet& s_, const Tables& t_, const ProductMixture& mix_,
        const std::vector<std::uint8_t>& order_, const Periods& periods_, bool stats_, int threads)
      : s(s_),
        t(t_),
        mix(mix_),
        order(order_),
        periods(periods_),
        stats(stats_),
        chunks(chunk_count(s_.pixels())),
        batch(light_batch(s_, t_.stride, chunks, threads)),
        pairs(batch * chunks),
        lights(s_.held_lights()) {}

  // Runs f, keeping the first exception of any thread (the loops then skip their work).
  template <typename F>
  void guarded(F&& f) {
    if (failed.load()) return;
    try {
      f();
    } catch (...) {
#pragma omp critical(btfgmm_em_failure)
      if (!failure) failure = std::current_exception();
      failed = true;
    }
  }

  // The lights [first, first + n) of one batch, by the calling thread's share of the team's
  // work (orphaned worksharing loops: called by every thread of the parallel region): each
  // (light, chunk) pair, then each light's statistics from its chunks.
  void run_batch(std::size_t first, std::size_t n, Workspace& w) {
    const auto n_pairs = std::ptrdiff_t(n * chunks);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t i = 0; i < n_pairs; ++i)
      guarded([&] {
        ChunkStats& cs = pairs[std::size_t(i)];
        cs.reset(stats ? s.views : 0, stats ? t.stride : 0);
        chunk_pass(s, t, order, first + std::size_t(i) / chunks, std::size_t(i) % chunks, chunks, w,
                   stats, cs);
      });
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t j = 0; j < std::ptrdiff_t(n); ++j)
      guarded([&] {
        const std::size_t l = first + std::size_t(j);
        const std::span<ChunkStats> mine(&pairs[std::size_t(j) * chunks], chunks);
        lights[l - s.first_light] =
            stats ? light_statistics(s, t, mix, l, mine, periods) : light_log_likelihood(mine);
      });
  }
};

// One E pass, Eq. (2)-(4), over the lights this process holds, each in chunk_count() chunks of
// pixels: returns each light's statistics (light_statistics; with `stats` false, L's terms
// alone). Accumulation: float within a (pixel, light) block of nv samples (and per view over
// kViewFlush pixels), double beyond, in a fixed order per chunk and light, so the result
// depends on neither the threads nor the processes.
std::vector<std::vector<double>> e_pass(const SampleSet& s, const Tables& t,
                                        const ProductMixture& mix,
                                        const std::vector<std::uint8_t>& order,
                                        const Periods& periods, int threads, bool stats) {
  EPass e(s, t, mix, order, periods, stats, threads);
#pragma omp parallel num_threads(threads)
  {
    const detail::FlushDenormals flush;
    Workspace w(t.stride, s.views, kGroup);
    for (std::size_t l = s.first_light; l < s.light_end(); l += e.batch)
      e.run_batch(l, std::min(e.batch, s.light_end() - l), w);
  }
  if (e.failure) std::rethrow_exception(e.failure);
  return std::move(e.lights);
}

// The statistics of every light, from every process, added in light order: L of Eq. (3) and
// the sufficient statistics of the M-step (mixture_internal.hpp).
struct Combined {
  double log_likelihood = 0.0;
  detail::SufficientStatistics ss;
  explicit Combined(std::size_t m) : ss(m) {}
};

// Every process's lights in order (the processes in rank order hold the lights in order), each
// light's numbers `per` apart (one process: a vector per light).
std::vector<const double*> lights_in_order(const std::vector<std::vector<double>>& all,
                                           std::size_t per) {
  std::vector<const double*> out;
  for (const std::vector<double>& r : all) {
    assert(r.size() % per == 0);
    for (std::size_t at = 0; at + per <= r.size(); at += per) out.push_back(&r[at]);
  }
  return out;
}

// Every light's statistics, this process's and, over processes, the others' (gathered).
std::vector<std::vector<double>> all_lights(const SampleSet& s,
                                            std::vector<std::vector<double>>&& mine) {
  if (!s.processes) return std::move(mine);
  std::vector<double> flat;
  for (const auto& l : mine) flat.insert(flat.end(), l.begin(), l.end());
  return all_gather_values<double>(*s.processes, std::span<const double>(flat));
}

Combined combine(const SampleSet& s, std::size_t m_count, bool stats,
                 std::vector<std::vector<double>>&& mine, int threads) {
  const auto all = all_lights(s, std::move(mine));
  const std::vector<const double*> lights =
      lights_in_order(all, stats ? 1 + m_count * kPerComponent : 1);
  Combined out(m_count);
  for (const double* r : lights) out.log_likelihood += r[0];
  if (!stats) return out;
    // Each component's sums over the lights in light order, the components over the threads.
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::ptrdiff_t mi = 0; mi < std::ptrdiff_t(m_count); ++mi) {
    const auto m = std::size_t(mi);
    for (const double* r : lights) {
      const double* o = r + 1 + m * kPerComponent;
      out.ss.s0[m] += o[0];
      for (std::size_t n = 0; n < std::size_t(kVariables); ++n) {
        out.ss.s1[m][n] += o[1 + n];
        out.ss.s2[m][n] += o[1 + kVariables + n];
      }
    }
  }
  return out;
}

int resolve_threads(int threads) {
  return threads > 0 ? threads : omp_get_max_threads();
}

// Whether the fit was asked to stop (config.stop): in any process of a distributed set, so
// that all stop after the same iteration.
bool asked_to_stop(const SampleSet& s, const EmConfig& config) {
  const std::uint8_t mine = config.stop && config.stop->load() ? 1 : 0;
  if (!s.processes) return mine != 0;
  for (const auto& r : all_gather_values<std::uint8_t>(*s.processes, std::span(&mine, 1)))
    if (!r.empty() && r[0] != 0) return true;
  return false;
}

// L of Eq. (3) of `mix` over every process's samples.
// The E pass on the fit's compute device where it has one (em_gpu.hpp), else on the threads.
std::vector<std::vector<double>> any_e_pass(detail::GpuEPass* gpu, const SampleSet& s,
                                            const Tables& t, const ProductMixture& mix,
                                            const std::vector<std::uint8_t>& order,
                                            const Periods& periods, int threads, bool stats) {
  return gpu ? gpu->run(t, mix, periods, stats) : e_pass(s, t, mix, order, periods, threads, stats);
}

double log_likelihood_of(const SampleSet& s, const ProductMixture& mix,
                         const std::vector<std::uint8_t>& order, const Periods& periods,
                         int threads, detail::GpuEPass* gpu = nullptr) {
  const Tables t = detail::make_tables(s, mix, periods, threads);
  auto lights = any_e_pass(gpu, s, t, mix, order, periods, threads, false);
  return combine(s, mix.size(), false, std::move(lights), threads).log_likelihood /
         double(s.size());
}

double seconds_from(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// One iteration: the tables, Eq. (2) in parts; Eq. (3)-(4) over this process's lights, every
// process's statistics added in light order; the M-step, Eq. (5)-(7). Returns L of the
// parameters it started from; adds the time of each stage to `stages`.
double em_iteration(const SampleSet& s, ProductMixture& mix, const EmConfig& config,
                    const std::vector<std::uint8_t>& order, int threads, detail::GpuEPass* gpu,
                    EmResult& result) {
  const Periods periods = detail::tile_periods(s, config.tile_wraps);
  auto at = Clock::now();
  const Tables t = detail::make_tables(s, mix, periods, threads);
  result.stages.tables += seconds_from(at);
  at = Clock::now();
  auto lights = any_e_pass(gpu, s, t, mix, order, periods, threads, true);
  result.stages.e_pass += seconds_from(at);
  at = Clock::now();
  const Combined c = combine(s, mix.size(), true, std::move(lights), threads);
  result.dropped += detail::m_step(mix, c.ss, double(s.size()), config.variance_floor,
                                   config.min_component_samples, periods);
  result.stages.m_step += seconds_from(at);
  return c.log_likelihood / double(s.size());
}

}  // namespace

EmResult fit_em(const SampleSet& s, ProductMixture& mix, const EmConfig& config,
                const EmCallback& progress, const EmResult* resume,
                const EmStateCallback& after_iteration) {
  detail::check_em_input(s.size(), mix, config);
  // A resumed fit's clock goes on from the time of the state it resumes.
  const double before = resume && !resume->seconds.empty() ? resume->seconds.back() : 0.0;
  const auto t0 = Clock::now() - std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>(before));
  const int threads = resolve_threads(config.threads);
  // The device holds the samples for every iteration; the CPU's pass reads the views in
  // their colour order.
  std::optional<detail::GpuEPass> gpu;
  if (config.device) gpu.emplace(*config.device, s);
  const std::vector<std::uint8_t> order = gpu ? std::vector<std::uint8_t>{} : detail::view_order(s);
  EmResult result;
  if (resume) {
    result = *resume;
    result.interrupted = false;
  }
  for (int it = result.iterations + 1; it <= config.max_iterations && !result.converged; ++it) {
    const double ll = em_iteration(s, mix, config, order, threads, gpu ? &*gpu : nullptr, result);
    // Stop test: the gain of L (record_iteration), or a stop from outside (the state so far,
    // to resume from).
    detail::record_iteration(result, ll, it, config, mix.size(), t0, progress);
    if (after_iteration) after_iteration(mix, result);
    if (asked_to_stop(s, config) && it < config.max_iterations && !result.converged) {
      result.interrupted = true;
      return result;
    }
  }
  result.final_log_likelihood =
      config.final_log_likelihood
          ? log_likelihood_of(s, mix, order, detail::tile_periods(s, config.tile_wraps), threads,
                              gpu ? &*gpu : nullptr)
          : std::numeric_limits<double>::quiet_NaN();
  return result;
}

double estimate_em_iteration_seconds(const SampleSet& s, const ProductMixture& start, int threads,
                                     const std::shared_ptr<ComputeDevice>& device) {
  check_em_size(s, start.size());
  const std::size_t held = s.held_lights();
  const std::size_t probe = std::clamp<std::size_t>((held + 31) / 32, 1, held);
  const SampleSet p = first_lights(s, probe);
  ProductMixture mix = start;
  const int n = resolve_threads(threads);
  const Periods periods = detail::tile_periods(p, true);
  auto at = Clock::now();
  const Tables t = detail::make_tables(p, mix, periods, n);
  const double tables = seconds_from(at);
  // The E pass of the probe's lights, run until 3 runs or 0.2 s: the least of its times (the
  // first run starts the threads; a loaded machine slows some runs).
  std::optional<Combined> c;
  std::optional<detail::GpuEPass> gpu;
  if (device) gpu.emplace(*device, p);
  const std::vector<std::uint8_t> order = gpu ? std::vector<std::uint8_t>{} : detail::view_order(p);
  double per_light = std::numeric_limits<double>::infinity(), spent = 0.0;
  for (int run = 0; run < 3 && (run == 0 || spent < 0.2); ++run) {
    at = Clock::now();
    c.emplace(combine(p, mix.size(), true,
                      any_e_pass(gpu ? &*gpu : nullptr, p, t, mix, order, periods, n, true), n));
    const double seconds = seconds_from(at);
    spent += seconds;
    per_light = std::min(per_light, seconds / double(probe));
  }
  at = Clock::now();
  const EmConfig defaults;
  detail::m_step(mix, c->ss, double(s.size()), defaults.variance_floor,
                 defaults.min_component_samples, periods);
  return tables + per_light * double(held) + seconds_from(at);
}

double estimate_em_iteration_seconds(const SampleSet& s, std::size_t components, int threads,
                                     const std::shared_ptr<ComputeDevice>& device) {
  check_em_size(s, components);
  // M equal components over the whole set: none is negligible, none is skipped.
  ProductMixture mix;
  mix.resize(components);
  for (std::size_t m = 0; m < components; ++m) {
    mix.weight[m] = 1.0 / double(components);
    mix.mean[m].fill(0.0);
    mix.var[m].fill(1.0);
  }
  return estimate_em_iteration_seconds(s, mix, threads, device);
}

double mean_log_likelihood(const SampleSet& s, const ProductMixture& mix, int threads,
                           bool tile_wraps) {
  EmConfig c;
  c.threads = threads;
  detail::check_em_input(s.size(), mix, c);
  return log_likelihood_of(s, mix, detail::view_order(s), detail::tile_periods(s, tile_wraps),
                           resolve_threads(threads));
}

}  // namespace btfgmm
