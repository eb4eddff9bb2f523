// What one light contributes to the sufficient statistics of the M-step, Eq. (5)-(7), from
// its sums per table column: one function for the E pass on the CPU (em.cpp) and on a compute
// device (em_gpu.cpp), which sum the same numbers in other orders.
#pragma once

#include <cstddef>
#include <vector>

#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/samples.hpp"
#include "model/em_group_pass.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {

// Per component: sum q, the nine sums of q (x - mu_old), the nine of q (x - mu_old)^2.
constexpr std::size_t kPerComponent = 1 + 2 * kVariables;

// One light's sums over its samples, each row `stride` numbers, one per table column: sum q
// (q); sum q dx, q dx^2, q dy, q dy^2 (xy, 4 rows; dx, dy the pixel's minimum-image distance
// to the component's mean); of the view angles alpha_v, beta_v sum q d, q d^2 (views, 4 rows,
// d = angle - mean); of the colours sum q d (c1, 3 rows) and q d^2 (c2, 3 rows); and the
// light's samples' terms of L, Eq. (3) (ll).
struct ColumnSums {
  double ll = 0.0;
  const double* q = nullptr;
  const double* xy = nullptr;
  const double* views = nullptr;
  const double* c1 = nullptr;
  const double* c2 = nullptr;
};

// The light's kLightValues numbers, L's terms first, then kPerComponent per component in the
// mixture's order (table column k holds component t.order[k]); the light's own angles
// (alpha_i, beta_i) are added here, from sum q.
std::vector<double> light_statistics(const SampleSet& s, const Tables& t, const ProductMixture& mix,
                                     std::size_t l, const ColumnSums& sums, const Periods& periods);

}  // namespace btfgmm::detail
