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
#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <numbers>
#include <type_traits>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/samples.hpp"
#include "core/fast_exp.hpp"
#include "core/flush_denormals.hpp"
#if defined(__AVX512F__)
#include "model/em_avx512.hpp"
#endif
#include "model/mixture_internal.hpp"

namespace btfgmm {
namespace {

constexpr std::size_t kChunks = 16;

// Components are padded to a multiple of kLanes with entries whose log density is -1e30 (their
// exp is exactly 0), so every loop over components runs whole vectors.
constexpr std::size_t kLanes = 16;
constexpr float kAbsent = -1e30f;

struct Tables {
  std::size_t m = 0, stride = 0;            // components, padded count
  std::vector<std::size_t> order;           // table column k holds component order[k]
  float skip_margin = 0;                    // Delta of the chunk skip (group_pass)
  std::vector<float> s, l, v;               // P x stride, ni x stride, nv x stride
  std::vector<float> mu, neg_half_inv_var;  // 3 x stride each (colour)
  // For the AVX-512 pass's chunk bound (em_avx512.hpp, ChunkBound), per chunk of kLanes
  // components, padded to whole vectors of chunks: the largest V of each view, the box of the
  // colour means and the largest -1/(2 sigma^2) of each colour.
  std::size_t padded_chunks = 0;
  std::vector<float> v_max;                         // nv x padded_chunks
  std::array<std::vector<float>, 3> lo, hi, h_max;  // padded_chunks each
};

// Components grouped into vectors of kLanes whose colour means (r, g, b) lie close together
// (a k-d split, mixture_internal.hpp): a sample's responsibilities concentrate on the
// components whose colour is near its own, so they share few vectors, and the vectors' colour
// boxes are small, which tightens the chunk bound of the AVX-512 pass. The order changes
// nothing but float summation order; it is a function of the parameters alone.
std::vector<std::size_t> block_order(const ProductMixture& mix) {
  return detail::kd_order(mix, {6, 7, 8}, kLanes);
}

Tables make_tables(const SampleSet& s, const ProductMixture& mix) {
  Tables t;
  const std::size_t m_count = t.m = mix.size();
  const std::size_t st = t.stride = (m_count + kLanes - 1) / kLanes * kLanes;
  t.order = block_order(mix);
  // A component whose log density is below the sample's maximum by more than this has
  // q < e^-Delta; all of them together change the sum by less than M e^-Delta = e^-17.5
  // relative, below float's resolution (2^-24 = e^-16.6).
  t.skip_margin = float(std::log(double(m_count)) + 17.5);
  t.s.assign(s.pixels() * st, kAbsent);
  t.l.assign(s.lights * st, 0.0f);
  t.v.assign(s.views * st, 0.0f);
  t.mu.assign(3 * st, 0.0f);
  t.neg_half_inv_var.assign(3 * st, 0.0f);
  std::vector<double> base(m_count);
  for (std::size_t k = 0; k < m_count; ++k) {
    const std::size_t m = t.order[k];
    double b = std::log(mix.weight[m]) - 0.5 * kVariables * std::log(2.0 * std::numbers::pi);
    for (int n = 0; n < kVariables; ++n) b -= 0.5 * std::log(mix.var[m][n]);
    base[k] = b;
    for (int c = 0; c < 3; ++c) {
      t.mu[c * st + k] = float(mix.mean[m][6 + c]);
      t.neg_half_inv_var[c * st + k] = float(-0.5 / mix.var[m][6 + c]);
    }
  }
  auto gauss = [&](std::size_t k, int n, double x) {
    const std::size_t m = t.order[k];
    const double d = x - mix.mean[m][n];
    return -0.5 * d * d / mix.var[m][n];
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
  return t;
}

struct ChunkStats {
  std::vector<double> ql, qv, c1, c2;  // ni x stride, nv x stride, 3 x stride, 3 x stride
};

// Per-thread work space of the E pass.
struct Workspace {
  std::vector<float> sl, t, a0, a1, a2, qv, cmax;
  std::vector<std::uint8_t> live;
  std::vector<std::uint32_t> live_list;  // the AVX-512 pass's live vectors
  std::vector<float> sl_max, ub;         // its chunk bound: per block, per group
  std::vector<std::uint32_t> candidates;
  std::vector<std::uint32_t> view_list;  // the block's views in processing order
  explicit Workspace(std::size_t stride, std::size_t views, int group)
      : sl(stride),
        t(std::size_t(group) * stride),
        a0(stride),
        a1(3 * stride),
        a2(3 * stride),
        qv(views * stride),
        cmax(std::size_t(group) * (stride / kLanes)),
        live(stride / kLanes),
        live_list(stride / kLanes),
        sl_max((stride / kLanes + kLanes - 1) / kLanes * kLanes, -INFINITY),
        ub(5 * sl_max.size()),
        candidates(stride / kLanes),
        view_list(views) {}
};

// G samples of one (pixel, light) block: the views views[0 .. G - 1]. Eq. (3)-(4) for each sample,
// and with `stats` the responsibilities folded into the block's accumulators at once:
// a0 += sum q, a1 += sum q d, a2 += sum q d^2 (d = colour - mean), qv[view] += q. The G samples
// share every load of a component's parameters.
template <int G>
double group_pass(const Tables& t, const SampleSet& s, std::size_t p, std::size_t l,
                  const std::uint32_t* views, Workspace& w, bool stats) {
  const std::size_t st = t.stride;
  const float* __restrict sl = w.sl.data();
  const float* __restrict mu0 = t.mu.data();
  const float* __restrict mu1 = mu0 + st;
  const float* __restrict mu2 = mu1 + st;
  const float* __restrict h0 = t.neg_half_inv_var.data();
  const float* __restrict h1 = h0 + st;
  const float* __restrict h2 = h1 + st;
  float r[G][3];
  const float* vrow[G];
  float* __restrict tt[G];
  for (int g = 0; g < G; ++g) {
    const float* rr = &s.residual[s.index(p, l, views[g]) * 3];
    r[g][0] = rr[0];
    r[g][1] = rr[1];
    r[g][2] = rr[2];
    vrow[g] = &t.v[std::size_t(views[g]) * st];
    tt[g] = &w.t[std::size_t(g) * st];
  }
  // log w_m F(x | m) for the G samples (the per-pixel, per-light and per-view parts from the
  // tables, the colour terms here), with the maximum of every vector of kLanes components.
  const std::size_t chunks = st / kLanes;
#pragma omp simd
  for (std::size_t m = 0; m < st; ++m) {
    const float base = sl[m], m0 = mu0[m], m1 = mu1[m], m2 = mu2[m];
    const float k0 = h0[m], k1 = h1[m], k2 = h2[m];
#pragma GCC unroll 8
    for (int g = 0; g < G; ++g) {
      const float d0 = r[g][0] - m0, d1 = r[g][1] - m1, d2 = r[g][2] - m2;
      tt[g][m] = base + vrow[g][m] + k0 * d0 * d0 + k1 * d1 * d1 + k2 * d2 * d2;
    }
  }
  float* __restrict cmax = w.cmax.data();  // G x chunks
  for (int g = 0; g < G; ++g)
    for (std::size_t j = 0; j < chunks; ++j) {
      float cm = -INFINITY;
#pragma omp simd reduction(max : cm)
      for (std::size_t m = j * kLanes; m < (j + 1) * kLanes; ++m)
        cm = tt[g][m] > cm ? tt[g][m] : cm;
      cmax[std::size_t(g) * chunks + j] = cm;
    }
  float mx[G];
  for (int g = 0; g < G; ++g) {
    mx[g] = -INFINITY;
    for (std::size_t j = 0; j < chunks; ++j)
      mx[g] = std::max(mx[g], cmax[std::size_t(g) * chunks + j]);
  }
  // A vector of components whose log densities are all below every sample's maximum by more
  // than the margin holds only responsibilities below e^-margin (make_tables): skipped.
  std::uint8_t* __restrict live = w.live.data();
  for (std::size_t j = 0; j < chunks; ++j) {
    bool any = false;
    for (int g = 0; g < G; ++g)
      any = any || cmax[std::size_t(g) * chunks + j] >= mx[g] - t.skip_margin;
    live[j] = any;
  }
  // Eq. (4) by log-sum-exp, and Eq. (3).
  double ll = 0.0;
  float inv[G];
  for (int g = 0; g < G; ++g) {
    float* __restrict x = tt[g];
    const float top = mx[g];
    float sum = 0.0f;
    for (std::size_t j = 0; j < chunks; ++j) {
      if (!live[j]) continue;
#pragma omp simd reduction(+ : sum)
      for (std::size_t m = j * kLanes; m < (j + 1) * kLanes; ++m)
        sum += (x[m] = detail::fast_exp(x[m] - top));
    }
    ll += double(top) + std::log(double(sum));
    inv[g] = 1.0f / sum;
  }
  if (!stats) return ll;
  float* __restrict a0 = w.a0.data();
  float* __restrict a1 = w.a1.data();
  float* __restrict a2 = w.a2.data();
  float* __restrict qv[G];
  for (int g = 0; g < G; ++g) qv[g] = &w.qv[std::size_t(views[g]) * st];
  for (std::size_t j = 0; j < chunks; ++j) {
    if (!live[j]) continue;
#pragma omp simd
    for (std::size_t m = j * kLanes; m < (j + 1) * kLanes; ++m) {
      const float m0 = mu0[m], m1 = mu1[m], m2 = mu2[m];
      float s0 = 0, s1a = 0, s1b = 0, s1c = 0, s2a = 0, s2b = 0, s2c = 0;
#pragma GCC unroll 8
      for (int g = 0; g < G; ++g) {
        const float q = tt[g][m] * inv[g];
        const float d0 = r[g][0] - m0, d1 = r[g][1] - m1, d2 = r[g][2] - m2;
        const float q0 = q * d0, q1 = q * d1, q2 = q * d2;
        s0 += q;
        s1a += q0;
        s1b += q1;
        s1c += q2;
        s2a += q0 * d0;
        s2b += q1 * d1;
        s2c += q2 * d2;
        qv[g][m] += q;
      }
      a0[m] += s0;
      a1[m] += s1a;
      a1[st + m] += s1b;
      a1[2 * st + m] += s1c;
      a2[m] += s2a;
      a2[st + m] += s2b;
      a2[2 * st + m] += s2c;
    }
  }
  return ll;
}

constexpr int kGroup = 4;

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
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t i = 0; i < s.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], s.residual[i * 3 + std::size_t(c)]);
      hi[c] = std::max(hi[c], s.residual[i * 3 + std::size_t(c)]);
    }
  const float span[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  std::vector<std::uint8_t> order(s.size());
  const auto n = std::ptrdiff_t(blocks);
#pragma omp parallel
  {
    std::vector<std::pair<std::uint32_t, std::uint8_t>> key(nv);
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      const std::size_t first = std::size_t(b) * nv;
      for (std::size_t v = 0; v < nv; ++v)
        key[v] = {colour_key(&s.residual[(first + v) * 3], lo, span), std::uint8_t(v)};
      std::sort(key.begin(), key.end());
      for (std::size_t v = 0; v < nv; ++v) order[first + v] = key[v].second;
    }
  }
  return order;
}

