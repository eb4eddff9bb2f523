// The evaluators of the renderer: the model (Eq. 8-11) for many surface points at once, and
// the measured data interpolated over the measured directions; a fast look-up of
// DirectionInterpolator's weights.
//
// The model kernel (docs/RENDERING.md, "The kernel"). For a point with inputs
// x_I = (x, y, alpha_i, beta_i, alpha_v, beta_v) in model units, Eq. (9) gives the log weight
//   t_m = log w_m - 1/2 sum_k log sigma_mk^2 - sum_k (x_k - mu_mk)^2 / (2 sigma_mk^2),
// and the colour is sum_m W_m mu_m,rgb (times the colour unit) plus the mean BRDF (Eq. 11).
// Points come in blocks of up to 256 (a 16 x 16 screen block); per block:
//  1. the box of the block's inputs (x and y as up to two intervals, the tile wraps);
//  2. per component an upper bound U_m and a lower bound L_m of t_m over the box; Lmax, at
//     most every point's largest log weight t*, so a skipped component has a normalised
//     weight below exp(U_m - Lmax); components are skipped while the skipped set's
//     sum of exp(U_m - Lmax) times R, the spread of the components' colour means in levels,
//     stays within the tolerance (select_components);
//  3. each point sums exp(t_m - r) and exp(t_m - r) mu_m over the kept components
//     (r = max_m U_m, an upper bound of every t_m in the block, so no per-point maximum pass
//     is needed while r - Lmax is small; a block where it is not takes the per-point maximum
//     first), vectorised over 16 points at a time: a component's parameters (one 64-byte
//     record) are broadcast, nothing is gathered, no horizontal sums;
//  4. the mean BRDF, interpolated over the measured directions, from the block's first
//     point's light and view triangles for every point well inside both, vectorised.
// Work is in log2 units with a polynomial exp2 (Cephes' exp2f polynomial, relative error
// ~2e-7).
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <numbers>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/render/render.hpp"

