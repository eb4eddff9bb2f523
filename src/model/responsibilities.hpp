// The E step of EM, Eq. (2)-(4) of the paper (docs/ALGORITHM.md): the log density of a
// component and the responsibilities, in the one place both EM paths take them from.
//
// The responsibilities (Eq. 4),
//   q_m(x) = w_m F(x | m) / sum_j w_j F(x | j),
// are computed in the log domain by log-sum-exp: with l_m = log w_m F(x | m) and
// top = max_m l_m, q_m = e^(l_m - top) / sum_j e^(l_j - top), and the sample's term of L
// (Eq. 3) is log sum_j w_j F(x | j) = top + log sum_j e^(l_j - top).
//
// The same Eq. (4) comes in three forms, one per caller:
//   responsibilities (double)    the reference EM (em_reference.cpp), std::exp;
//   responsibilities (float row) the grid path's group pass (em_group_pass.hpp, group_pass),
//                                fast_exp, components in vectors of kLanes, vectors whose
//                                responsibilities are all below e^-margin skipped;
//   responsibilities16           the same on 16 lanes for the AVX-512 group pass
//                                (group_pass_avx512), G samples at once.
// The grid forms leave q_m as e^(l_m - top) and return 1 / sum beside: the fold into the
// statistics multiplies (q_m = e^(l_m - top) * inv) where it reads them.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <span>

#include "btfgmm/model/mixture.hpp"
#include "core/fast_exp.hpp"
#include "model/mixture_internal.hpp"
#if defined(__AVX512F__)
#include "model/em_avx512.hpp"
#endif

namespace btfgmm::detail {

// The grid path pads the components to a multiple of kLanes: one vector of floats.
constexpr std::size_t kLanes = 16;

// Eq. (2) in the log domain, log w_m F(x | m) = log w_m - (K/2) log(2 pi)
//   + sum_n [ -(x_n - mu_mn)^2 / (2 sigma_mn^2) - (1/2) log sigma_mn^2 ],
// in its pieces: the grid path tabulates the terms of the variables apart (em.cpp, make_tables).

// log w_m - (K/2) log(2 pi): the part of Eq. (2) that depends on no variable.
inline double log_weight_and_norm(double weight) {
  return std::log(weight) - 0.5 * kVariables * std::log(2.0 * std::numbers::pi);
}

// The part of log w_m F(x | m) that depends on no value of x: log w_m - (K/2) log(2 pi)
// - (1/2) sum_n log sigma_mn^2 (the grid path's tables start from it).
inline double log_density_constant(const ProductMixture& mix, std::size_t m) {
  double b = log_weight_and_norm(mix.weight[m]);
  for (int n = 0; n < kVariables; ++n) b -= 0.5 * std::log(mix.var[m][n]);
  return b;
}

// log w_m F(x | m), Eq. (2) in the log domain, of the sample x (9 values; x and y wrap with
// their periods, mixture_internal.hpp).
inline double log_weighted_density(const ProductMixture& mix, std::size_t m, const double* x,
                                   const Periods& periods) {
  double l = log_weight_and_norm(mix.weight[m]);
  for (int n = 0; n < kVariables; ++n)
    l += gauss_exponent(x[n], mix.mean[m][n], mix.var[m][n], periods[std::size_t(n)]) -
         0.5 * std::log(mix.var[m][n]);
  return l;
}

// Eq. (4) for one sample: `log_density` holds l_m = log w_m F(x | m) of every component;
// `q` (as long) receives the responsibilities q_m. Returns the sample's term of L, Eq. (3).
inline double responsibilities(std::span<const double> log_density, std::span<double> q) {
  const double top = *std::max_element(log_density.begin(), log_density.end());
  double sum = 0.0;
  for (std::size_t m = 0; m < log_density.size(); ++m)
    sum += (q[m] = std::exp(log_density[m] - top));
  for (std::size_t m = 0; m < log_density.size(); ++m) q[m] /= sum;
  return top + std::log(sum);
}

// Eq. (4) for one sample of the grid path, in float: x holds l_m of the padded components,
// `chunks` vectors of kLanes, `top` their maximum; only the vectors j with live[j] count (the
// others hold responsibilities below e^-margin and are left as they are). On return x holds
// e^(l_m - top) on the live vectors and `inv` the reciprocal of their sum: q_m = x_m * inv.
// Returns the sample's term of L, Eq. (3).
[[gnu::always_inline]] inline double responsibilities(float* __restrict x, std::size_t chunks,
                                                      const std::uint8_t* __restrict live,
                                                      float top, float& inv) {
  float sum = 0.0f;
  for (std::size_t j = 0; j < chunks; ++j) {
    if (!live[j]) continue;
#pragma omp simd reduction(+ : sum)
    for (std::size_t m = j * kLanes; m < (j + 1) * kLanes; ++m)
      sum += (x[m] = fast_exp(x[m] - top));
  }
  inv = 1.0f / sum;
  return double(top) + std::log(double(sum));
}

#if defined(__AVX512F__)
// Eq. (4) for G samples on 16 lanes: the float form above (fast_exp16 is fast_exp on 16 lanes)
// for the AVX-512 group pass. Sample g's l_m are the row tt + g st, mx[g] their maximum; only
// the n_live vectors listed in `live` (component offsets / 16) count. On return those hold
// e^(l_m - mx[g]) and inv[g] the reciprocal of their sum: q_m = tt_m * inv[g]. Returns the sum
// of the G samples' terms of L, Eq. (3).
template <int G>
[[gnu::always_inline]] inline double responsibilities16(float* tt, std::size_t st,
                                                        const std::uint32_t* live,
                                                        std::size_t n_live, const float mx[G],
                                                        __m512 inv[G]) {
  __m512 mxb[G], sum[G];
  for (int g = 0; g < G; ++g) {
    mxb[g] = _mm512_set1_ps(mx[g]);
    sum[g] = _mm512_setzero_ps();
  }
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
  for (int g = 0; g < G; ++g) {
    const float s = hsum16(sum[g]);
    ll += double(mx[g]) + std::log(double(s));
    inv[g] = _mm512_set1_ps(1.0f / s);
  }
  return ll;
}
#endif

}  // namespace btfgmm::detail
