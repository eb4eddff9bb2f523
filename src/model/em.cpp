// EM on the sample grid, Eq. (3)-(7), organised for speed (docs/ALGORITHM.md, "The grid path").
//
// For component m and sample (pixel p, light l, view v), log w_m F(x | m) splits into
//   S[p][m]  (log w_m, the normalisation, and the x, y terms: depends on the pixel only)
// + L[l][m]  (the alpha_i, beta_i terms: the light only)
// + V[v][m]  (the alpha_v, beta_v terms: the view only)
// + the three colour terms (the sample itself).
// The tables are built once per iteration; a block is one (pixel, light) pair and its nv
// views, whose responsibilities are folded at once into the statistics:
//   per view:        sum q                      (the view angles follow from these)
//   per component:   sum q, sum q dx, q dx^2, q dy, q dy^2 (the pixel's minimum-image
//                    distances), sum q d, sum q d^2 with d = colour - previous mean.
// Each light's pixels are cut into a fixed number of chunks whose statistics are reduced in
// chunk order to the light's 1 + 19 M numbers; the lights' are added in light order, over
// every process of a distributed sample set (docs/SCALING.md). So the result is the same for
// any number of threads and processes.
//
// Per iteration: the tables (make_tables), the E pass (e_pass: Eq. 2-4, the group passes of
// em_group_pass.hpp; light_statistics), the lights combined (combine), the M-step (Eq. 5-7,
// m_step in mixture.cpp) and the stop test.
#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>

#include "btfgmm/core/communicator.hpp"
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

// The minimum-image distances of every column x and row y of the tile to each component's
// mean x and y (dx: W x stride, dy: H x stride; 0 for padding), for the spatial sums.
void tabulate_pixel_offsets(Tables& t, const SampleSet& s, const ProductMixture& mix) {
  const std::size_t st = t.stride;
  const detail::Periods periods = tile_periods(s);
  t.dx.assign(std::size_t(s.width) * st, 0.0);
  t.dy.assign(std::size_t(s.height) * st, 0.0);
  for (std::size_t k = 0; k < t.m; ++k) {
    const auto& mu = mix.mean[t.order[k]];
    for (std::size_t x = 0; x < std::size_t(s.width); ++x)
      t.dx[x * st + k] = detail::wrapped_difference(double(x) - mu[0], periods[0]);
    for (std::size_t y = 0; y < std::size_t(s.height); ++y)
      t.dy[y * st + k] = detail::wrapped_difference(double(y) - mu[1], periods[1]);
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
  tabulate_pixel_offsets(t, s, mix);
  return t;
}

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

// The box of every process's residual colours from each one's (lo, hi).
void colour_box_of_all(const SampleSet& s, float lo[3], float hi[3]) {
  if (!s.processes) return;
  const float mine[6] = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]};
  for (const std::vector<float>& r : all_gather_values<float>(*s.processes, mine))
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], r.at(std::size_t(c)));
      hi[c] = std::max(hi[c], r.at(3 + std::size_t(c)));
    }
}

