// The E pass of a group of samples with AVX-512 intrinsics (em.cpp's group_pass, the same
// arithmetic): the compiler does not keep the per-vector skip test and the running sums in
// registers on its own. Included by em.cpp and predict.cpp only where __AVX512F__ is defined.
#pragma once

// GCC 12's AVX-512 headers trip -Wmaybe-uninitialized on their own _mm512_undefined_ps.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace btfgmm::detail {

// fast_exp (fast_exp.hpp) on 16 lanes: the same reduction and polynomial, 2^n by scalef.
inline __m512 fast_exp16(__m512 x) {
  const __m512 lo = _mm512_set1_ps(-87.3f), hi = _mm512_set1_ps(88.0f);
  const __mmask16 under = _mm512_cmp_ps_mask(x, lo, _CMP_LT_OQ);
  x = _mm512_min_ps(_mm512_max_ps(x, lo), hi);
  const __m512 n = _mm512_roundscale_ps(_mm512_mul_ps(x, _mm512_set1_ps(1.44269504088896341f)),
                                        _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  __m512 r = _mm512_fnmadd_ps(n, _mm512_set1_ps(0.693359375f), x);
  r = _mm512_fnmadd_ps(n, _mm512_set1_ps(-2.12194440e-4f), r);
  __m512 p = _mm512_set1_ps(1.9875691500e-4f);
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(1.3981999507e-3f));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(8.3334519073e-3f));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(4.1665795894e-2f));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(1.6666665459e-1f));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(5.0000001201e-1f));
  p = _mm512_fmadd_ps(p, _mm512_mul_ps(r, r), r);
  p = _mm512_add_ps(p, _mm512_set1_ps(1.0f));
  return _mm512_maskz_mov_ps(static_cast<__mmask16>(~under), _mm512_scalef_ps(p, n));
}

// Horizontal max and sum by halving (GCC 12's _mm512_reduce_* trip -Wuninitialized).
inline __m128 fold_to_128(__m512 v, bool max) {
  const __m256 lo = _mm512_castps512_ps256(v);
  const __m256 hi = _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1));
  const __m256 a = max ? _mm256_max_ps(lo, hi) : _mm256_add_ps(lo, hi);
  const __m128 l = _mm256_castps256_ps128(a), h = _mm256_extractf128_ps(a, 1);
  return max ? _mm_max_ps(l, h) : _mm_add_ps(l, h);
}
inline float hmax16(__m512 v) {
  __m128 b = fold_to_128(v, true);
  b = _mm_max_ps(b, _mm_movehl_ps(b, b));
  b = _mm_max_ss(b, _mm_movehdup_ps(b));
  return _mm_cvtss_f32(b);
}
inline float hsum16(__m512 v) {
  __m128 b = fold_to_128(v, false);
  b = _mm_add_ps(b, _mm_movehl_ps(b, b));
  b = _mm_add_ss(b, _mm_movehdup_ps(b));
  return _mm_cvtss_f32(b);
}

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

// G (1 to 4) samples of one (pixel, light) block: Eq. (3)-(4) for each, and with `stats` the
// responsibilities folded into the block's accumulators at once. sl: the block's S + L row;
// mu, h: the colour means and -1/(2 sigma^2), 3 rows of st; vrow_in[g]: the view table rows;
// r[g]: the residual colours; tt: G x st scratch; live: scratch of st / 16 indices; margin:
// the skip margin; a0 (st), a1, a2 (3 st): sum q, sum q d, sum q d^2 (d = colour - mean);
// qv_in[g] (st each): sum q per view; cb: the chunk bound (cb.v_max[g] the views' rows).
// Returns the sum of the G samples' log-likelihoods. The G samples share every load of a
// component's parameters.
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
  // log w_m F(x | m) of the chunk at o for the four samples, into tt and out.
  auto densities = [&](std::size_t o, __m512 out[G]) {
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
  };
  // Bound pass: per sample g an upper bound ub_g[j] of its log densities in chunk j
  // (ChunkBound), vectorised over 16 chunks at a time; ub_4[j] = max_g ub_g[j].
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
  // A lower bound of each sample's maximum: the densities of the chunk with the largest bound.
  const float top = hmax16(best);
  std::size_t first = 0;
  while (first + 1 < chunks && cb.ub[4 * pc + first] != top) ++first;
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
  // log w_m F(x | m) of the other candidates, and each sample's maximum.
  for (std::size_t i = 0; i < n_cand; ++i) {
    if (cb.candidates[i] == first) continue;
    __m512 x[G];
    densities(std::size_t(cb.candidates[i]) * 16, x);
    for (int g = 0; g < G; ++g) mxv[g] = _mm512_max_ps(mxv[g], x[g]);
  }
  float mx[G];
  __m512 mxb[G], thr[G], sum[G];
  for (int g = 0; g < G; ++g) {
    mx[g] = hmax16(mxv[g]);
    mxb[g] = _mm512_set1_ps(mx[g]);
    thr[g] = _mm512_set1_ps(mx[g] - margin);
    sum[g] = _mm512_setzero_ps();
  }
  // The vectors where any of the four samples has a responsibility above e^-margin, as a
  // list (no data-dependent branch per vector below); the others are skipped here and below
  // (their tt is left as it was).
  std::size_t n_live = 0;
  for (std::size_t i = 0; i < n_cand; ++i) {
    const std::uint32_t j = cb.candidates[i];
    const std::size_t o = std::size_t(j) * 16;
    __mmask16 any = 0;
    for (int g = 0; g < G; ++g)
      any |= _mm512_cmp_ps_mask(_mm512_loadu_ps(tt + std::size_t(g) * st + o), thr[g], _CMP_GE_OQ);
    live[n_live] = j;
    n_live += any != 0;
  }
  // exp(t - max) on the live vectors.
  for (std::size_t i = 0; i < n_live; ++i) {
    const std::size_t o = std::size_t(live[i]) * 16;
    for (int g = 0; g < G; ++g) {
      float* p = tt + std::size_t(g) * st + o;
      const __m512 e = fast_exp16(_mm512_sub_ps(_mm512_loadu_ps(p), mxb[g]));
      _mm512_storeu_ps(p, e);
      sum[g] = _mm512_add_ps(sum[g], e);
    }
  }
  double ll = 0.0;
  __m512 inv[G];
  for (int g = 0; g < G; ++g) {
    const float s = hsum16(sum[g]);
    ll += double(mx[g]) + std::log(double(s));
    inv[g] = _mm512_set1_ps(1.0f / s);
  }
  if (!stats) return ll;
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
  return ll;
}

}  // namespace btfgmm::detail

#pragma GCC diagnostic pop
