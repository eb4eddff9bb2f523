// The render kernel's pieces shared by model_evaluator.cpp and component_bounds.cpp
// (docs/RENDERING.md, "The kernel"): 16-lane float vectors and a vectorised exp2, a block's
// inputs, the per-component records built from Eq. (9)-(10) (model/conditional.hpp), the sums
// of Eq. (8) over the kept components, and the evaluator's state.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "btfgmm/core/fast_interpolation.hpp"
#include "btfgmm/model/mixture.hpp"
#include "btfgmm/render/model_evaluator.hpp"
#include "model/conditional.hpp"

namespace btfgmm::detail {

constexpr int kMaxBlock = int(ModelEvaluator::kGroup);

// A vector of 16 floats (one AVX-512 register; GCC lowers it to narrower registers where
// the machine has none) and its integer twin.
constexpr int kLanes = 16;
using Vf = float __attribute__((vector_size(64)));
using Vi = std::int32_t __attribute__((vector_size(64)));

inline Vf splat(float v) {
  return Vf{} + v;
}

// 2^x for x <= 0 on 16 lanes: x = n + f, |f| <= 1/2, 2^f by Cephes' exp2f polynomial
// (relative error ~2e-7), 2^n added to the exponent bits. Inputs below -126 give 2^-126.
inline Vf exp2v(Vf x) {
  x = x < splat(-126.0f) ? splat(-126.0f) : x;
  const Vf shifter = splat(12582912.0f);
  const Vf n = (x + shifter) - shifter;
  const Vf f = x - n;
  Vf p = splat(1.535336188319500e-4f);
  p = p * f + 1.339887440266574e-3f;
  p = p * f + 9.618437357674640e-3f;
  p = p * f + 5.550332471162809e-2f;
  p = p * f + 2.402264791363012e-1f;
  p = p * f + 6.931472028550421e-1f;
  p = p * f + 1.0f;
  Vi bits = std::bit_cast<Vi>(p);
  bits += __builtin_convertvector(n, Vi) << 23;
  return std::bit_cast<Vf>(bits);
}

// The inputs 0 and 1, x and y, wrap around the tile: the kernel takes them as fractions of the
// tile's width and height, u = x / W and v = y / H in [0, 1), and their terms in the minimum
// image (log2_marginal_term, wrapped_root in model/conditional.hpp).
constexpr int kWrappedInputs = 2;

// A block's inputs, lane by lane: x[k][i] is input k of point i, padded to whole vectors
// (x and y as fractions of the tile).
struct BlockInputs {
  alignas(64) float x[kInputs][kMaxBlock];
  // The light and view vectors (x, y, z each), for the mean BRDF.
  alignas(64) float dir[6][kMaxBlock];
  // The sums of sum_points, point by point: 2^t and 2^t mu per colour.
  alignas(64) float sum[4][kMaxBlock];
};

// Per component (16 floats, one cache line): per input the scale s and offset s mu (the term
// of Eq. 9 is (x s - s mu)^2 in log2 units; for x and y the scale is S = s W, s H and the
// term is wrapped_root(u S - s mu, S)^2), the log2 base weight, the colour means.
constexpr int kRecord = 16;
struct alignas(64) Record {
  float v[kRecord];
};

inline Vf load(const float* p) {
  Vf v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// Eq. (9)'s exponent in log2 units, less `ref`, at a point (T = float) or a vector of points
// (T = Vf) with inputs x: base - sum_k (x_k s_k - s_k mu_k)^2 from a component's record c. The
// one statement of the kernel's term of Eq. (10), for the sums, the per-point maxima and the
// exact weights of the bounds. `Wrapped`: the terms of x and y in the minimum image
// (wrapped_root); otherwise as they stand, for a record whose offsets already hold the image
// of its mean nearest to every point of the block (image_records).
template <bool Wrapped, class T>
[[gnu::always_inline]] inline T record_log2_weight(const float* __restrict c, const T* x, T ref) {
  T l = c[12] - ref;
  for (int d = 0; d < kInputs; ++d) {
    T e = x[d] * c[d] - c[kInputs + d];
    if constexpr (Wrapped)
      if (d < kWrappedInputs) e = wrapped_root(e, c[d]);
    l -= e * e;
  }
  return l;
}

// The sums of Eq. (8) for a vector of points: 2^t and 2^t mu per colour, lane by lane.
using LaneSums = ConditionalColour<Vf>;

// Over the components `keep[0..na)` of `rec`, for P vectors of points starting at lane vector
// v0: the sums of Eq. (8), 2^(t - ref) and 2^(t - ref) mu, added to `out`, with t = base -
// sum_k (x_k s_k - o_k)^2 Eq. (9)'s exponent in log2 units (the record's terms of Eq. 10,
// record_log2_weight<Wrapped>) and ref the point's reference (at least its largest t, or close
// enough that nothing overflows). Vectorised over the points: every component's parameters
// are broadcast.
template <int P, bool Wrapped>
inline void sum_points(const Record* __restrict rec, const std::uint32_t* __restrict keep,
                       std::size_t na, const BlockInputs& in, int v0, const Vf* ref,
                       LaneSums* out) {
  Vf x[P][kInputs], r[P];
  LaneSums sums[P];
  for (int q = 0; q < P; ++q) {
    for (int d = 0; d < kInputs; ++d) x[q][d] = load(&in.x[d][(v0 + q) * kLanes]);
    r[q] = ref[v0 + q];
    sums[q] = out[q];
  }
  for (std::size_t a = 0; a < na; ++a) {
    const float* c = rec[keep[a]].v;
    for (int q = 0; q < P; ++q)
      sums[q].add(exp2v(record_log2_weight<Wrapped>(c, x[q], r[q])), c[13], c[14], c[15]);
  }
  for (int q = 0; q < P; ++q) out[q] = sums[q];
}

// The largest of `mx` and t over the components `keep[0..na)` of `rec`, per point (for blocks
// whose bounds are too loose for a common reference).
template <bool Wrapped>
inline Vf max_log_weight(const Record* __restrict rec, const std::uint32_t* __restrict keep,
                         std::size_t na, const BlockInputs& in, int v, Vf mx) {
  Vf x[kInputs];
  for (int d = 0; d < kInputs; ++d) x[d] = load(&in.x[d][v * kLanes]);
  for (std::size_t a = 0; a < na; ++a) {
    const Vf l = record_log2_weight<Wrapped>(rec[keep[a]].v, x, Vf{});
    mx = l > mx ? l : mx;
  }
  return mx;
}

// Up to two closed intervals in [0, 1] holding a set of wrapped coordinates (fractions of
// the tile).
struct Intervals {
  float lo[2] = {0, 0}, hi[2] = {0, 0};
  int count = 1;
};

}  // namespace btfgmm::detail

namespace btfgmm {

struct ModelEvaluator::Impl {
  int width = 0, height = 0;
  std::size_t m = 0;
  std::array<double, kVariables> unit{};
  // Per input k and component: s = sqrt(log2(e) / (2 sigma^2)) and s * mu, so that
  // (x s - s mu)^2 is the term of Eq. (10) in log2 units (log2_marginal_term; x and y: S = s W,
  // s H, the inputs fractions of the tile, the term wrapped); base = Eq. (9)'s
  // log_weight_base in log2 units; the colour means of Eq. (8) in model units.
  std::array<std::vector<float>, kInputs> scale, offset;
  std::vector<float> base;
  std::array<std::vector<float>, 3> colour;
  // The same, a record of kRecord floats per component: scale 0-5, offset 6-11, base 12,
  // colour 13-15 (aligned: a record is one cache line).
  std::vector<detail::Record> record;
  // For the bounds: the means and s^2 per input, in the kernel's units (x, y: mu / W and S^2).
  std::array<std::vector<float>, kInputs> mean_f, scale2_f;
  // Skipping: on when tolerance > 0; a skipped set's sum of 2^(U_m - Lmax) may reach
  // budget = tolerance / spread (spread: of the components' colour means, levels).
  bool cull = false;
  double budget = 0.0;
  std::vector<float> mean_brdf;
  std::size_t views = 0;
  FastDirectionInterpolator lights_interp, views_interp;
  // The directions projected on the disk, (x, y) of their unit vectors.
  std::vector<std::array<double, 2>> light_xy, view_xy;

