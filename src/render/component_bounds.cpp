// The render kernel's culling (docs/RENDERING.md, "The kernel", steps 2): per block of points,
// bounds of every component's log weight (Eq. 9) over the block's box of inputs, and the
// components whose skipping the bounds prove to change no colour by more than the tolerance.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "render/model_kernel.hpp"

namespace btfgmm::detail {

namespace {

// The distance of x from mu on the circle of circumference 1 (the minimum image), for x, mu
// in [0, 1].
inline float circle_distance(float x, float mu) {
  const float a = std::abs(x - mu);
  return std::min(a, 1.0f - a);
}

// The bounds' terms of a wrapped input (x or y as a fraction of the tile, the term in the
// minimum image): over the intervals [a0, b0], [a1, b1] (in [0, 1]), the nearest and the
// farthest distance on the circle from each component's mean. The nearest is 0 inside an
// interval, else the nearer end's; the farthest is 1/2 where the mean's antipode lies inside
// an interval, else the farther end's (the distance from mu grows along an arc up to the
// antipode).
void bound_wrapped_input(const float* __restrict mean, const float* __restrict sc2, float a0,
                         float b0, float a1, float b1, std::size_t M, float* __restrict upper,
                         float* __restrict lower, float* __restrict mag) {
#pragma omp simd
  for (std::size_t j = 0; j < M; ++j) {
    const float mu = mean[j];
    const float anti = mu < 0.5f ? mu + 0.5f : mu - 0.5f;
    const bool in0 = mu >= a0 && mu <= b0, in1 = mu >= a1 && mu <= b1;
    const bool anti_in = (anti >= a0 && anti <= b0) || (anti >= a1 && anti <= b1);
    const float e0 = std::min(circle_distance(a0, mu), circle_distance(b0, mu));
    const float e1 = std::min(circle_distance(a1, mu), circle_distance(b1, mu));
    const float f0 = std::max(circle_distance(a0, mu), circle_distance(b0, mu));
    const float f1 = std::max(circle_distance(a1, mu), circle_distance(b1, mu));
    const float dmin = in0 || in1 ? 0.0f : std::min(e0, e1);
    const float dmax = anti_in ? 0.5f : std::max(f0, f1);
    const float far = dmax * dmax * sc2[j];
    upper[j] -= dmin * dmin * sc2[j];
    lower[j] -= far;
    mag[j] += far;
  }
}

}  // namespace

// Per component, an upper and a lower bound of its log2 weight (Eq. 9, log2 units) over a
// box of inputs: x and y as up to two intervals each, the four angles as intervals.
// Vectorised over the components, one input at a time, in float with a margin for rounding.
void bound_log_weights(const ModelEvaluator::Impl& k, const Intervals& bx, const Intervals& by,
                       const std::array<float, kInputs>& lo, const std::array<float, kInputs>& hi,
                       float* __restrict upper, float* __restrict lower,
                       float* __restrict magnitude) {
  const std::size_t M = k.m;
  for (std::size_t j = 0; j < M; ++j) {
    upper[j] = lower[j] = k.base[j];
    magnitude[j] = 0.0f;
  }
  for (int d = 0; d < kInputs; ++d) {
    Intervals iv;
    if (d == 0) iv = bx;
    if (d == 1) iv = by;
    if (d >= 2) iv.lo[0] = lo[std::size_t(d)], iv.hi[0] = hi[std::size_t(d)];
    const float* __restrict mean = k.mean_f[std::size_t(d)].data();
    const float* __restrict sc2 = k.scale2_f[std::size_t(d)].data();
    const float a0 = iv.lo[0], b0 = iv.hi[0];
    const float a1 = iv.count == 2 ? iv.lo[1] : a0, b1 = iv.count == 2 ? iv.hi[1] : b0;
    float* __restrict mag = magnitude;
    if (d < kWrappedInputs) {
      bound_wrapped_input(mean, sc2, a0, b0, a1, b1, M, upper, lower, mag);
      continue;
    }
#pragma omp simd
    for (std::size_t j = 0; j < M; ++j) {
      const float mu = mean[j];
      const float n0 = std::max(std::max(a0 - mu, mu - b0), 0.0f);
      const float n1 = std::max(std::max(a1 - mu, mu - b1), 0.0f);
      const float f0 = std::max(std::abs(mu - a0), std::abs(mu - b0));
      const float f1 = std::max(std::abs(mu - a1), std::abs(mu - b1));
      const float dmin = std::min(n0, n1), dmax = std::max(f0, f1);
      const float far = dmax * dmax * sc2[j];
      upper[j] -= dmin * dmin * sc2[j];
      lower[j] -= far;
      mag[j] += far;
    }
  }
  // Rounding of the inputs, of these sums and of the kernel's float arithmetic.
  const float* __restrict mag = magnitude;
#pragma omp simd
  for (std::size_t j = 0; j < M; ++j) {
    const float margin = 1e-3f + 4e-6f * (mag[j] + std::abs(k.base[j]));
    upper[j] += margin;
    lower[j] -= margin;
  }
}

// The components a block needs (their indices into `keep`, returning how many), r = the
// largest upper bound kept, and Lmax, a lower bound of every point's largest log2 weight t*:
// the larger of max_m lower_m and, over the points, the smallest of the exact log weights of
// the four components with the largest upper bounds. A component may be skipped while the
// skipped set's sum of 2^(upper_m - Lmax) stays within the budget: its normalised weight at
// any point is below 2^(upper_m - Lmax). The sum is taken a whole log2 unit of
// (Lmax - upper) at a time, from the farthest components in.
std::size_t select_components(const ModelEvaluator::Impl& k, const BlockInputs& in, int n,
                              const float* __restrict upper, const float* __restrict lower,
                              std::uint32_t* __restrict keep, std::int32_t* __restrict bucket,
                              double& r, double& lmax) {
  const std::size_t M = k.m;
  float lm = -std::numeric_limits<float>::infinity(), um = lm;
#pragma omp simd reduction(max : lm, um)
  for (std::size_t j = 0; j < M; ++j) {
    lm = std::max(lm, lower[j]);
    um = std::max(um, upper[j]);
  }
  // The exact log weights, at every point, of the components with the largest upper and
  // lower bounds: the smaller over the points of their larger is a lower bound of t*.
  std::array<std::size_t, 2> best_j{0, 0};
  for (std::size_t j = 0; j < M; ++j)
    if (upper[j] == um) {
      best_j[0] = j;
      break;
    }
  for (std::size_t j = 0; j < M; ++j)
    if (lower[j] == lm) {
      best_j[1] = j;
      break;
    }
  float exact = std::numeric_limits<float>::infinity();
  for (int i = 0; i < n; ++i) {
    float x[kInputs];
    for (int d = 0; d < kInputs; ++d) x[d] = in.x[d][i];
    float best = -std::numeric_limits<float>::infinity();
    for (std::size_t j : best_j)
      best = std::max(best, record_log2_weight<true>(k.record[j].v, x, 0.0f));
    exact = std::min(exact, best);
  }
  lmax = std::max(double(lm), double(exact) - 1e-3 - 4e-6 * std::abs(double(exact)));
  // Buckets of g = Lmax - upper by whole log2 units: -1 for g < 0 (always kept), 63 for
  // everything beyond; a component in bucket b >= 0 has 2^-g <= 2^-b.
  const float lf = float(lmax);
#pragma omp simd
  for (std::size_t j = 0; j < M; ++j) {
    const float g = lf - upper[j];
    bucket[j] = g < 0.0f ? -1 : std::int32_t(std::min(g, 63.0f));
  }
  std::array<std::uint32_t, 65> count{};
  for (std::size_t j = 0; j < M; ++j) ++count[std::size_t(bucket[j] + 1)];
  double used = 0.0;
  int stop = 63;  // buckets above `stop` are skipped
  for (; stop >= 0; --stop) {
    const double mass = double(count[std::size_t(stop + 1)]) * std::exp2(-double(stop));
    if (used + mass > k.budget) break;
    used += mass;
  }
  std::size_t kept = 0;
  float rf = -std::numeric_limits<float>::infinity();
  for (std::size_t j = 0; j < M; ++j) {
    const bool take = bucket[j] <= stop;
    keep[kept] = std::uint32_t(j);
    kept += take;
    rf = std::max(rf, take ? upper[j] : rf);
  }
  r = rf;
  return kept;
}

ImageLists image_records(const ModelEvaluator::Impl& k, const Intervals& bx, const Intervals& by,
                         const std::uint32_t* __restrict keep, std::size_t kept,
                         Record* __restrict local, std::uint32_t* __restrict plain_index,
                         std::uint32_t* __restrict wrapped) {
  ImageLists n;
  const Intervals* box[kWrappedInputs] = {&bx, &by};
  for (std::size_t a = 0; a < kept; ++a) {
    const std::uint32_t j = keep[a];
    float shift[kWrappedInputs] = {};
    bool one_image = true;
    for (int d = 0; d < kWrappedInputs; ++d) {
      const Intervals& iv = *box[d];
      const float mu = k.mean_f[std::size_t(d)][j];  // in [0, 1)
      const float anti = mu < 0.5f ? mu + 0.5f : mu - 0.5f;
      one_image = one_image && iv.count == 1 && !(anti >= iv.lo[0] && anti <= iv.hi[0]);
      // The image of the mean nearest to the box's centre, mu - i: the offset s (mu - i) P.
      shift[d] = std::nearbyint(mu - 0.5f * (iv.lo[0] + iv.hi[0]));
    }
    if (!one_image) {
      wrapped[n.wrapped++] = j;
      continue;
    }
    Record& r = local[n.plain];
    r = k.record[j];
    for (int d = 0; d < kWrappedInputs; ++d) r.v[kInputs + d] -= shift[d] * r.v[d];
    plain_index[n.plain] = std::uint32_t(n.plain);
    ++n.plain;
  }
  return n;
}

}  // namespace btfgmm::detail