namespace btfgmm {
namespace {

constexpr int kMaxBlock = int(ModelEvaluator::kGroup);
// The most pairs of light and view triangles whose affine weights a block's mean BRDF takes
// before the points still left take the exact look-up.
constexpr int kAffineRounds = 4;

// atan2(y, x) for x >= 0 (a result in [-pi/2, pi/2]), vectorisable: the ratio of the
// smaller to the larger magnitude in [0, 1], reduced by tan(pi/8) and Cephes' atanf
// polynomial (absolute error ~2e-7 radians; tests/test_render.cpp measures it).
inline float atan2_right(float y, float x) {
  const float ay = std::abs(y);
  const bool swap = ay > x;
  const float num = swap ? x : ay, den = swap ? ay : x;
  const float t = den > 0.0f ? num / den : 0.0f;
  const bool big = t > 0.41421356237f;
  const float u = big ? (t - 1.0f) / (t + 1.0f) : t;
  const float z = u * u;
  float p = 8.05374449538e-2f;
  p = p * z - 1.38776856032e-1f;
  p = p * z + 1.99777106478e-1f;
  p = p * z - 3.33329491539e-1f;
  float r = p * z * u + u + (big ? 0.78539816339745f : 0.0f);
  r = swap ? 1.57079632679490f - r : r;
  return y < 0.0f ? -r : r;
}

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

// A block's inputs, lane by lane: x[k][i] is input k of point i, padded to whole vectors.
struct BlockInputs {
  alignas(64) float x[kInputs][kMaxBlock];
  // The light and view vectors (x, y, z each), for the mean BRDF.
  alignas(64) float dir[6][kMaxBlock];
  // The sums of sum_points, point by point: 2^t and 2^t mu per colour.
  alignas(64) float sum[4][kMaxBlock];
};

// The barycentric weights of a triangle of directions as affine functions of the projected
// direction (qx, qy): w_i = c[i][0] + c[i][1] qx + c[i][2] qy, the formula of
// DirectionInterpolator rearranged. `ok` is false for a degenerate triangle.
struct AffineTriangle {
  float c[3][3] = {};
  bool ok = false;
};

AffineTriangle affine_triangle(const std::vector<std::array<double, 2>>& xy,
                               const std::array<std::uint32_t, 3>& t) {
  AffineTriangle r;
  if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return r;
  const auto &a = xy[t[0]], &b = xy[t[1]], &c = xy[t[2]];
  const double area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
  if (!(std::abs(area) > 1e-12)) return r;
  const double wa[3] = {b[0] * c[1] - b[1] * c[0], b[1] - c[1], c[0] - b[0]};
  const double wb[3] = {c[0] * a[1] - c[1] * a[0], c[1] - a[1], a[0] - c[0]};
  for (int i = 0; i < 3; ++i) {
    r.c[0][i] = float(wa[i] / area);
    r.c[1][i] = float(wb[i] / area);
    r.c[2][i] = float((i == 0 ? 1.0 : 0.0) - (wa[i] + wb[i]) / area);
  }
  r.ok = true;
  return r;
}

// Per component (16 floats, one cache line): per input the scale s and offset s mu (the term
// of Eq. 9 is (x s - s mu)^2 in log2 units), the log2 base weight, the colour means.
constexpr int kRecord = 16;
struct alignas(64) Record {
  float v[kRecord];
};

inline Vf load(const float* p) {
  Vf v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// The sums of a vector of points: 2^t and 2^t mu per colour.
struct LaneSums {
  Vf sum, c0, c1, c2;
};

// Over the kept components `keep[0..na)`, for P vectors of points starting at lane vector
// v0: the sums of 2^(t - ref) and 2^(t - ref) mu, t = base - sum_k (x_k s_k - o_k)^2, with
// ref the point's reference (at least its largest t, or close enough that nothing
// overflows). Vectorised over the points: every component's parameters are broadcast.
template <int P>
inline void sum_points(const Record* __restrict rec, const std::uint32_t* __restrict keep,
                       std::size_t na, const BlockInputs& in, int v0, const Vf* ref,
                       LaneSums* out) {
  Vf x[P][kInputs], r[P], s[P], c0[P], c1[P], c2[P];
  for (int q = 0; q < P; ++q) {
    for (int d = 0; d < kInputs; ++d) x[q][d] = load(&in.x[d][(v0 + q) * kLanes]);
    r[q] = ref[v0 + q];
    s[q] = c0[q] = c1[q] = c2[q] = Vf{};
  }
  for (std::size_t a = 0; a < na; ++a) {
    const float* c = rec[keep[a]].v;
    for (int q = 0; q < P; ++q) {
      Vf l = c[12] - r[q];
      for (int d = 0; d < kInputs; ++d) {
        const Vf e = x[q][d] * c[d] - c[kInputs + d];
        l -= e * e;
      }
      const Vf w = exp2v(l);
      s[q] += w;
      c0[q] += w * c[13];
      c1[q] += w * c[14];
      c2[q] += w * c[15];
    }
  }
  for (int q = 0; q < P; ++q) out[q] = {s[q], c0[q], c1[q], c2[q]};
}

// The largest t over the kept components, per point (for blocks whose bounds are too loose
// for a common reference).
inline Vf max_log_weight(const Record* __restrict rec, const std::uint32_t* __restrict keep,
                         std::size_t na, const BlockInputs& in, int v) {
  Vf x[kInputs];
  for (int d = 0; d < kInputs; ++d) x[d] = load(&in.x[d][v * kLanes]);
  Vf mx = splat(-std::numeric_limits<float>::infinity());
  for (std::size_t a = 0; a < na; ++a) {
    const float* c = rec[keep[a]].v;
    Vf l = splat(c[12]);
    for (int d = 0; d < kInputs; ++d) {
      const Vf e = x[d] * c[d] - c[kInputs + d];
      l -= e * e;
    }
    mx = l > mx ? l : mx;
  }
  return mx;
}

// x modulo the period, as predict() wraps it (a coordinate already inside is returned as is).
double wrap(double x, int period) {
  if (x >= 0.0 && x < double(period)) return x;
  double r = std::fmod(x, double(period));
  if (r < 0) r += period;
  return r >= period ? 0.0 : r;
}

// Up to two closed intervals in [0, period] holding a set of wrapped coordinates.
struct Intervals {
  float lo[2] = {0, 0}, hi[2] = {0, 0};
  int count = 1;
};

Intervals wrapped_box(const float* v, int n, int stride, int period) {
  const float ref = v[0], half = 0.5f * float(period), per = float(period);
  float dmin = 0, dmax = 0;
  for (int i = 1; i < n; ++i) {
    float d = v[i * stride] - ref;
    if (d > half) d -= per;
    if (d < -half) d += per;
    dmin = std::min(dmin, d);
    dmax = std::max(dmax, d);
  }
  Intervals r;
  const float a = ref + dmin, b = ref + dmax;
  if (b - a >= half) {  // wide: the whole tile
    r.lo[0] = 0;
    r.hi[0] = per;
  } else if (a < 0) {
    r.count = 2;
    r.lo[0] = a + per, r.hi[0] = per;
    r.lo[1] = 0, r.hi[1] = b;
  } else if (b > per) {
    r.count = 2;
    r.lo[0] = a, r.hi[0] = per;
    r.lo[1] = 0, r.hi[1] = b - per;
  } else {
    r.lo[0] = a, r.hi[0] = b;
  }
  return r;
}

}  // namespace

// ---- the fast direction interpolator ------------------------------------------------------

FastDirectionInterpolator::FastDirectionInterpolator(const DirectionSet& set) : slow_(set) {
  for (const Direction& d : set) {
    const Vec3 v = to_vector(d);
    points_.push_back({v.x, v.y});
  }
  triangles_ = slow_.triangles();
  // The boundary edges, in DirectionInterpolator's order (so that ties resolve alike).
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> count;
  for (const auto& t : triangles_)
    for (int e = 0; e < 3; ++e)
      count[{std::min(t[std::size_t(e)], t[std::size_t(e + 1) % 3]),
             std::max(t[std::size_t(e)], t[std::size_t(e + 1) % 3])}]++;
  for (const auto& [edge, n] : count)
    if (n == 1) hull_edges_.push_back({edge.first, edge.second});
  if (triangles_.empty()) return;  // the slow path handles degenerate sets
  grid_ = std::clamp(int(std::sqrt(double(triangles_.size()))) * 2, 4, 256);
  const std::size_t cells = std::size_t(grid_) * std::size_t(grid_);
  std::vector<std::vector<std::uint32_t>> lists(cells);
  const double margin = 1e-9;
  for (std::uint32_t t = 0; t < triangles_.size(); ++t) {
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (std::uint32_t i : triangles_[t]) {
      x0 = std::min(x0, points_[i][0]);
      x1 = std::max(x1, points_[i][0]);
      y0 = std::min(y0, points_[i][1]);
      y1 = std::max(y1, points_[i][1]);
    }
    auto cell = [&](double v) {
      return std::clamp(int(std::floor((v + 1.0) * 0.5 * grid_)), 0, grid_ - 1);
    };
    for (int cy = cell(y0 - margin); cy <= cell(y1 + margin); ++cy)
      for (int cx = cell(x0 - margin); cx <= cell(x1 + margin); ++cx)
        lists[std::size_t(cy) * std::size_t(grid_) + std::size_t(cx)].push_back(t);
  }
  cell_start_.push_back(0);
  for (const auto& l : lists) {
    cell_triangles_.insert(cell_triangles_.end(), l.begin(), l.end());
    cell_start_.push_back(std::uint32_t(cell_triangles_.size()));
  }
}

DirectionInterpolator::Weights FastDirectionInterpolator::weights(const Vec3& v) const {
  std::uint32_t hint = std::numeric_limits<std::uint32_t>::max();
  return weights(v, hint);
}

DirectionInterpolator::Weights FastDirectionInterpolator::weights(const Vec3& v,
                                                                  std::uint32_t& hint) const {
  if (triangles_.empty()) return slow_.weights(v);
  // As DirectionInterpolator: below the horizon, the horizon direction with the same azimuth.
  const double n = std::sqrt(v.x * v.x + v.y * v.y + std::max(v.z, 0.0) * std::max(v.z, 0.0));
  if (!(n > 0.0) || !std::isfinite(n)) return weights_at(0.0, 0.0, &hint);
  return weights_at(v.x / n, v.y / n, &hint);
}

// The arithmetic of DirectionInterpolator::weights_at over the triangles near the query
// (every triangle that could contain it): the same weights, bit for bit. Repeated here rather
// than called: this file is built with other floating-point flags, and calling the other
// file's normalisation instead changed the last bit of some weights (the test asserts equal
// bits). A query well inside
// the hinted triangle (every barycentric weight above 1e-4) lies in no other triangle: that
// triangle is the one the scan would find.
DirectionInterpolator::Weights FastDirectionInterpolator::weights_at(double qx, double qy,
                                                                     std::uint32_t* hint) const {
  DirectionInterpolator::Weights best;
  double best_min = -std::numeric_limits<double>::infinity();
  std::uint32_t best_tri = std::numeric_limits<std::uint32_t>::max();
  const auto try_triangle = [&](std::uint32_t ti) {
    const auto& t = triangles_[ti];
    const auto &a = points_[t[0]], &b = points_[t[1]], &c = points_[t[2]];
    const double area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    const double wa = ((b[0] - qx) * (c[1] - qy) - (b[1] - qy) * (c[0] - qx)) / area;
    const double wb = ((c[0] - qx) * (a[1] - qy) - (c[1] - qy) * (a[0] - qx)) / area;
    const double wc = 1.0 - wa - wb;
    const double m = std::min({wa, wb, wc});
    if (m > best_min) {
      best_min = m;
      best_tri = ti;
      best.index = t;
      best.weight = {wa, wb, wc};
    }
  };
  if (hint && *hint < triangles_.size()) try_triangle(*hint);
  if (!(best_min > 1e-4)) {
    best_min = -std::numeric_limits<double>::infinity();
    best_tri = std::numeric_limits<std::uint32_t>::max();
    const int cx = std::clamp(int(std::floor((qx + 1.0) * 0.5 * grid_)), 0, grid_ - 1);
    const int cy = std::clamp(int(std::floor((qy + 1.0) * 0.5 * grid_)), 0, grid_ - 1);
    const std::size_t cell = std::size_t(cy) * std::size_t(grid_) + std::size_t(cx);
    for (std::uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k)
      try_triangle(cell_triangles_[k]);
  }
  if (hint) *hint = best_tri;
  if (best_min < -1e-12) {
    if (hint) *hint = std::numeric_limits<std::uint32_t>::max();
    double best_d = std::numeric_limits<double>::infinity();
    for (const auto& e : hull_edges_) {
      const auto &a = points_[e[0]], &b = points_[e[1]];
      const double dx = b[0] - a[0], dy = b[1] - a[1], len2 = dx * dx + dy * dy;
      double s = len2 > 0.0 ? ((qx - a[0]) * dx + (qy - a[1]) * dy) / len2 : 0.0;
      s = std::clamp(s, 0.0, 1.0);
      const double px = a[0] + s * dx - qx, py = a[1] + s * dy - qy;
      const double d2 = px * px + py * py;
      if (d2 < best_d) {
        best_d = d2;
        best.index = {e[0], e[1], e[0]};
        best.weight = {1.0 - s, s, 0.0};
      }
    }
  }
  double sum = 0.0;
  for (double& w : best.weight) sum += (w = std::max(w, 0.0));
  for (double& w : best.weight) w /= sum;
  for (int i = 0; i < 3; ++i)
    if (best.weight[std::size_t(i)] > 1.0 - 1e-12) {
      best.weight = {0.0, 0.0, 0.0};
      best.weight[std::size_t(i)] = 1.0;
    }
  return best;
}

// ---- the model ----------------------------------------------------------------------------

struct ModelEvaluator::Impl {
  int width = 0, height = 0;
  std::size_t m = 0;
  std::array<double, kVariables> unit{};
  // Per input k and component: s = sqrt(log2(e) / (2 sigma^2)) and s * mu, so that
  // (x s - s mu)^2 is the term of Eq. (9) in log2 units; base = log2 of w_m over the
  // normalisation; the colour means in model units.
  std::array<std::vector<float>, kInputs> scale, offset;
  std::vector<float> base;
  std::array<std::vector<float>, 3> colour;
  // The same, a record of kRecord floats per component: scale 0-5, offset 6-11, base 12,
  // colour 13-15 (aligned: a record is one cache line).
  std::vector<Record> record;
  // For the bounds: the means and s^2 per input.
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

namespace {

// Per component, an upper and a lower bound of its log2 weight (Eq. 9, log2 units) over a
// box of inputs: x and y as up to two intervals each, the four angles as intervals.
// Vectorised over the components, one input at a time, in float with a margin for rounding.
[[gnu::noinline]] void bound_log_weights(const ModelEvaluator::Impl& k, const Intervals& bx,
                                         const Intervals& by, const std::array<float, kInputs>& lo,
                                         const std::array<float, kInputs>& hi,
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
[[gnu::noinline]] std::size_t select_components(
    const ModelEvaluator::Impl& k, const BlockInputs& in, int n, const float* __restrict upper,
    const float* __restrict lower, std::uint32_t* __restrict keep, std::int32_t* __restrict bucket,
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
    float best = -std::numeric_limits<float>::infinity();
    for (std::size_t j : best_j) {
      float t = k.base[j];
      for (int d = 0; d < kInputs; ++d) {
        const float e = in.x[d][i] * k.scale[std::size_t(d)][j] - k.offset[std::size_t(d)][j];
        t -= e * e;
      }
      best = std::max(best, t);
    }
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

}  // namespace

ModelEvaluator::ModelEvaluator(const BtfModel& model, double tolerance) {
  const ProductMixture& mix = model.mixture;
  if (mix.size() == 0 || model.width < 1 || model.height < 1 || model.lights.empty() ||
      model.views.empty() || model.mean_brdf.size() != model.lights.size() * model.views.size() * 3)
    throw Error(Error::Kind::kArgument,
                "render: the model is empty or inconsistent (no components, no tile or a mean "
                "BRDF of the wrong size); load it with load_model()");
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance))
    throw Error(Error::Kind::kArgument,
                fmt::format("--tolerance {} must be a finite number of levels >= 0", tolerance));
  impl_ = std::make_unique<Impl>(model);
  Impl& k = *impl_;
  k.width = model.width;
  k.height = model.height;
  k.m = mix.size();
  k.unit = model.scaling.unit;
  k.mean_brdf = model.mean_brdf;
  k.views = model.views.size();
  const double log2e = std::numbers::log2e;
  for (int i = 0; i < kInputs; ++i) {
    k.scale[std::size_t(i)].resize(k.m);
    k.offset[std::size_t(i)].resize(k.m);
    k.mean_f[std::size_t(i)].resize(k.m);
    k.scale2_f[std::size_t(i)].resize(k.m);
  }
  k.base.resize(k.m);
  for (auto& c : k.colour) c.resize(k.m);
  std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t j = 0; j < k.m; ++j) {
    // As predict(): log w_m - 1/2 sum_{n in I} log sigma^2.
    double b = std::log(mix.weight[j]);
    for (int i = 0; i < kInputs; ++i) b -= 0.5 * std::log(mix.var[j][std::size_t(i)]);
    k.base[j] = float(b * log2e);
    for (int i = 0; i < kInputs; ++i) {
      const double s2 = log2e / (2.0 * mix.var[j][std::size_t(i)]);
      const double s = std::sqrt(s2);
      k.scale[std::size_t(i)][j] = float(s);
      k.offset[std::size_t(i)][j] = float(s * mix.mean[j][std::size_t(i)]);
      k.mean_f[std::size_t(i)][j] = float(mix.mean[j][std::size_t(i)]);
      k.scale2_f[std::size_t(i)][j] = float(s2);
    }
    for (int c = 0; c < 3; ++c) {
      const double mu = mix.mean[j][std::size_t(6 + c)];
      k.colour[std::size_t(c)][j] = float(mu);
      lo[std::size_t(c)] = std::min(lo[std::size_t(c)], mu * k.unit[std::size_t(6 + c)]);
      hi[std::size_t(c)] = std::max(hi[std::size_t(c)], mu * k.unit[std::size_t(6 + c)]);
    }
  }
  k.record.resize(k.m);
  for (std::size_t j = 0; j < k.m; ++j) {
    float* rec = k.record[j].v;
    for (int i = 0; i < kInputs; ++i) {
      rec[i] = k.scale[std::size_t(i)][j];
      rec[kInputs + i] = k.offset[std::size_t(i)][j];
    }
    rec[12] = k.base[j];
    for (int c = 0; c < 3; ++c) rec[13 + c] = k.colour[std::size_t(c)][j];
  }
  const double spread = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  if (tolerance > 0.0 && k.m > 1) {
    k.cull = true;
    // Skipped components change a colour by at most spread * sum 2^(U_m - Lmax) (see the
    // file's comment): that sum may reach tolerance / spread.
    k.budget = spread > 0.0 ? tolerance / spread : std::numeric_limits<double>::infinity();
  }
}

ModelEvaluator::~ModelEvaluator() = default;
ModelEvaluator::ModelEvaluator(ModelEvaluator&&) noexcept = default;
ModelEvaluator& ModelEvaluator::operator=(ModelEvaluator&&) noexcept = default;
std::size_t ModelEvaluator::components() const {
  return impl_->m;
}

EvaluationStats ModelEvaluator::evaluate(std::span<const SurfacePoint> points, std::span<float> rgb,
                                         std::span<const std::uint32_t> groups) const {
  if (rgb.size() < points.size() * 3)
    throw Error(Error::Kind::kArgument, "evaluate: the output holds fewer than 3 floats a point");
  const auto t0 = Clock::now();
  const Impl& k = *impl_;
  const std::size_t M = k.m;
  if (points.size() >= (std::size_t(1) << 32))
    throw Error(Error::Kind::kArgument, "evaluate: more than 2^32 points at once; split them");
  // Group boundaries: the caller's, or consecutive groups of kMaxBlock.
  std::vector<std::uint32_t> bounds;
  if (groups.empty()) {
    for (std::size_t p = 0; p < points.size(); p += kMaxBlock) bounds.push_back(std::uint32_t(p));
    bounds.push_back(std::uint32_t(points.size()));
  } else {
    bounds.assign(groups.begin(), groups.end());
    if (bounds.back() != points.size()) bounds.push_back(std::uint32_t(points.size()));
    for (std::size_t b = 0; b + 1 < bounds.size(); ++b)
      if (bounds[b + 1] < bounds[b] || bounds[b + 1] - bounds[b] > kGroup)
        throw Error(Error::Kind::kArgument,
                    fmt::format("evaluate: group {} is not ascending or holds more than {} points",
                                b, kGroup));
  }
  const std::ptrdiff_t blocks = std::ptrdiff_t(bounds.size()) - 1;
  std::uint64_t evaluated = 0;
  int bad = 0;  // a point that is not finite or has a direction below the horizon
  const float u2 = float(1.0 / k.unit[2]), u3 = float(1.0 / k.unit[3]), u4 = float(1.0 / k.unit[4]),
              u5 = float(1.0 / k.unit[5]);
#pragma omp parallel reduction(+ : evaluated) reduction(| : bad)
  {
    auto in = std::make_unique<BlockInputs>();
    std::vector<float> upper(M), lower(M), scratch(M);
    std::vector<std::int32_t> bucket(M);
    std::vector<std::uint32_t> keep(M);
    std::array<Vf, kMaxBlock / kLanes> ref;
    std::array<LaneSums, kMaxBlock / kLanes> sums;
    std::vector<std::uint8_t> exact(kMaxBlock);
    std::uint32_t hint_l = std::numeric_limits<std::uint32_t>::max(), hint_v = hint_l;
#pragma omp for schedule(dynamic, 4)
    for (std::ptrdiff_t blk = 0; blk < blocks; ++blk) {
      const std::size_t p0 = bounds[std::size_t(blk)];
      const int n = int(bounds[std::size_t(blk) + 1] - p0);
      if (n == 0) continue;
      const SurfacePoint* pts = &points[p0];
      int block_bad = 0;
      for (int i = 0; i < n; ++i) {
        const SurfacePoint& p = pts[i];
        block_bad |= !std::isfinite(p.x) || !std::isfinite(p.y) || !(p.light[2] >= 0.0f) ||
                     !(p.view[2] >= 0.0f);
      }
      if (block_bad) {
        bad = 1;
        continue;
      }
      // 1. The inputs in model units, lane by lane; the last point repeated to whole vectors.
      const int nv = (n + kLanes - 1) / kLanes, padded = nv * kLanes;
      for (int i = 0; i < n; ++i) {
        const SurfacePoint& p = pts[i];
        in->x[0][i] = float(wrap(p.x, k.width));
        in->x[1][i] = float(wrap(p.y, k.height));
        for (int c = 0; c < 3; ++c) {
          in->dir[c][i] = p.light[std::size_t(c)];
          in->dir[3 + c][i] = p.view[std::size_t(c)];
        }
      }
      // Onion-slice angles (directions.hpp): alpha = atan2(y, z), beta = asin(x) =
      // atan2(x, sqrt(1 - x^2)); z >= 0. Vectorised over the points.
#pragma omp simd
      for (int i = 0; i < n; ++i) {
        const float lx = std::clamp(in->dir[0][i], -1.0f, 1.0f),
                    vx = std::clamp(in->dir[3][i], -1.0f, 1.0f);
        in->x[2][i] = atan2_right(in->dir[1][i], in->dir[2][i]) * u2;
        in->x[3][i] = atan2_right(lx, std::sqrt((1.0f - lx) * (1.0f + lx))) * u3;
        in->x[4][i] = atan2_right(in->dir[4][i], in->dir[5][i]) * u4;
        in->x[5][i] = atan2_right(vx, std::sqrt((1.0f - vx) * (1.0f + vx))) * u5;
      }
      for (int d = 0; d < kInputs; ++d)
        for (int i = n; i < padded; ++i) in->x[d][i] = in->x[d][n - 1];
      // 2. The box, and the bounds of every component's log weight over it.
      const Intervals bx = wrapped_box(in->x[0], n, 1, k.width);
      const Intervals by = wrapped_box(in->x[1], n, 1, k.height);
      std::array<float, kInputs> lo{}, hi{};
      for (int d = 2; d < kInputs; ++d) {
        float a = in->x[d][0], b = a;
#pragma omp simd reduction(min : a) reduction(max : b)
        for (int i = 0; i < n; ++i) {
          a = std::min(a, in->x[d][i]);
          b = std::max(b, in->x[d][i]);
        }
        lo[std::size_t(d)] = a;
        hi[std::size_t(d)] = b;
      }
      std::size_t kept = 0;
      double r = 0.0, lmax = 0.0;
      const bool cull = k.cull;
      if (cull) {
        bound_log_weights(k, bx, by, lo, hi, upper.data(), lower.data(), scratch.data());
        kept = select_components(k, *in, n, upper.data(), lower.data(), keep.data(), bucket.data(),
                                 r, lmax);
      } else {
        for (std::size_t j = 0; j < M; ++j) keep[kept++] = std::uint32_t(j);
      }
      evaluated += std::uint64_t(kept) * std::uint64_t(n);
      // 3. The sums, with the block's reference r when every point's largest term is then far
      // from underflow (r - Lmax <= 56 in log2 units), else each point's own maximum.
      const Record* rec = k.record.data();
      const bool one_pass = cull && r - lmax <= 56.0;
      for (int v = 0; v < nv; ++v)
        ref[std::size_t(v)] =
            one_pass ? splat(float(r)) : max_log_weight(rec, keep.data(), kept, *in, v);
      int v = 0;
      for (; v + 2 <= nv; v += 2)
        sum_points<2>(rec, keep.data(), kept, *in, v, ref.data(), &sums[std::size_t(v)]);
      if (v < nv) sum_points<1>(rec, keep.data(), kept, *in, v, ref.data(), &sums[std::size_t(v)]);
      for (int w = 0; w < nv; ++w) {
        std::memcpy(&in->sum[0][w * kLanes], &sums[std::size_t(w)].sum, sizeof(Vf));
        std::memcpy(&in->sum[1][w * kLanes], &sums[std::size_t(w)].c0, sizeof(Vf));
        std::memcpy(&in->sum[2][w * kLanes], &sums[std::size_t(w)].c1, sizeof(Vf));
        std::memcpy(&in->sum[3][w * kLanes], &sums[std::size_t(w)].c2, sizeof(Vf));
      }
      // 4. Eq. (11): the conditional expectation plus the mean BRDF at these directions,
      // interpolated over the measured directions. The block's directions vary little: the
      // first point's light and view triangles (found as DirectionInterpolator finds them)
      // serve every point that lies well inside both (every weight above 1e-4, so that no
      // other triangle holds it), in one vectorised pass; the others take the exact look-up.
      const auto mean_brdf = [&](const DirectionInterpolator::Weights& wl,
                                 const DirectionInterpolator::Weights& wv, int a, int b, int c) {
        return k.mean_brdf[(wl.index[std::size_t(a)] * k.views + wv.index[std::size_t(b)]) * 3 +
                           std::size_t(c)];
      };
      const float unit0 = float(k.unit[6]), unit1 = float(k.unit[7]), unit2 = float(k.unit[8]);
      float* out = &rgb[p0 * 3];
      // Rounds: the light and view triangles of the first point still left (the block's first
      // point in the first round) serve every left point well inside both.
      std::fill(exact.begin(), exact.begin() + n, std::uint8_t(1));
      int first = 0;
      for (int round = 0; round < kAffineRounds && first < n; ++round) {
        const SurfacePoint& seed = pts[first];
        const auto wl0 =
            k.lights_interp.weights(Vec3{seed.light[0], seed.light[1], seed.light[2]}, hint_l);
        const auto wv0 =
            k.views_interp.weights(Vec3{seed.view[0], seed.view[1], seed.view[2]}, hint_v);
        const AffineTriangle tl = affine_triangle(k.light_xy, wl0.index),
                             tv = affine_triangle(k.view_xy, wv0.index);
        if (!(tl.ok && tv.ok)) break;
        float table[3][3][3];
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            for (int c = 0; c < 3; ++c) table[a][b][c] = mean_brdf(wl0, wv0, a, b, c);
        std::uint8_t* __restrict ex = exact.data();
#pragma omp simd
        for (int i = first; i < n; ++i) {
          float q[2][2];
          for (int s = 0; s < 2; ++s) {
            const float x = in->dir[3 * s][i], y = in->dir[3 * s + 1][i],
                        z = std::max(in->dir[3 * s + 2][i], 0.0f);
            const float inv = 1.0f / std::sqrt(x * x + y * y + z * z);
            q[s][0] = x * inv;
            q[s][1] = y * inv;
          }
          float wl[3], wv[3];
          for (int a = 0; a < 3; ++a) {
            wl[a] = tl.c[a][0] + tl.c[a][1] * q[0][0] + tl.c[a][2] * q[0][1];
            wv[a] = tv.c[a][0] + tv.c[a][1] * q[1][0] + tv.c[a][2] * q[1][1];
          }
          const float m = std::min(std::min(std::min(wl[0], wl[1]), std::min(wl[2], wv[0])),
                                   std::min(wv[1], wv[2]));
          float mb[3] = {0, 0, 0};
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) {
              const float w = wl[a] * wv[b];
              for (int c = 0; c < 3; ++c) mb[c] += w * table[a][b][c];
            }
          // (Every value computed on every lane, then selected: no branches in the loop.)
          const bool done = (ex[i] != 0) & (m > 1e-4f);
          const float inv_sum = 1.0f / in->sum[0][i];
          const float c0 = in->sum[1][i] * inv_sum * unit0 + mb[0],
                      c1 = in->sum[2][i] * inv_sum * unit1 + mb[1],
                      c2 = in->sum[3][i] * inv_sum * unit2 + mb[2];
          out[i * 3] = done ? c0 : out[i * 3];
          out[i * 3 + 1] = done ? c1 : out[i * 3 + 1];
          out[i * 3 + 2] = done ? c2 : out[i * 3 + 2];
          ex[i] = done ? std::uint8_t(0) : ex[i];
        }
        while (first < n && !exact[std::size_t(first)]) ++first;
      }
      for (int i = 0; i < n; ++i) {
        if (!exact[std::size_t(i)]) continue;
        const SurfacePoint& p = pts[i];
        const auto wl = k.lights_interp.weights(Vec3{p.light[0], p.light[1], p.light[2]}, hint_l);
        const auto wv = k.views_interp.weights(Vec3{p.view[0], p.view[1], p.view[2]}, hint_v);
        std::array<double, 3> mb{0, 0, 0};
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const double w = wl.weight[std::size_t(a)] * wv.weight[std::size_t(b)];
            if (w == 0.0) continue;
            for (int c = 0; c < 3; ++c) mb[std::size_t(c)] += w * mean_brdf(wl, wv, a, b, c);
          }
        const float inv_sum = 1.0f / in->sum[0][i];
        float* o = &out[i * 3];
        o[0] = in->sum[1][i] * inv_sum * unit0 + float(mb[0]);
        o[1] = in->sum[2][i] * inv_sum * unit1 + float(mb[1]);
        o[2] = in->sum[3][i] * inv_sum * unit2 + float(mb[2]);
      }
    }
  }
  if (bad)
    for (const SurfacePoint& p : points)
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !(p.light[2] >= 0.0f) ||
          !(p.view[2] >= 0.0f))
        throw Error(Error::Kind::kArgument,
                    fmt::format("evaluate: a point ({}, {}) is not finite or has a direction "
                                "below the horizon",
                                p.x, p.y));
  EvaluationStats st;
  st.points = points.size();
  st.nominal = std::uint64_t(points.size()) * std::uint64_t(M);
  st.evaluated = evaluated;
  st.seconds = seconds_since(t0);
  return st;
}