  explicit Impl(const BtfModel& model) : lights_interp(model.lights), views_interp(model.views) {
    for (const Direction& d : model.lights) light_xy.push_back({to_vector(d).x, to_vector(d).y});
    for (const Direction& d : model.views) view_xy.push_back({to_vector(d).x, to_vector(d).y});
  }
};

}  // namespace btfgmm

namespace btfgmm::detail {

// Per component, an upper and a lower bound of its log2 weight (Eq. 9, log2 units) over a
// box of inputs: x and y as up to two intervals each, the four angles as intervals.
// Vectorised over the components, one input at a time, in float with a margin for rounding.
void bound_log_weights(const ModelEvaluator::Impl& k, const Intervals& bx, const Intervals& by,
                       const std::array<float, kInputs>& lo, const std::array<float, kInputs>& hi,
                       float* __restrict upper, float* __restrict lower,
                       float* __restrict magnitude);

// The kept components `keep[0..kept)` of a block with the boxes bx, by of its x and y, in two
// lists: those whose mean's antipode (where the minimum image changes from one image of the
// mean to the next) lies outside both boxes have one image nearest to every point of the
// block, and go to `local` as records whose offsets hold that image (s mu + k S), evaluated as
// they stand (local[0..plain), indexed by plain_index); the others go to `wrapped` (indices
// into the model's records) and take the minimum image point by point. A box that is split
// at the tile's edge or wide sends every component to `wrapped`. Returns the counts.
struct ImageLists {
  std::size_t plain = 0, wrapped = 0;
};
ImageLists image_records(const ModelEvaluator::Impl& k, const Intervals& bx, const Intervals& by,
                         const std::uint32_t* __restrict keep, std::size_t kept,
                         Record* __restrict local, std::uint32_t* __restrict plain_index,
                         std::uint32_t* __restrict wrapped);

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
                              double& r, double& lmax);

}  // namespace btfgmm::detail
