// EM on the sample grid, Eq. (3)-(7), organised for speed (docs/ALGORITHM.md, "The grid path").
//
// For component m and sample (pixel p, light l, view v), log w_m F(x | m) splits into
//   S[p][m]  (log w_m, the normalisation, and the x, y terms: depends on the pixel only)
// + L[l][m]  (the alpha_i, beta_i terms: the light only)
// + V[v][m]  (the alpha_v, beta_v terms: the view only)
// + the three colour terms (the sample itself).
// The tables are built once per iteration; a block is one (pixel, light) pair and its nv
// views, whose responsibilities are folded at once into the statistics:
//   per pixel, light and view: sum q            (x, y and the angles follow from these)
//   per component:             sum q d, sum q d^2 with d = colour - previous mean.
// Blocks are grouped into a fixed number of chunks of pixels whose statistics are reduced in
// chunk order, so the result is the same for any number of threads.
//
// Per iteration: the tables (make_tables), the E pass (e_pass: Eq. 2-4, the group passes of
// em_group_pass.hpp), the sufficient statistics of every component (sufficient_statistics),
// the M-step (Eq. 5-7, m_step in mixture.cpp) and the stop test.
#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>

#include "btfgmm/core/text.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/samples.hpp"
#include "core/flush_denormals.hpp"
#include "model/em_group_pass.hpp"
#include "model/mixture_internal.hpp"
#include "model/responsibilities.hpp"