// ---- the data -----------------------------------------------------------------------------

struct DataEvaluator::Impl {
  const Btf* btf;
  FastDirectionInterpolator lights, views;
  explicit Impl(const Btf& b) : btf(&b), lights(b.lights()), views(b.views()) {}
};

DataEvaluator::DataEvaluator(const Btf& btf) {
  if (btf.width() < 1 || btf.height() < 1 || btf.image_count() == 0)
    throw Error(Error::Kind::kArgument, "render: the measured data is empty");
  impl_ = std::make_unique<Impl>(btf);
}
DataEvaluator::~DataEvaluator() = default;
DataEvaluator::DataEvaluator(DataEvaluator&&) noexcept = default;
DataEvaluator& DataEvaluator::operator=(DataEvaluator&&) noexcept = default;

EvaluationStats DataEvaluator::evaluate(std::span<const SurfacePoint> points,
                                        std::span<float> rgb) const {
  if (rgb.size() < points.size() * 3)
    throw Error(Error::Kind::kArgument, "evaluate: the output holds fewer than 3 floats a point");
  const auto t0 = Clock::now();
  const Btf& b = *impl_->btf;
  const int W = b.width(), H = b.height();
  const std::ptrdiff_t n = std::ptrdiff_t(points.size());
#pragma omp parallel
  {
    std::uint32_t hint_l = std::numeric_limits<std::uint32_t>::max(), hint_v = hint_l;
#pragma omp for schedule(dynamic, 256)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      const SurfacePoint& p = points[std::size_t(i)];
      const auto wl = impl_->lights.weights(Vec3{p.light[0], p.light[1], p.light[2]}, hint_l);
      const auto wv = impl_->views.weights(Vec3{p.view[0], p.view[1], p.view[2]}, hint_v);
      // Bilinear between the pixels around (x, y), pixel centres at whole coordinates.
      const double x = wrap(p.x, W), y = wrap(p.y, H);
      const int xa = int(std::floor(x)) % W, ya = int(std::floor(y)) % H;
      const int xb = (xa + 1) % W, yb = (ya + 1) % H;
      const double fx = x - std::floor(x), fy = y - std::floor(y);
      const std::size_t o00 = (std::size_t(ya) * std::size_t(W) + std::size_t(xa)) * 3,
                        o10 = (std::size_t(ya) * std::size_t(W) + std::size_t(xb)) * 3,
                        o01 = (std::size_t(yb) * std::size_t(W) + std::size_t(xa)) * 3,
                        o11 = (std::size_t(yb) * std::size_t(W) + std::size_t(xb)) * 3;
      const double w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy,
                   w11 = fx * fy;
      std::array<double, 3> c{0, 0, 0};
      for (int a = 0; a < 3; ++a)
        for (int bb = 0; bb < 3; ++bb) {
          const double w = wl.weight[std::size_t(a)] * wv.weight[std::size_t(bb)];
          if (w == 0.0) continue;
          const float* img = b.image(wl.index[std::size_t(a)], wv.index[std::size_t(bb)]);
          for (int ch = 0; ch < 3; ++ch)
            c[std::size_t(ch)] +=
                w * (w00 * img[o00 + std::size_t(ch)] + w10 * img[o10 + std::size_t(ch)] +
                     w01 * img[o01 + std::size_t(ch)] + w11 * img[o11 + std::size_t(ch)]);
        }
      for (int ch = 0; ch < 3; ++ch)
        rgb[std::size_t(i) * 3 + std::size_t(ch)] = float(c[std::size_t(ch)]);
    }
  }
  EvaluationStats st;
  st.points = points.size();
  st.nominal = st.evaluated = std::uint64_t(points.size()) * 36;
  st.seconds = seconds_since(t0);
  return st;
}

}  // namespace btfgmm