// One E pass. With `stats`, folds the responsibilities into qp (P x stride) and the chunks.
// Accumulation: float within a (pixel, light) block of nv samples (and per view within a
// pixel's ni blocks), double beyond, in a fixed order per chunk.
double e_pass(const SampleSet& s, const Tables& t, const std::vector<std::uint8_t>& order,
              int threads, std::vector<double>* qp, std::vector<ChunkStats>* stats) {
  const std::size_t st = t.stride, ni = s.lights, nv = s.views, pixels = s.pixels();
  std::vector<double> chunk_ll(kChunks, 0.0);
  std::exception_ptr failure;
  const bool want = stats != nullptr;
#pragma omp parallel num_threads(threads)
  {
    const detail::FlushDenormals flush;
    Workspace w(st, nv, kGroup);
#pragma omp for schedule(dynamic, 1)
    for (std::size_t c = 0; c < kChunks; ++c) {
      try {
        ChunkStats* cs = want ? &(*stats)[c] : nullptr;
        double ll = 0.0;
        for (std::size_t p = c * pixels / kChunks; p < (c + 1) * pixels / kChunks; ++p) {
          if (want) std::fill(w.qv.begin(), w.qv.end(), 0.0f);
          for (std::size_t l = 0; l < ni; ++l) {
            const float* srow = &t.s[p * st];
            const float* lrow = &t.l[l * st];
#pragma omp simd
            for (std::size_t m = 0; m < st; ++m) w.sl[m] = srow[m] + lrow[m];
            if (want) {
              std::fill(w.a0.begin(), w.a0.end(), 0.0f);
              std::fill(w.a1.begin(), w.a1.end(), 0.0f);
              std::fill(w.a2.begin(), w.a2.end(), 0.0f);
            }
            // The block's views in colour order (view_order), or their own.
            std::uint32_t* views = w.view_list.data();
            if (order.empty())
              for (std::size_t v = 0; v < nv; ++v) views[v] = std::uint32_t(v);
            else
              for (std::size_t v = 0; v < nv; ++v) views[v] = order[s.index(p, l, v)];
            std::size_t v = 0;
#if defined(__AVX512F__)
            detail::ChunkBound cb;
            cb.padded_chunks = t.padded_chunks;
            for (std::size_t j = 0; j < st / kLanes; ++j)
              w.sl_max[j] = detail::hmax16(_mm512_loadu_ps(&w.sl[j * kLanes]));
            cb.sl_max = w.sl_max.data();
            for (std::size_t k = 0; k < 3; ++k) {
              cb.lo[k] = t.lo[k].data();
              cb.hi[k] = t.hi[k].data();
              cb.h_max[k] = t.h_max[k].data();
            }
            cb.ub = w.ub.data();
            cb.candidates = w.candidates.data();
            // Groups of four views, then the remaining views one at a time.
            auto group = [&](auto size) {
              constexpr int G = decltype(size)::value;
              const float* vrow[G];
              float r[G][3];
              float* qv[G];
              for (int g = 0; g < G; ++g) {
                const std::size_t view = views[v + std::size_t(g)];
                vrow[g] = &t.v[view * st];
                const float* rr = &s.residual[s.index(p, l, view) * 3];
                for (int k = 0; k < 3; ++k) r[g][k] = rr[k];
                qv[g] = &w.qv[view * st];
                cb.v_max[g] = &t.v_max[view * t.padded_chunks];
              }
              ll += detail::group_pass_avx512<G>(st, w.sl.data(), t.mu.data(),
                                                 t.neg_half_inv_var.data(), vrow, r, w.t.data(),
                                                 w.live_list.data(), t.skip_margin, want,
                                                 w.a0.data(), w.a1.data(), w.a2.data(), qv, cb);
              v += std::size_t(G);
            };
            while (v + 4 <= nv) group(std::integral_constant<int, 4>{});
            while (v < nv) group(std::integral_constant<int, 1>{});
#endif
            for (; v + kGroup <= nv; v += kGroup)
              ll += group_pass<kGroup>(t, s, p, l, views + v, w, want);
            for (; v < nv; ++v) ll += group_pass<1>(t, s, p, l, views + v, w, want);
            if (!want) continue;
            double* qpp = &(*qp)[p * st];
            double* qll = &cs->ql[l * st];
            for (std::size_t m = 0; m < st; ++m) {
              qpp[m] += double(w.a0[m]);
              qll[m] += double(w.a0[m]);
            }
            for (std::size_t k = 0; k < 3 * st; ++k) {
              cs->c1[k] += double(w.a1[k]);
              cs->c2[k] += double(w.a2[k]);
            }
          }
          if (want)
            for (std::size_t k = 0; k < nv * st; ++k) cs->qv[k] += double(w.qv[k]);
        }
        chunk_ll[c] = ll;
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

int resolve_threads(int threads) {
  return threads > 0 ? threads : omp_get_max_threads();
}

}  // namespace

EmResult fit_em(const SampleSet& s, ProductMixture& mix, const EmConfig& config,
                const EmCallback& progress, const EmResult* resume,
                const EmStateCallback& after_iteration) {
  detail::check_em_input(s.size(), mix, config);
  const auto t0 = std::chrono::steady_clock::now();
  const int threads = resolve_threads(config.threads);
  const std::size_t pixels = s.pixels(), ni = s.lights, nv = s.views;
  const std::vector<std::uint8_t> order = view_order(s);
  EmResult result;
  if (resume) {
    result = *resume;
    result.interrupted = false;
  }
  for (int it = result.iterations + 1; it <= config.max_iterations && !result.converged; ++it) {
    const std::size_t m_count = mix.size();
    const Tables t = make_tables(s, mix);
    const std::size_t st = t.stride;
    std::vector<double> qp(pixels * st, 0.0);
    std::vector<ChunkStats> chunks(kChunks);
    for (auto& c : chunks) {
      c.ql.assign(ni * st, 0.0);
      c.qv.assign(nv * st, 0.0);
      c.c1.assign(3 * st, 0.0);
      c.c2.assign(3 * st, 0.0);
    }
    const double ll = e_pass(s, t, order, threads, &qp, &chunks);
    // Reduce the chunks in order.
    std::vector<double> ql(ni * st, 0.0), qv(nv * st, 0.0), c1(3 * st, 0.0), c2(3 * st, 0.0);
    for (const auto& c : chunks) {
      for (std::size_t k = 0; k < ql.size(); ++k) ql[k] += c.ql[k];
      for (std::size_t k = 0; k < qv.size(); ++k) qv[k] += c.qv[k];
      for (std::size_t k = 0; k < c1.size(); ++k) c1[k] += c.c1[k];
      for (std::size_t k = 0; k < c2.size(); ++k) c2[k] += c.c2[k];
    }
    // Sufficient statistics in the form of the reference path: sum q, and the sums of
    // q (x - mu_old), q (x - mu_old)^2 for each variable.
    std::vector<double> s0(m_count, 0.0);
    std::vector<std::array<double, kVariables>> s1(m_count), s2(m_count);
    for (std::size_t k = 0; k < m_count; ++k) {
      const std::size_t m = t.order[k];  // table column k holds component m
      s1[m].fill(0.0);
      s2[m].fill(0.0);
      const auto& mu = mix.mean[m];
      auto add = [&](int n, double q, double x) {
        const double d = x - mu[n];
        s1[m][n] += q * d;
        s2[m][n] += q * d * d;
      };
      for (std::size_t p = 0; p < pixels; ++p) {
        const double q = qp[p * st + k];
        s0[m] += q;
        add(0, q, double(p % std::size_t(s.width)));
        add(1, q, double(p / std::size_t(s.width)));
      }
      for (std::size_t l = 0; l < ni; ++l) {
        add(2, ql[l * st + k], s.light_ab[l][0]);
        add(3, ql[l * st + k], s.light_ab[l][1]);
      }
      for (std::size_t v = 0; v < nv; ++v) {
        add(4, qv[v * st + k], s.view_ab[v][0]);
        add(5, qv[v * st + k], s.view_ab[v][1]);
      }
      for (int c = 0; c < 3; ++c) {
        s1[m][6 + c] = c1[c * st + k];
        s2[m][6 + c] = c2[c * st + k];
      }
    }
    result.dropped += detail::m_step(mix, s0, s1, s2, double(s.size()), config.variance_floor,
                                     config.min_component_samples);
    detail::record_iteration(result, ll, it, config, mix.size(), t0, progress);
    if (after_iteration) after_iteration(mix, result);
    if (config.stop && config.stop->load() && it < config.max_iterations && !result.converged) {
      result.interrupted = true;
      return result;
    }
  }
  result.final_log_likelihood =
      config.final_log_likelihood ? e_pass(s, make_tables(s, mix), order, threads, nullptr, nullptr)
                                  : std::numeric_limits<double>::quiet_NaN();
  return result;
}

double mean_log_likelihood(const SampleSet& s, const ProductMixture& mix, int threads) {
  EmConfig c;
  c.threads = threads;
  detail::check_em_input(s.size(), mix, c);
  return e_pass(s, make_tables(s, mix), view_order(s), resolve_threads(threads), nullptr, nullptr);
}

}  // namespace btfgmm