// The views of every (pixel, light) block in the order of their residual colours (a Morton
// key): the four samples of a group then have similar colours, so the components near one
// of them are near all four and the skip of group_pass drops more vectors (on generated data
// the live fraction falls from about 0.42 to 0.31). Grouping changes nothing but float
// summation order, and the order is a function of the data alone. One byte a sample; sets of
// more than 256 views keep their own order (empty result).
std::vector<std::uint8_t> view_order(const SampleSet& s) {
  const std::size_t nv = s.views, held = s.held_lights(), blocks = s.pixels() * held;
  if (nv > 256 || nv < 2) return {};
  const auto n = std::ptrdiff_t(blocks);
  auto block = [&](std::ptrdiff_t b, float* r) {
    s.block_residuals(std::size_t(b) / held, s.first_light + std::size_t(b) % held, r);
  };
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
#pragma omp parallel reduction(min : lo[:3]) reduction(max : hi[:3])
  {
    std::vector<float> r(nv * 3);
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      block(b, r.data());
      for (std::size_t k = 0; k < nv * 3; ++k) {
        lo[k % 3] = std::min(lo[k % 3], r[k]);
        hi[k % 3] = std::max(hi[k % 3], r[k]);
      }
    }
  }
  colour_box_of_all(s, lo, hi);
  const float span[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  std::vector<std::uint8_t> order(s.size());
#pragma omp parallel
  {
    std::vector<std::pair<std::uint32_t, std::uint8_t>> key(nv);
    std::vector<float> r(nv * 3);
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      const std::size_t first = std::size_t(b) * nv;
      block(b, r.data());
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

// The statistics of one chunk of pixels of one light (double), reduced in chunk order: sum q
// (q), the sums of q dx, q dx^2, q dy, q dy^2 (xy, 4 x stride; dx, dy the pixel's minimum-image
// distance to the component's mean), sum q per view (qv, nv x stride), sum q d and q d^2 of
// the colours (c1, c2, 3 x stride), and the samples' terms of L (ll).
struct ChunkStats {
  std::vector<double> q, xy, qv, c1, c2;
  double ll = 0.0;
  ChunkStats(std::size_t views, std::size_t st)
      : q(st, 0.0), xy(4 * st, 0.0), qv(views * st, 0.0), c1(3 * st, 0.0), c2(3 * st, 0.0) {}
  void clear() {
    for (auto* v : {&q, &xy, &qv, &c1, &c2}) std::fill(v->begin(), v->end(), 0.0);
    ll = 0.0;
  }
};

// Per view, float holds the sums of at most this many pixels' responsibilities before they go
// to double.
constexpr std::size_t kViewFlush = 32;

// The block's accumulators (float) into the chunk's statistics (double): sum q, and with the
// pixel's distances dx, dy (stride each) the spatial sums.
[[gnu::always_inline]] inline void add_block_statistics(const Tables& t, const double* dx,
                                                        const double* dy, const Workspace& w,
                                                        ChunkStats& cs) {
  const std::size_t st = t.stride;
  for (std::size_t m = 0; m < st; ++m) {
    const double q = double(w.a0[m]);
    cs.q[m] += q;
    cs.xy[m] += q * dx[m];
    cs.xy[st + m] += q * dx[m] * dx[m];
    cs.xy[2 * st + m] += q * dy[m];
    cs.xy[3 * st + m] += q * dy[m] * dy[m];
  }
  for (std::size_t k = 0; k < 3 * st; ++k) {
    cs.c1[k] += double(w.a1[k]);
    cs.c2[k] += double(w.a2[k]);
  }
}

// The per-view sums of the workspace (float) into the chunk's (double), and cleared.
void flush_views(Workspace& w, ChunkStats& cs) {
  for (std::size_t k = 0; k < w.qv.size(); ++k) cs.qv[k] += double(w.qv[k]);
  std::fill(w.qv.begin(), w.qv.end(), 0.0f);
}

// The pixels of chunk c of light l: one (pixel, light) block each. Adds the sum of their
// samples' terms of L to cs.ll; with `stats`, folds the responsibilities into cs.
void chunk_pass(const SampleSet& s, const Tables& t, const std::vector<std::uint8_t>& order,
                std::size_t l, std::size_t c, Workspace& w, bool stats, ChunkStats& cs) {
  const std::size_t pixels = s.pixels(), st = t.stride, width = std::size_t(s.width);
  const std::size_t first = c * pixels / kChunks, last = (c + 1) * pixels / kChunks;
  if (stats) std::fill(w.qv.begin(), w.qv.end(), 0.0f);
  for (std::size_t p = first; p < last; ++p) {
    block_pass(s, t, order, p, l, w, stats, cs.ll);
    if (!stats) continue;
    add_block_statistics(t, &t.dx[(p % width) * st], &t.dy[(p / width) * st], w, cs);
    if ((p - first + 1) % kViewFlush == 0 || p + 1 == last) flush_views(w, cs);
  }
}

// What one light contributes to the sufficient statistics of the M-step, from its chunks'
// (reduced in chunk order): kLightValues numbers, L's terms first, then per component (in the
// mixture's order) sum q, the nine sums of q (x - mu_old) and the nine of q (x - mu_old)^2
// (x, y as accumulated; the angles from this light and the views; the colours as accumulated).
constexpr std::size_t kPerComponent = 1 + 2 * kVariables;
// `qv`: the chunks' per-view sums, already reduced (sum_views).
std::vector<double> light_statistics(const SampleSet& s, const Tables& t, const ProductMixture& mix,
                                     std::size_t l, const std::vector<ChunkStats>& chunks,
                                     const std::vector<double>& qv) {
  const std::size_t st = t.stride;
  ChunkStats sum(0, st);
  sum.qv = qv;
  for (const ChunkStats& c : chunks) {
    for (std::size_t k = 0; k < st; ++k) sum.q[k] += c.q[k];
    for (std::size_t k = 0; k < sum.xy.size(); ++k) sum.xy[k] += c.xy[k];
    for (std::size_t k = 0; k < sum.c1.size(); ++k) sum.c1[k] += c.c1[k];
    for (std::size_t k = 0; k < sum.c2.size(); ++k) sum.c2[k] += c.c2[k];
    sum.ll += c.ll;
  }
  std::vector<double> out(1 + t.m * kPerComponent, 0.0);
  out[0] = sum.ll;
  const detail::Periods periods = tile_periods(s);
  for (std::size_t k = 0; k < t.m; ++k) {
    const std::size_t m = t.order[k];  // table column k holds component m
    double* o = &out[1 + m * kPerComponent];
    double* s1 = o + 1;
    double* s2 = o + 1 + kVariables;
    const auto& mu = mix.mean[m];
    auto add = [&](int n, double q, double x) {
      const double d = detail::wrapped_difference(x - mu[n], periods[std::size_t(n)]);
      s1[n] += q * d;
      s2[n] += q * d * d;
    };
    o[0] = sum.q[k];
    s1[0] = sum.xy[k];
    s2[0] = sum.xy[st + k];
    s1[1] = sum.xy[2 * st + k];
    s2[1] = sum.xy[3 * st + k];
    add(2, sum.q[k], s.light_ab[l][0]);
    add(3, sum.q[k], s.light_ab[l][1]);
    for (std::size_t v = 0; v < s.views; ++v) {
      add(4, sum.qv[v * st + k], s.view_ab[v][0]);
      add(5, sum.qv[v * st + k], s.view_ab[v][1]);
    }
    for (int c = 0; c < 3; ++c) {
      s1[6 + c] = sum.c1[std::size_t(c) * st + k];
      s2[6 + c] = sum.c2[std::size_t(c) * st + k];
    }
  }
  return out;
}

// The chunks' per-view sums reduced in chunk order into qv, shared among the threads of the
// E pass (an orphaned worksharing loop: called by every thread of its parallel region).
void sum_views(const std::vector<ChunkStats>& chunks, std::vector<double>& qv) {
  const auto n = std::ptrdiff_t(qv.size());
#pragma omp for schedule(static)
  for (std::ptrdiff_t k = 0; k < n; ++k) {
    double a = 0.0;
    for (const ChunkStats& c : chunks) a += c.qv[std::size_t(k)];
    qv[std::size_t(k)] = a;
  }
}

// One E pass, Eq. (2)-(4), over the lights this process holds, light by light, each in
// kChunks chunks of pixels: returns each light's statistics (light_statistics; with `stats`
// false, L's terms alone). Accumulation: float within a (pixel, light) block of nv samples
// (and per view over kViewFlush pixels), double beyond, in a fixed order per chunk and light,
// so the result depends on neither the threads nor the processes.
std::vector<std::vector<double>> e_pass(const SampleSet& s, const Tables& t,
                                        const ProductMixture& mix,
                                        const std::vector<std::uint8_t>& order, int threads,
                                        bool stats) {
  std::vector<std::vector<double>> lights;
  std::vector<ChunkStats> chunks(kChunks, ChunkStats(stats ? s.views : 0, stats ? t.stride : 0));
  std::vector<double> qv(stats ? s.views * t.stride : 0);
  std::exception_ptr failure;
  std::atomic<bool> failed{false};
#pragma omp parallel num_threads(threads)
  {
    const detail::FlushDenormals flush;
    Workspace w(t.stride, s.views, kGroup);
    for (std::size_t l = s.first_light; l < s.light_end(); ++l) {
#pragma omp for schedule(dynamic, 1)
      for (std::size_t c = 0; c < kChunks; ++c) {
        if (failed.load()) continue;
        try {
          chunks[c].clear();
          chunk_pass(s, t, order, l, c, w, stats, chunks[c]);
        } catch (...) {
#pragma omp critical(btfgmm_em_failure)
          if (!failure) failure = std::current_exception();
          failed = true;
        }
      }
      if (stats) sum_views(chunks, qv);
#pragma omp single
      {
        if (failed.load()) {
        } else if (stats) {
          lights.push_back(light_statistics(s, t, mix, l, chunks, qv));
        } else {
          double ll = 0.0;
          for (const ChunkStats& c : chunks) ll += c.ll;
          lights.push_back({ll});
        }
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  return lights;
}

// The statistics of every light, from every process, added in light order: L of Eq. (3) and
// the sufficient statistics of the M-step (mixture_internal.hpp).
struct Combined {
  double log_likelihood = 0.0;
  detail::SufficientStatistics ss;
  explicit Combined(std::size_t m) : ss(m) {}
};

Combined combine(const SampleSet& s, std::size_t m_count, bool stats,
                 const std::vector<std::vector<double>>& mine) {
  std::vector<double> flat;
  for (const auto& l : mine) flat.insert(flat.end(), l.begin(), l.end());
  SingleProcess alone;
  Communicator& processes = s.processes ? *s.processes : alone;
  const auto all = all_gather_values<double>(processes, std::span<const double>(flat));
  const std::size_t per = stats ? 1 + m_count * kPerComponent : 1;
  Combined out(m_count);
  for (const std::vector<double>& r : all) {  // processes in order hold the lights in order
    for (std::size_t at = 0; at + per <= r.size(); at += per) {
      out.log_likelihood += r[at];
      if (!stats) continue;
      for (std::size_t m = 0; m < m_count; ++m) {
        const double* o = &r[at + 1 + m * kPerComponent];
        out.ss.s0[m] += o[0];
        for (std::size_t n = 0; n < std::size_t(kVariables); ++n) {
          out.ss.s1[m][n] += o[1 + n];
          out.ss.s2[m][n] += o[1 + kVariables + n];
        }
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
double log_likelihood_of(const SampleSet& s, const ProductMixture& mix,
                         const std::vector<std::uint8_t>& order, int threads) {
  const Tables t = make_tables(s, mix);
  return combine(s, mix.size(), false, e_pass(s, t, mix, order, threads, false)).log_likelihood /
         double(s.size());
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
    // Eq. (3)-(4) over this process's lights; every process's statistics added in light
    // order.
    const Combined c = combine(s, mix.size(), true, e_pass(s, t, mix, order, threads, true));
    // M-step, Eq. (5)-(7).
    result.dropped += detail::m_step(mix, c.ss, double(s.size()), config.variance_floor,
                                     config.min_component_samples, tile_periods(s));
    // Stop test: the gain of L (record_iteration), or a stop from outside (the state so far,
    // to resume from).
    detail::record_iteration(result, c.log_likelihood / double(s.size()), it, config, mix.size(),
                             t0, progress);
    if (after_iteration) after_iteration(mix, result);
    if (asked_to_stop(s, config) && it < config.max_iterations && !result.converged) {
      result.interrupted = true;
      return result;
    }
  }
  result.final_log_likelihood = config.final_log_likelihood
                                    ? log_likelihood_of(s, mix, order, threads)
                                    : std::numeric_limits<double>::quiet_NaN();
  return result;
}

double mean_log_likelihood(const SampleSet& s, const ProductMixture& mix, int threads) {
  EmConfig c;
  c.threads = threads;
  detail::check_em_input(s.size(), mix, c);
  return log_likelihood_of(s, mix, view_order(s), resolve_threads(threads));
}

}  // namespace btfgmm
