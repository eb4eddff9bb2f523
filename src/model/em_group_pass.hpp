// The E pass of one group of samples on the grid path (em.cpp; docs/ALGORITHM.md, "The grid
// path"): G samples of one (pixel, light) block, G of its views, share every load of a
// component's parameters. In stages:
//   densities         log w_m F(x | m), Eq. (2): the block's S + L row and the view's row of
//                     the tables, and the colour terms of the sample;
//   maxima and skip   each sample's maximum, and the vectors of kLanes components in which
//                     some sample has a responsibility above e^-margin (the others skipped);
//   responsibilities  Eq. (4) and the samples' terms of L, Eq. (3) (responsibilities.hpp);
//   fold              with `stats`, the responsibilities folded into the block's accumulators
//                     at once: a0 += sum q, a1 += sum q d, a2 += sum q d^2 (d = colour -
//                     mean), qv[view] += q.
// Two implementations of the same arithmetic: group_pass, vectorised by the compiler, and
// group_pass_avx512, in intrinsics (the compiler does not keep the per-vector skip test and
// the running sums in registers on its own), which also bounds each vector's densities before
// computing them (ChunkBound). Where __AVX512F__ is defined, e_pass runs the second only.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "btfgmm/model/samples.hpp"
#include "model/responsibilities.hpp"
#if defined(__AVX512F__)
#include "model/em_avx512.hpp"
#endif