namespace btfgmm {
namespace {

using detail::kAbsent;
using detail::kGroup;
using detail::kLanes;
using detail::Tables;
using detail::Workspace;

constexpr std::size_t kChunks = 16;

// Components grouped into vectors of kLanes whose colour means (r, g, b) lie close together
// (a k-d split, mixture_internal.hpp): a sample's responsibilities concentrate on the
// components whose colour is near its own, so they share few vectors, and the vectors' colour
// boxes are small, which tightens the chunk bound of the AVX-512 pass. The order changes
// nothing but float summation order; it is a function of the parameters alone.
std::vector<std::size_t> block_order(const ProductMixture& mix) {
  return detail::kd_order(mix, {6, 7, 8}, kLanes);
}

// The periods of the nine variables on the sample grid: x and y wrap around the tile
// (mixture_internal.hpp, "The tile wraps").
detail::Periods tile_periods(const SampleSet& s) {
  return detail::variable_periods({double(s.width), double(s.height)});
}

// The tables of log w_m F(x | m), Eq. (2), in parts: S (log w_m, the normalisation and the
// x, y terms, wrapped) per pixel, L (alpha_i, beta_i) per light, V (alpha_v, beta_v) per view, and
// the colour means and -1/(2 sigma^2) for the colour terms.
void tabulate_densities(Tables& t, const SampleSet& s, const ProductMixture& mix) {
  const std::size_t m_count = t.m, st = t.stride;
  t.s.assign(s.pixels() * st, kAbsent);
  t.l.assign(s.lights * st, 0.0f);
  t.v.assign(s.views * st, 0.0f);
  t.mu.assign(3 * st, 0.0f);
  t.neg_half_inv_var.assign(3 * st, 0.0f);
  std::vector<double> base(m_count);
  for (std::size_t k = 0; k < m_count; ++k) {
    const std::size_t m = t.order[k];
    base[k] = detail::log_density_constant(mix, m);
    for (int c = 0; c < 3; ++c) {
      t.mu[c * st + k] = float(mix.mean[m][6 + c]);
      t.neg_half_inv_var[c * st + k] = float(-0.5 / mix.var[m][6 + c]);
    }
  }
  const detail::Periods periods = tile_periods(s);
  auto gauss = [&](std::size_t k, int n, double x) {
    const std::size_t m = t.order[k];
    return detail::gauss_exponent(x, mix.mean[m][n], mix.var[m][n], periods[std::size_t(n)]);
  };
  for (std::size_t p = 0; p < s.pixels(); ++p) {
    const double x = double(p % std::size_t(s.width)), y = double(p / std::size_t(s.width));
    for (std::size_t k = 0; k < m_count; ++k)
      t.s[p * st + k] = float(base[k] + gauss(k, 0, x) + gauss(k, 1, y));
  }
  for (std::size_t l = 0; l < s.lights; ++l)
    for (std::size_t k = 0; k < m_count; ++k)
      t.l[l * st + k] = float(gauss(k, 2, s.light_ab[l][0]) + gauss(k, 3, s.light_ab[l][1]));
  for (std::size_t v = 0; v < s.views; ++v)
    for (std::size_t k = 0; k < m_count; ++k)
      t.v[v * st + k] = float(gauss(k, 4, s.view_ab[v][0]) + gauss(k, 5, s.view_ab[v][1]));
}

// What the AVX-512 pass's chunk bound reads (ChunkBound), per chunk of kLanes components:
// the largest V of each view, the box of the colour means, the largest -1/(2 sigma^2).
void tabulate_chunk_bounds(Tables& t, const SampleSet& s) {
  const std::size_t m_count = t.m, st = t.stride;
  const std::size_t chunks = st / kLanes;
  const std::size_t pc = t.padded_chunks = (chunks + kLanes - 1) / kLanes * kLanes;
  t.v_max.assign(s.views * pc, 0.0f);
  for (std::size_t v = 0; v < s.views; ++v)
    for (std::size_t j = 0; j < chunks; ++j)
      t.v_max[v * pc + j] =
          *std::max_element(&t.v[v * st + j * kLanes], &t.v[v * st + (j + 1) * kLanes]);
  for (int c = 0; c < 3; ++c) {
    t.lo[c].assign(pc, 0.0f);
    t.hi[c].assign(pc, 0.0f);
    t.h_max[c].assign(pc, 0.0f);
    for (std::size_t j = 0; j < chunks; ++j) {
      float lo = INFINITY, hi = -INFINITY, hm = -INFINITY;
      for (std::size_t k = j * kLanes; k < std::min(m_count, (j + 1) * kLanes); ++k) {
        lo = std::min(lo, t.mu[std::size_t(c) * st + k]);
        hi = std::max(hi, t.mu[std::size_t(c) * st + k]);
        hm = std::max(hm, t.neg_half_inv_var[std::size_t(c) * st + k]);
      }
      t.lo[c][j] = lo;
      t.hi[c][j] = hi;
      t.h_max[c][j] = hm;
    }
  }
}

Tables make_tables(const SampleSet& s, const ProductMixture& mix) {
  Tables t;
  const std::size_t m_count = t.m = mix.size();
  t.stride = (m_count + kLanes - 1) / kLanes * kLanes;
  t.order = block_order(mix);
  // A component whose log density is below the sample's maximum by more than this has
  // q < e^-Delta; all of them together change the sum by less than M e^-Delta = e^-17.5
  // relative, below float's resolution (2^-24 = e^-16.6).
  t.skip_margin = float(std::log(double(m_count)) + 17.5);
  tabulate_densities(t, s, mix);
  tabulate_chunk_bounds(t, s);
  return t;
}

// The statistics of one chunk of pixels (double), reduced in chunk order.
struct ChunkStats {
  std::vector<double> ql, qv, c1, c2;  // ni x stride, nv x stride, 3 x stride, 3 x stride
  ChunkStats(const SampleSet& s, std::size_t st)
      : ql(s.lights * st, 0.0), qv(s.views * st, 0.0), c1(3 * st, 0.0), c2(3 * st, 0.0) {}
};

// What the E pass accumulates: sum q per pixel (qp, P x stride) and the statistics of each
// chunk of pixels.
struct GridStatistics {
  std::vector<double> qp;
  std::vector<ChunkStats> chunks;
  GridStatistics(const SampleSet& s, std::size_t st) : qp(s.pixels() * st, 0.0) {
    chunks.reserve(kChunks);  // each chunk's zeros written in place, not copied from a first
    for (std::size_t c = 0; c < kChunks; ++c) chunks.emplace_back(s, st);
  }
};

// Morton key of a colour (10 bits a channel over the box lo..hi).
std::uint32_t colour_key(const float* rgb, const float lo[3], const float span[3]) {
  std::uint32_t k = 0;
  for (int c = 0; c < 3; ++c) {
    const float u = span[c] > 0 ? (rgb[c] - lo[c]) / span[c] : 0.0f;
    const auto q = std::uint32_t(std::clamp(u, 0.0f, 0.9999f) * 1024.0f);
    for (int bit = 0; bit < 10; ++bit) k |= ((q >> bit) & 1u) << (3 * bit + c);
  }
  return k;
}

// The views of every (pixel, light) block in the order of their residual colours (a Morton
// key): the four samples of a group then have similar colours, so the components near one
// of them are near all four and the skip of group_pass drops more vectors (on generated data
// the live fraction falls from about 0.42 to 0.31). Grouping changes nothing but float
// summation order, and the order is a function of the data alone. One byte a sample; sets of
// more than 256 views keep their own order (empty result).
std::vector<std::uint8_t> view_order(const SampleSet& s) {
  const std::size_t nv = s.views, blocks = s.pixels() * s.lights;
  if (nv > 256 || nv < 2) return {};
  const auto n = std::ptrdiff_t(blocks);
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
#pragma omp parallel reduction(min : lo[:3]) reduction(max : hi[:3])
  {
    std::vector<float> r(nv * 3);
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      s.block_residuals(std::size_t(b) / s.lights, std::size_t(b) % s.lights, r.data());
      for (std::size_t k = 0; k < nv * 3; ++k) {
        lo[k % 3] = std::min(lo[k % 3], r[k]);
        hi[k % 3] = std::max(hi[k % 3], r[k]);
      }
    }
  }
  const float span[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  std::vector<std::uint8_t> order(s.size());
#pragma omp parallel
  {
    std::vector<std::pair<std::uint32_t, std::uint8_t>> key(nv);
    std::vector<float> r(nv * 3);
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      const std::size_t first = std::size_t(b) * nv;
      s.block_residuals(std::size_t(b) / s.lights, std::size_t(b) % s.lights, r.data());
      for (std::size_t v = 0; v < nv; ++v)
        key[v] = {colour_key(&r[v * 3], lo, span), std::uint8_t(v)};
      std::sort(key.begin(), key.end());
      for (std::size_t v = 0; v < nv; ++v) order[first + v] = key[v].second;
    }
  }
  return order;
}

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

// The block's accumulators (float) into the per-pixel sums qp and the chunk's statistics
// (double).
[[gnu::always_inline]] inline void add_block_statistics(const Tables& t, std::size_t p,
                                                        std::size_t l, const Workspace& w,
                                                        std::vector<double>& qp, ChunkStats& cs) {
  const std::size_t st = t.stride;
  double* qpp = &qp[p * st];
  double* qll = &cs.ql[l * st];
  for (std::size_t m = 0; m < st; ++m) {
    qpp[m] += double(w.a0[m]);
    qll[m] += double(w.a0[m]);
  }
  for (std::size_t k = 0; k < 3 * st; ++k) {
    cs.c1[k] += double(w.a1[k]);
    cs.c2[k] += double(w.a2[k]);
  }
}

// The pixels of chunk c: every (pixel, light) block. Returns the sum of their samples' terms
// of L; with `cs`, folds the responsibilities into qp and cs.
double chunk_pass(const SampleSet& s, const Tables& t, const std::vector<std::uint8_t>& order,
                  std::size_t c, Workspace& w, std::vector<double>* qp, ChunkStats* cs) {
  const std::size_t ni = s.lights, nv = s.views, pixels = s.pixels(), st = t.stride;
  const bool stats = cs != nullptr;
  double ll = 0.0;
  for (std::size_t p = c * pixels / kChunks; p < (c + 1) * pixels / kChunks; ++p) {
    if (stats) std::fill(w.qv.begin(), w.qv.end(), 0.0f);
    for (std::size_t l = 0; l < ni; ++l) {
      block_pass(s, t, order, p, l, w, stats, ll);
      if (stats) add_block_statistics(t, p, l, w, *qp, *cs);
    }
    if (stats)
      for (std::size_t k = 0; k < nv * st; ++k) cs->qv[k] += double(w.qv[k]);
  }
  return ll;
}

// One E pass, Eq. (2)-(4): returns L, Eq. (3). With `g`, folds the responsibilities into it.
// Accumulation: float within a (pixel, light) block of nv samples (and per view within a
// pixel's ni blocks), double beyond, in a fixed order per chunk.
double e_pass(const SampleSet& s, const Tables& t, const std::vector<std::uint8_t>& order,
              int threads, GridStatistics* g) {
  std::vector<double> chunk_ll(kChunks, 0.0);
  std::exception_ptr failure;
#pragma omp parallel num_threads(threads)
  {
    const detail::FlushDenormals flush;
    Workspace w(t.stride, s.views, kGroup);
#pragma omp for schedule(dynamic, 1)
    for (std::size_t c = 0; c < kChunks; ++c) {
      try {
        chunk_ll[c] =
            chunk_pass(s, t, order, c, w, g ? &g->qp : nullptr, g ? &g->chunks[c] : nullptr);
      } catch (...) {
#pragma omp critical(btfgmm_em_failure)
        if (!failure) failure = std::current_exception();
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  double total = 0.0;
  for (double v : chunk_ll) total += v;  // fixed order
  return total / double(s.size());
}

// The sufficient statistics of the M-step (mixture_internal.hpp) from the E pass's: the
// chunks reduced in order, then per component sum q, and the sums of q (x - mu_old),
// q (x - mu_old)^2 for each variable (x, y from the pixels, their minimum images; the angles
// from the lights and views; the colours as accumulated).
detail::SufficientStatistics sufficient_statistics(const SampleSet& s, const Tables& t,
                                                   const ProductMixture& mix,
                                                   const GridStatistics& g) {
  const std::size_t st = t.stride, pixels = s.pixels(), ni = s.lights, nv = s.views;
  ChunkStats sum(s, st);
  for (const auto& c : g.chunks) {
    for (std::size_t k = 0; k < sum.ql.size(); ++k) sum.ql[k] += c.ql[k];
    for (std::size_t k = 0; k < sum.qv.size(); ++k) sum.qv[k] += c.qv[k];
    for (std::size_t k = 0; k < sum.c1.size(); ++k) sum.c1[k] += c.c1[k];
    for (std::size_t k = 0; k < sum.c2.size(); ++k) sum.c2[k] += c.c2[k];
  }
  detail::SufficientStatistics ss(t.m);
  const detail::Periods periods = tile_periods(s);
  for (std::size_t k = 0; k < t.m; ++k) {
    const std::size_t m = t.order[k];  // table column k holds component m
    const auto& mu = mix.mean[m];
    auto add = [&](int n, double q, double x) {
      const double d = detail::wrapped_difference(x - mu[n], periods[std::size_t(n)]);
      ss.s1[m][n] += q * d;
      ss.s2[m][n] += q * d * d;
    };
    for (std::size_t p = 0; p < pixels; ++p) {
      const double q = g.qp[p * st + k];
      ss.s0[m] += q;
      add(0, q, double(p % std::size_t(s.width)));
      add(1, q, double(p / std::size_t(s.width)));
    }
    for (std::size_t l = 0; l < ni; ++l) {
      add(2, sum.ql[l * st + k], s.light_ab[l][0]);
      add(3, sum.ql[l * st + k], s.light_ab[l][1]);
    }
    for (std::size_t v = 0; v < nv; ++v) {
      add(4, sum.qv[v * st + k], s.view_ab[v][0]);
      add(5, sum.qv[v * st + k], s.view_ab[v][1]);
    }
    for (int c = 0; c < 3; ++c) {
      ss.s1[m][6 + c] = sum.c1[c * st + k];
      ss.s2[m][6 + c] = sum.c2[c * st + k];
    }
  }
  return ss;
}

int resolve_threads(int threads) {
  return threads > 0 ? threads : omp_get_max_threads();
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
  const std::vector<std::uint8_t> order = view_order(s);
  EmResult result;
  if (resume) {
    result = *resume;
    result.interrupted = false;
  }
  for (int it = result.iterations + 1; it <= config.max_iterations && !result.converged; ++it) {
    const Tables t = make_tables(s, mix);  // Eq. (2) in parts
    GridStatistics g(s, t.stride);
    const double ll = e_pass(s, t, order, threads, &g);  // Eq. (3)-(4)
    // M-step, Eq. (5)-(7).
    result.dropped +=
        detail::m_step(mix, sufficient_statistics(s, t, mix, g), double(s.size()),
                       config.variance_floor, config.min_component_samples, tile_periods(s));
    // Stop test: the gain of L (record_iteration), or a stop from outside (the state so far,
    // to resume from).
    detail::record_iteration(result, ll, it, config, mix.size(), t0, progress);
    if (after_iteration) after_iteration(mix, result);
    if (config.stop && config.stop->load() && it < config.max_iterations && !result.converged) {
      result.interrupted = true;
      return result;
    }
  }
  result.final_log_likelihood = config.final_log_likelihood
                                    ? e_pass(s, make_tables(s, mix), order, threads, nullptr)
                                    : std::numeric_limits<double>::quiet_NaN();
  return result;
}

double mean_log_likelihood(const SampleSet& s, const ProductMixture& mix, int threads) {
  EmConfig c;
  c.threads = threads;
  detail::check_em_input(s.size(), mix, c);
  return e_pass(s, make_tables(s, mix), view_order(s), resolve_threads(threads), nullptr);
}

}  // namespace btfgmm