namespace btfgmm::detail {

// Components are padded to a multiple of kLanes with entries whose log density is -1e30 (their
// exp is exactly 0), so every loop over components runs whole vectors.
constexpr float kAbsent = -1e30f;
// Views per group.
constexpr int kGroup = 4;

// The tables of one iteration (em.cpp, make_tables).
struct Tables {
  std::size_t m = 0, stride = 0;            // components, padded count
  std::vector<std::size_t> order;           // table column k holds component order[k]
  float skip_margin = 0;                    // Delta of the vector skip (group_pass)
  std::vector<float> s, l, v;               // P x stride, ni x stride, nv x stride
  std::vector<float> mu, neg_half_inv_var;  // 3 x stride each (colour)
  // For the AVX-512 pass's chunk bound (ChunkBound), per chunk of kLanes components, padded to
  // whole vectors of chunks: the largest V of each view, the box of the colour means and the
  // largest -1/(2 sigma^2) of each colour.
  std::size_t padded_chunks = 0;
  std::vector<float> v_max;                         // nv x padded_chunks
  std::array<std::vector<float>, 3> lo, hi, h_max;  // padded_chunks each
  // For the spatial sums: the minimum-image distance of each column x and row y to each
  // component's mean x and y (W x stride, H x stride).
  std::vector<double> dx, dy;
};

// Per-thread work space of the E pass.
struct Workspace {
  std::vector<float> sl, t, a0, a1, a2, qv, cmax;
  std::vector<std::uint8_t> live;
  std::vector<std::uint32_t> live_list;  // the AVX-512 pass's live vectors
  std::vector<float> sl_max, ub;         // its chunk bound: per block, per group
  std::vector<std::uint32_t> candidates;
  std::vector<std::uint32_t> view_list;  // the block's views in processing order
  std::vector<float> residual;           // the block's residual colours, nv x 3
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
        view_list(views),
        residual(views * 3) {}
};

// ---- group_pass: the compiler's vectors ------------------------------------------------------

// log w_m F(x | m), Eq. (2), of every component for the G samples into their rows tt[g]: the
// block's S + L row sl, the views' rows vrow[g], the colour terms of the residuals r[g].
template <int G>
[[gnu::always_inline]] inline void group_densities(const Tables& t, const float* __restrict sl,
                                                   const float (&r)[G][3],
                                                   const float* const (&vrow)[G],
                                                   float* __restrict (&tt)[G]) {
  const std::size_t st = t.stride;
  const float* __restrict mu0 = t.mu.data();
  const float* __restrict mu1 = mu0 + st;
  const float* __restrict mu2 = mu1 + st;
  const float* __restrict h0 = t.neg_half_inv_var.data();
  const float* __restrict h1 = h0 + st;
  const float* __restrict h2 = h1 + st;
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
}

// The maximum of every vector of kLanes components for each sample (cmax, G x chunks), and
// each sample's maximum mx[g].
template <int G>
[[gnu::always_inline]] inline void group_maxima(float* __restrict (&tt)[G], std::size_t chunks,
                                                float* __restrict cmax, float (&mx)[G]) {
  for (int g = 0; g < G; ++g)
    for (std::size_t j = 0; j < chunks; ++j) {
      float cm = -INFINITY;
#pragma omp simd reduction(max : cm)
      for (std::size_t m = j * kLanes; m < (j + 1) * kLanes; ++m)
        cm = tt[g][m] > cm ? tt[g][m] : cm;
      cmax[std::size_t(g) * chunks + j] = cm;
    }
  for (int g = 0; g < G; ++g) {
    mx[g] = -INFINITY;
    for (std::size_t j = 0; j < chunks; ++j)
      mx[g] = std::max(mx[g], cmax[std::size_t(g) * chunks + j]);
  }
}

// A vector of components whose log densities are all below every sample's maximum by more
// than the margin holds only responsibilities below e^-margin (make_tables): live[j] = 0, and
// it is skipped.
template <int G>
[[gnu::always_inline]] inline void live_vectors(const float* __restrict cmax, std::size_t chunks,
                                                const float (&mx)[G], float margin,
                                                std::uint8_t* __restrict live) {
  for (std::size_t j = 0; j < chunks; ++j) {
    bool any = false;
    for (int g = 0; g < G; ++g) any = any || cmax[std::size_t(g) * chunks + j] >= mx[g] - margin;
    live[j] = any;
  }
}

// The fold: the responsibilities q = tt[g] * inv[g] of the live vectors into the block's
// accumulators a0, a1, a2 and the views' rows of qv.
template <int G>
[[gnu::always_inline]] inline void fold_statistics(const Tables& t, const float (&r)[G][3],
                                                   float* __restrict (&tt)[G],
                                                   const float (&inv)[G],
                                                   const std::uint8_t* __restrict live,
                                                   const std::uint32_t* views, Workspace& w) {
  const std::size_t st = t.stride, chunks = st / kLanes;
  const float* __restrict mu0 = t.mu.data();
  const float* __restrict mu1 = mu0 + st;
  const float* __restrict mu2 = mu1 + st;
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
}

// G samples of one (pixel, light) block: the views views[0 .. G - 1], their residual colours
// in w.residual. Eq. (2)-(4) for each sample, and with `stats` the fold. Returns the sum of
// the G samples' terms of L, Eq. (3).
template <int G>
[[gnu::always_inline]] inline double group_pass(const Tables& t, const std::uint32_t* views,
                                                Workspace& w, bool stats) {
  const std::size_t st = t.stride, chunks = st / kLanes;
  float r[G][3];
  const float* vrow[G];
  float* __restrict tt[G];
  for (int g = 0; g < G; ++g) {
    const float* rr = &w.residual[std::size_t(views[g]) * 3];
    r[g][0] = rr[0];
    r[g][1] = rr[1];
    r[g][2] = rr[2];
    vrow[g] = &t.v[std::size_t(views[g]) * st];
    tt[g] = &w.t[std::size_t(g) * st];
  }
  group_densities<G>(t, w.sl.data(), r, vrow, tt);
  float mx[G];
  group_maxima<G>(tt, chunks, w.cmax.data(), mx);
  std::uint8_t* __restrict live = w.live.data();
  live_vectors<G>(w.cmax.data(), chunks, mx, t.skip_margin, live);
  double ll = 0.0;
  float inv[G];
  for (int g = 0; g < G; ++g) ll += responsibilities(tt[g], chunks, live, mx[g], inv[g]);
  if (stats) fold_statistics<G>(t, r, tt, inv, live, views, w);
  return ll;
}

#if defined(__AVX512F__)
// ---- group_pass_avx512: intrinsics -----------------------------------------------------------

// Per vector of 16 components (a chunk), what bounds its log densities over a group of
// samples without computing them: t_k = sl_k + V_k + sum_c h_kc (r_c - mu_kc)^2 with h < 0, so
// t_k <= max(sl) + max(V) + sum_c max(h_c) gap_c^2, gap_c the distance of the colour r_c to the
// chunk's interval [lo_c, hi_c] of means. Arrays of padded_chunks (a multiple of 16) floats;
// padding chunks have sl_max = -inf.
struct ChunkBound {
  std::size_t padded_chunks = 0;
  const float* sl_max = nullptr;  // the block's
  const float* v_max[4] = {};     // the four views'
  const float* lo[3] = {};
  const float* hi[3] = {};
  const float* h_max[3] = {};
  float* ub = nullptr;                  // scratch, 5 x padded_chunks
  std::uint32_t* candidates = nullptr;  // scratch, st / 16
};

// log w_m F(x | m), Eq. (2), of the chunk at o for the G samples, into tt and out: the block's
// S + L row sl, the views' rows vrow[g], the colour terms of the residuals rv[g] with the means
// mu and h = -1/(2 sigma^2) (3 rows of st each).
template <int G>
[[gnu::always_inline]] inline void group_densities16(std::size_t o, std::size_t st, const float* sl,
                                                     const float* mu, const float* h,
                                                     const float* const (&vrow)[G],
                                                     const __m512 (&rv)[G][3], float* tt,
                                                     __m512 out[G]) {
  const __m512 base = _mm512_loadu_ps(sl + o);
  const __m512 m0 = _mm512_loadu_ps(mu + o), m1 = _mm512_loadu_ps(mu + st + o),
               m2 = _mm512_loadu_ps(mu + 2 * st + o);
  const __m512 k0 = _mm512_loadu_ps(h + o), k1 = _mm512_loadu_ps(h + st + o),
               k2 = _mm512_loadu_ps(h + 2 * st + o);
  for (int g = 0; g < G; ++g) {
    const __m512 d0 = _mm512_sub_ps(rv[g][0], m0), d1 = _mm512_sub_ps(rv[g][1], m1),
                 d2 = _mm512_sub_ps(rv[g][2], m2);
    __m512 x = _mm512_add_ps(base, _mm512_loadu_ps(vrow[g] + o));
    x = _mm512_fmadd_ps(_mm512_mul_ps(k0, d0), d0, x);
    x = _mm512_fmadd_ps(_mm512_mul_ps(k1, d1), d1, x);
    x = _mm512_fmadd_ps(_mm512_mul_ps(k2, d2), d2, x);
    _mm512_storeu_ps(tt + std::size_t(g) * st + o, x);
    out[g] = x;
  }
}

// Bound pass: per sample g an upper bound ub_g[j] of its log densities in chunk j (ChunkBound),
// vectorised over 16 chunks at a time, into cb.ub row g; ub_4[j] = max_g ub_g[j] into row 4.
// Returns the largest bound.
template <int G>
[[gnu::always_inline]] inline float chunk_upper_bounds(const ChunkBound& cb,
                                                       const __m512 (&rv)[G][3]) {
  const std::size_t pc = cb.padded_chunks;
  __m512 best = _mm512_set1_ps(-INFINITY);
  for (std::size_t j = 0; j < pc; j += 16) {
    const __m512 slm = _mm512_loadu_ps(cb.sl_max + j);
    __m512 gap2[G][3];
    {
      const __m512 lo0 = _mm512_loadu_ps(cb.lo[0] + j), lo1 = _mm512_loadu_ps(cb.lo[1] + j),
                   lo2 = _mm512_loadu_ps(cb.lo[2] + j), hi0 = _mm512_loadu_ps(cb.hi[0] + j),
                   hi1 = _mm512_loadu_ps(cb.hi[1] + j), hi2 = _mm512_loadu_ps(cb.hi[2] + j);
      const __m512 lo[3] = {lo0, lo1, lo2}, hi[3] = {hi0, hi1, hi2};
      for (int g = 0; g < G; ++g)
        for (int c = 0; c < 3; ++c) {
          const __m512 gap = _mm512_max_ps(
              _mm512_max_ps(_mm512_sub_ps(lo[c], rv[g][c]), _mm512_sub_ps(rv[g][c], hi[c])),
              _mm512_setzero_ps());
          gap2[g][c] = _mm512_mul_ps(gap, gap);
        }
    }
    const __m512 hm0 = _mm512_loadu_ps(cb.h_max[0] + j), hm1 = _mm512_loadu_ps(cb.h_max[1] + j),
                 hm2 = _mm512_loadu_ps(cb.h_max[2] + j);
    __m512 all = _mm512_set1_ps(-INFINITY);
    for (int g = 0; g < G; ++g) {
      __m512 u = _mm512_add_ps(slm, _mm512_loadu_ps(cb.v_max[g] + j));
      u = _mm512_fmadd_ps(hm0, gap2[g][0], u);
      u = _mm512_fmadd_ps(hm1, gap2[g][1], u);
      u = _mm512_fmadd_ps(hm2, gap2[g][2], u);
      _mm512_storeu_ps(cb.ub + std::size_t(g) * pc + j, u);
      all = _mm512_max_ps(all, u);
    }
    _mm512_storeu_ps(cb.ub + 4 * pc + j, all);
    best = _mm512_max_ps(best, all);
  }
  return hmax16(best);
}

// The candidates: the chunks whose bound reaches a sample's cut, and the chunk `first`, as a
// list of chunk indices in cb.candidates. Returns their count.
template <int G>
[[gnu::always_inline]] inline std::size_t candidate_chunks(const ChunkBound& cb, std::size_t chunks,
                                                           const __m512 (&cut)[G],
                                                           std::size_t first) {
  const std::size_t pc = cb.padded_chunks;
  std::size_t n_cand = 0;
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  for (std::size_t j = 0; j < pc; j += 16) {
    __mmask16 any = 0;
    for (int g = 0; g < G; ++g)
      any |=
          _mm512_cmp_ps_mask(_mm512_loadu_ps(cb.ub + std::size_t(g) * pc + j), cut[g], _CMP_GE_OQ);
    if (first >= j && first < j + 16) any |= __mmask16(1u << (first - j));
    if (j + 16 > chunks) any &= __mmask16((1u << (chunks - j)) - 1u);
    const __m512i idx = _mm512_add_epi32(_mm512_set1_epi32(int(j)), lane);
    _mm512_mask_compressstoreu_epi32(cb.candidates + n_cand, any, idx);
    n_cand += std::size_t(__builtin_popcount(unsigned(any)));
  }
  return n_cand;
}

// The vectors among the candidates where any of the G samples has a responsibility above
// e^-margin, as a list in `live` (no data-dependent branch per vector after it); the others
// are skipped from here on (their tt is left as it was). Returns their count.
template <int G>
[[gnu::always_inline]] inline std::size_t live_vectors16(const float* tt, std::size_t st,
                                                         const std::uint32_t* candidates,
                                                         std::size_t n_cand, const float (&mx)[G],
                                                         float margin, std::uint32_t* live) {
  __m512 thr[G];
  for (int g = 0; g < G; ++g) thr[g] = _mm512_set1_ps(mx[g] - margin);
  std::size_t n_live = 0;
  for (std::size_t i = 0; i < n_cand; ++i) {
    const std::uint32_t j = candidates[i];
    const std::size_t o = std::size_t(j) * 16;
    __mmask16 any = 0;
    for (int g = 0; g < G; ++g)
      any |= _mm512_cmp_ps_mask(_mm512_loadu_ps(tt + std::size_t(g) * st + o), thr[g], _CMP_GE_OQ);
    live[n_live] = j;
    n_live += any != 0;
  }
  return n_live;
}

// The fold: the responsibilities q = tt * inv[g] of the live vectors into the block's
// accumulators a0 (st), a1, a2 (3 st) and the views' rows qv[g].
template <int G>
[[gnu::always_inline]] inline void fold_statistics16(std::size_t st, const float* mu,
                                                     const float* tt, const __m512 (&rv)[G][3],
                                                     const __m512 (&inv)[G],
                                                     const std::uint32_t* live, std::size_t n_live,
                                                     float* a0, float* a1, float* a2,
                                                     float* const (&qv)[G]) {
  for (std::size_t i = 0; i < n_live; ++i) {
    const std::size_t o = std::size_t(live[i]) * 16;
    const __m512 m0 = _mm512_loadu_ps(mu + o), m1 = _mm512_loadu_ps(mu + st + o),
                 m2 = _mm512_loadu_ps(mu + 2 * st + o);
    __m512 s0 = _mm512_setzero_ps(), s1a = s0, s1b = s0, s1c = s0, s2a = s0, s2b = s0, s2c = s0;
    for (int g = 0; g < G; ++g) {
      const __m512 q = _mm512_mul_ps(_mm512_loadu_ps(tt + std::size_t(g) * st + o), inv[g]);
      const __m512 d0 = _mm512_sub_ps(rv[g][0], m0), d1 = _mm512_sub_ps(rv[g][1], m1),
                   d2 = _mm512_sub_ps(rv[g][2], m2);
      const __m512 q0 = _mm512_mul_ps(q, d0), q1 = _mm512_mul_ps(q, d1), q2 = _mm512_mul_ps(q, d2);
      s0 = _mm512_add_ps(s0, q);
      s1a = _mm512_add_ps(s1a, q0);
      s1b = _mm512_add_ps(s1b, q1);
      s1c = _mm512_add_ps(s1c, q2);
      s2a = _mm512_fmadd_ps(q0, d0, s2a);
      s2b = _mm512_fmadd_ps(q1, d1, s2b);
      s2c = _mm512_fmadd_ps(q2, d2, s2c);
      _mm512_storeu_ps(qv[g] + o, _mm512_add_ps(_mm512_loadu_ps(qv[g] + o), q));
    }
    auto acc = [](float* p, __m512 v) {
      _mm512_storeu_ps(p, _mm512_add_ps(_mm512_loadu_ps(p), v));
    };
    acc(a0 + o, s0);
    acc(a1 + o, s1a);
    acc(a1 + st + o, s1b);
    acc(a1 + 2 * st + o, s1c);
    acc(a2 + o, s2a);
    acc(a2 + st + o, s2b);
    acc(a2 + 2 * st + o, s2c);
  }
}

// G (1 to 4) samples of one (pixel, light) block: Eq. (2)-(4) for each, and with `stats` the
// fold. sl: the block's S + L row; mu, h: the colour means and -1/(2 sigma^2), 3 rows of st;
// vrow_in[g]: the view table rows; r[g]: the residual colours; tt: G x st scratch; live:
// scratch of st / 16 indices; margin: the skip margin; a0 (st), a1, a2 (3 st): sum q,
// sum q d, sum q d^2 (d = colour - mean); qv_in[g] (st each): sum q per view; cb: the chunk
// bound (cb.v_max[g] the views' rows). Returns the sum of the G samples' terms of L, Eq. (3).
template <int G>
inline double group_pass_avx512(std::size_t st, const float* sl, const float* mu, const float* h,
                                const float* const vrow_in[G], const float r[G][3], float* tt,
                                std::uint32_t* live, float margin, bool stats, float* a0, float* a1,
                                float* a2, float* const qv_in[G], const ChunkBound& cb) {
  const std::size_t chunks = st / 16;
  // Local copies: the stores below could alias the arrays, so the compiler would reload the
  // row pointers from them on every vector.
  const float* vrow[G];
  float* qv[G];
  for (int g = 0; g < G; ++g) {
    vrow[g] = vrow_in[g];
    qv[g] = qv_in[g];
  }
  __m512 rv[G][3];
  __m512 mxv[G];
  for (int g = 0; g < G; ++g) {
    for (int c = 0; c < 3; ++c) rv[g][c] = _mm512_set1_ps(r[g][c]);
    mxv[g] = _mm512_set1_ps(-INFINITY);
  }
  auto densities = [&](std::size_t o, __m512 out[G]) {
    group_densities16<G>(o, st, sl, mu, h, vrow, rv, tt, out);
  };
  const float top = chunk_upper_bounds<G>(cb, rv);
  // A lower bound of each sample's maximum: the densities of the chunk with the largest bound.
  std::size_t first = 0;
  while (first + 1 < chunks && cb.ub[4 * cb.padded_chunks + first] != top) ++first;
  __m512 probe[G];
  densities(first * 16, probe);
  // A chunk whose bounds are below each sample's lower bound by more than the margin holds
  // only densities below each sample's maximum by more than the margin: the exact skip below
  // would drop it, so its densities are not computed at all. The slack covers float rounding
  // of the bound and of the densities.
  __m512 cut[G];
  for (int g = 0; g < G; ++g) {
    mxv[g] = probe[g];
    const float low = hmax16(probe[g]);
    cut[g] = _mm512_set1_ps(low - margin - (1e-3f + 1e-5f * (std::abs(low) + std::abs(top))));
  }
  const std::size_t n_cand = candidate_chunks<G>(cb, chunks, cut, first);
  // log w_m F(x | m) of the other candidates, and each sample's maximum.
  for (std::size_t i = 0; i < n_cand; ++i) {
    if (cb.candidates[i] == first) continue;
    __m512 x[G];
    densities(std::size_t(cb.candidates[i]) * 16, x);
    for (int g = 0; g < G; ++g) mxv[g] = _mm512_max_ps(mxv[g], x[g]);
  }
  float mx[G];
  for (int g = 0; g < G; ++g) mx[g] = hmax16(mxv[g]);
  const std::size_t n_live = live_vectors16<G>(tt, st, cb.candidates, n_cand, mx, margin, live);
  __m512 inv[G];
  const double ll = responsibilities16<G>(tt, st, live, n_live, mx, inv);
  if (stats) fold_statistics16<G>(st, mu, tt, rv, inv, live, n_live, a0, a1, a2, qv);
  return ll;
}

// The block's chunk bound: the largest S + L of each chunk (into w.sl_max) and the tables'
// colour boxes; the views' rows are set per group.
[[gnu::always_inline]] inline ChunkBound block_chunk_bound(const Tables& t, Workspace& w) {
  ChunkBound cb;
  cb.padded_chunks = t.padded_chunks;
  for (std::size_t j = 0; j < t.stride / kLanes; ++j)
    w.sl_max[j] = hmax16(_mm512_loadu_ps(&w.sl[j * kLanes]));
  cb.sl_max = w.sl_max.data();
  for (std::size_t k = 0; k < 3; ++k) {
    cb.lo[k] = t.lo[k].data();
    cb.hi[k] = t.hi[k].data();
    cb.h_max[k] = t.h_max[k].data();
  }
  cb.ub = w.ub.data();
  cb.candidates = w.candidates.data();
  return cb;
}

// The nv views of one (pixel, light) block (their residual colours in w.residual) by
// group_pass_avx512: groups of four views, then the remaining views one at a time. Adds the
// samples' terms of L to ll; returns the number of views done (all).
[[gnu::always_inline]] inline std::size_t block_pass_avx512(const Tables& t, std::size_t nv,
                                                            const std::uint32_t* views,
                                                            Workspace& w, bool stats, double& ll) {
  const std::size_t st = t.stride;
  ChunkBound cb = block_chunk_bound(t, w);
  std::size_t v = 0;
  auto group = [&](auto size) {
    constexpr int G = decltype(size)::value;
    const float* vrow[G];
    float r[G][3];
    float* qv[G];
    for (int g = 0; g < G; ++g) {
      const std::size_t view = views[v + std::size_t(g)];
      vrow[g] = &t.v[view * st];
      const float* rr = &w.residual[view * 3];
      for (int k = 0; k < 3; ++k) r[g][k] = rr[k];
      qv[g] = &w.qv[view * st];
      cb.v_max[g] = &t.v_max[view * t.padded_chunks];
    }
    ll += group_pass_avx512<G>(st, w.sl.data(), t.mu.data(), t.neg_half_inv_var.data(), vrow, r,
                               w.t.data(), w.live_list.data(), t.skip_margin, stats, w.a0.data(),
                               w.a1.data(), w.a2.data(), qv, cb);
    v += std::size_t(G);
  };
  while (v + 4 <= nv) group(std::integral_constant<int, 4>{});
  while (v < nv) group(std::integral_constant<int, 1>{});
  return v;
}
#endif

}  // namespace btfgmm::detail
