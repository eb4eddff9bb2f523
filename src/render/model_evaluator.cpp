// ModelEvaluator: the model, Eq. (8)-(11), for many surface points at once
// (docs/RENDERING.md, "The kernel"); the equations are model/conditional.hpp's, here evaluated
// in float, 16 points a vector.
//
// For a point with inputs x_I = (x, y, alpha_i, beta_i, alpha_v, beta_v) in model units,
// Eq. (9)-(10) give the log weight
//   t_m = log w_m - 1/2 sum_k log sigma_mk^2 - sum_k (x_k - mu_mk)^2 / (2 sigma_mk^2),
// x - mu and y - mu in the minimum image (the Gaussians of x and y wrap around the tile,
// model/mixture_internal.hpp),
// and the colour is sum_m W_m mu_m,rgb (Eq. 8, times the colour unit) plus the mean BRDF
// (Eq. 11). Points come in blocks of up to 256 (a 16 x 16 screen block); per block:
//  1. the box of the block's inputs (x and y as up to two intervals, the tile wraps);
//  2. per component an upper bound U_m and a lower bound L_m of t_m over the box; Lmax, at
//     most every point's largest log weight t*, so a skipped component has a normalised
//     weight below exp(U_m - Lmax); components are skipped while the skipped set's
//     sum of exp(U_m - Lmax) times R, the spread of the components' colour means in levels,
//     stays within the tolerance (component_bounds.cpp);
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
#include <array>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/render/model_evaluator.hpp"
#include "btfgmm/render/render.hpp"
#include "model/conditional.hpp"
#include "render/model_kernel.hpp"

namespace btfgmm {
namespace {

using detail::BlockInputs;
using detail::Intervals;
using detail::kLanes;
using detail::kMaxBlock;
using detail::LaneSums;
using detail::Record;
using detail::Vf;

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

// Up to two closed intervals in [0, 1] holding a set of wrapped coordinates (the box of x or y,
// as fractions of the tile, over a block).
Intervals wrapped_box(const float* v, int n, int stride) {
  const float ref = v[0], half = 0.5f, per = 1.0f;
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

// Throws Error(kArgument) for a model the kernel cannot evaluate or a bad tolerance.
void check_model(const BtfModel& model, double tolerance) {
  const ProductMixture& mix = model.mixture;
  if (mix.size() == 0 || model.width < 1 || model.height < 1 || model.lights.empty() ||
      model.views.empty() || model.mean_brdf.size() != model.lights.size() * model.views.size() * 3)
    throw Error(Error::Kind::kArgument,
                "render: the model is empty or inconsistent (no components, no tile or a mean "
                "BRDF of the wrong size); load it with load_model()");
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance))
    throw Error(Error::Kind::kArgument,
                fmt::format("`tolerance` {} must be a finite number of levels >= 0", tolerance));
}

// The components' parameters in the kernel's form: Eq. (9)'s base (log_weight_base) and the
// terms of Eq. (10) (log2_marginal_term, x and y wrapped around the tile) in log2 units, the
// colour means of Eq. (8); per input for the bounds, and as one record per component for the
// sums.
void component_records(ModelEvaluator::Impl& k, const ProductMixture& mix,
                       const detail::Periods& periods) {
  const double log2e = std::numbers::log2e;
  for (std::size_t i = 0; i < std::size_t(kInputs); ++i) {
    k.scale[i].resize(k.m);
    k.offset[i].resize(k.m);
    k.mean_f[i].resize(k.m);
    k.scale2_f[i].resize(k.m);
  }
  k.base.resize(k.m);
  for (auto& c : k.colour) c.resize(k.m);
  for (std::size_t j = 0; j < k.m; ++j) {
    k.base[j] = float(detail::log_weight_base(mix, j) * log2e);
    for (std::size_t i = 0; i < std::size_t(kInputs); ++i) {
      const detail::Log2MarginalTerm term =
          detail::log2_marginal_term(mix.mean[j][i], mix.var[j][i], periods[i]);
      assert(term.wrapped == (int(i) < detail::kWrappedInputs));
      k.scale[i][j] = float(term.scale);
      k.offset[i][j] = float(term.offset);
      k.mean_f[i][j] = float(term.mean);
      k.scale2_f[i][j] = float(term.scale2);
    }
    for (std::size_t c = 0; c < 3; ++c) k.colour[c][j] = float(mix.mean[j][6 + c]);
  }
  k.record.resize(k.m);
  for (std::size_t j = 0; j < k.m; ++j) {
    float* rec = k.record[j].v;
    for (std::size_t i = 0; i < std::size_t(kInputs); ++i) {
      rec[i] = k.scale[i][j];
      rec[std::size_t(kInputs) + i] = k.offset[i][j];
    }
    rec[12] = k.base[j];
    for (std::size_t c = 0; c < 3; ++c) rec[13 + c] = k.colour[c][j];
  }
}

}  // namespace

ModelEvaluator::ModelEvaluator(const BtfModel& model, double tolerance) {
  check_model(model, tolerance);
  const ProductMixture& mix = model.mixture;
  impl_ = std::make_unique<Impl>(model);
  Impl& k = *impl_;
  k.width = model.width;
  k.height = model.height;
  k.m = mix.size();
  k.unit = model.scaling.unit;
  k.mean_brdf = model.mean_brdf;
  k.views = model.views.size();
  component_records(k, mix, detail::model_periods(model));
  const double spread = detail::colour_spread(mix, k.unit);
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

namespace {

// Where each group of points begins, then the number of points: the caller's `groups`
// (checked), or consecutive groups of kMaxBlock.
std::vector<std::uint32_t> group_bounds(std::size_t count, std::span<const std::uint32_t> groups) {
  std::vector<std::uint32_t> bounds;
  if (groups.empty()) {
    for (std::size_t p = 0; p < count; p += kMaxBlock) bounds.push_back(std::uint32_t(p));
    bounds.push_back(std::uint32_t(count));
  } else {
    bounds.assign(groups.begin(), groups.end());
    if (bounds.back() != count) bounds.push_back(std::uint32_t(count));
    for (std::size_t b = 0; b + 1 < bounds.size(); ++b)
      if (bounds[b + 1] < bounds[b] || bounds[b + 1] - bounds[b] > ModelEvaluator::kGroup)
        throw Error(Error::Kind::kArgument,
                    fmt::format("evaluate: group {} is not ascending or holds more than {} points",
                                b, ModelEvaluator::kGroup));
  }
  return bounds;
}

// Whether a point is not finite or has a direction below the horizon.
inline bool bad_point(const SurfacePoint& p) {
  return !std::isfinite(p.x) || !std::isfinite(p.y) || !(p.light[2] >= 0.0f) ||
         !(p.view[2] >= 0.0f);
}

// A thread's scratch, for one block at a time, and its hints of the last light and view
// triangles.
struct BlockScratch {
  std::unique_ptr<BlockInputs> in = std::make_unique<BlockInputs>();
  std::vector<float> upper, lower, scratch;
  std::vector<std::int32_t> bucket;
  std::vector<std::uint32_t> keep;
  // The kept components in the two lists of image_records: records with the block's image of
  // their means (and their indices), and the indices of those taken wrapped point by point.
  std::vector<Record> local;
  std::vector<std::uint32_t> plain, wrapped;
  detail::ImageLists lists;
  std::array<Vf, kMaxBlock / kLanes> ref;
  std::array<LaneSums, kMaxBlock / kLanes> sums;
  std::vector<std::uint8_t> exact;
  std::uint32_t hint_l = std::numeric_limits<std::uint32_t>::max(), hint_v = hint_l;
  explicit BlockScratch(std::size_t m)
      : upper(m),
        lower(m),
        scratch(m),
        bucket(m),
        keep(m),
        local(m),
        plain(m),
        wrapped(m),
        exact(kMaxBlock) {}
};

// 1. The inputs x_I in model units, lane by lane (x and y as fractions of the tile, wrapped
// into [0, 1]); the last point repeated to whole vectors. `angle_unit`: 1 / the units of the
// four angles.
inline void block_inputs(const ModelEvaluator::Impl& k, const SurfacePoint* pts, int n,
                         const std::array<float, 4>& angle_unit, BlockInputs& in) {
  const int nv = (n + kLanes - 1) / kLanes, padded = nv * kLanes;
  const double inv_w = 1.0 / k.width, inv_h = 1.0 / k.height;
  for (int i = 0; i < n; ++i) {
    const SurfacePoint& p = pts[i];
    in.x[0][i] = float(detail::tile_coordinate(p.x, k.width) * inv_w);
    in.x[1][i] = float(detail::tile_coordinate(p.y, k.height) * inv_h);
    for (int c = 0; c < 3; ++c) {
      in.dir[c][i] = p.light[std::size_t(c)];
      in.dir[3 + c][i] = p.view[std::size_t(c)];
    }
  }
  const float u2 = angle_unit[0], u3 = angle_unit[1], u4 = angle_unit[2], u5 = angle_unit[3];
  // Onion-slice angles (directions.hpp): alpha = atan2(y, z), beta = asin(x) =
  // atan2(x, sqrt(1 - x^2)); z >= 0. Vectorised over the points.
#pragma omp simd
  for (int i = 0; i < n; ++i) {
    const float lx = std::clamp(in.dir[0][i], -1.0f, 1.0f),
                vx = std::clamp(in.dir[3][i], -1.0f, 1.0f);
    in.x[2][i] = atan2_right(in.dir[1][i], in.dir[2][i]) * u2;
    in.x[3][i] = atan2_right(lx, std::sqrt((1.0f - lx) * (1.0f + lx))) * u3;
    in.x[4][i] = atan2_right(in.dir[4][i], in.dir[5][i]) * u4;
    in.x[5][i] = atan2_right(vx, std::sqrt((1.0f - vx) * (1.0f + vx))) * u5;
  }
  for (int d = 0; d < kInputs; ++d)
    for (int i = n; i < padded; ++i) in.x[d][i] = in.x[d][n - 1];
}

// 2. The box of the block's inputs, the bounds of every component's log weight over it and
// the components kept (all of them without culling; r and lmax are then left 0), in the two
// lists of image_records (s.lists).
inline std::size_t keep_components(const ModelEvaluator::Impl& k, BlockScratch& s, int n, double& r,
                                   double& lmax) {
  const BlockInputs& in = *s.in;
  const Intervals bx = wrapped_box(in.x[0], n, 1);
  const Intervals by = wrapped_box(in.x[1], n, 1);
  std::array<float, kInputs> lo{}, hi{};
  for (int d = 2; d < kInputs; ++d) {
    float a = in.x[d][0], b = a;
#pragma omp simd reduction(min : a) reduction(max : b)
    for (int i = 0; i < n; ++i) {
      a = std::min(a, in.x[d][i]);
      b = std::max(b, in.x[d][i]);
    }
    lo[std::size_t(d)] = a;
    hi[std::size_t(d)] = b;
  }
  std::size_t kept = 0;
  if (k.cull) {
    detail::bound_log_weights(k, bx, by, lo, hi, s.upper.data(), s.lower.data(), s.scratch.data());
    kept = detail::select_components(k, in, n, s.upper.data(), s.lower.data(), s.keep.data(),
                                     s.bucket.data(), r, lmax);
  } else {
    for (std::size_t j = 0; j < k.m; ++j) s.keep[kept++] = std::uint32_t(j);
  }
  s.lists = detail::image_records(k, bx, by, s.keep.data(), kept, s.local.data(), s.plain.data(),
                                  s.wrapped.data());
  return kept;
}

// The sums of Eq. (8) over one list of components (sum_points<., Wrapped>), two vectors of
// points at a time, added to s.sums.
template <bool Wrapped>
inline void list_sums(const Record* rec, const std::uint32_t* list, std::size_t count,
                      BlockScratch& s, int nv) {
  const BlockInputs& in = *s.in;
  int v = 0;
  for (; v + 2 <= nv; v += 2)
    detail::sum_points<2, Wrapped>(rec, list, count, in, v, s.ref.data(), &s.sums[std::size_t(v)]);
  if (v < nv)
    detail::sum_points<1, Wrapped>(rec, list, count, in, v, s.ref.data(), &s.sums[std::size_t(v)]);
}

// 3. The sums of Eq. (8) over the kept components, point by point into in.sum, with the
// block's reference r when every point's largest term is then far from underflow
// (`one_pass`: r - Lmax <= 56 in log2 units), else each point's own maximum. The components
// with one image of their means nearest to the whole block take the plain terms (s.local),
// the others the minimum image point by point.
inline void block_sums(const ModelEvaluator::Impl& k, BlockScratch& s, int n, bool one_pass,
                       double r) {
  BlockInputs& in = *s.in;
  const int nv = (n + kLanes - 1) / kLanes;
  const Record* rec = k.record.data();
  const detail::ImageLists& lists = s.lists;
  for (int v = 0; v < nv; ++v) {
    Vf ref = detail::splat(float(r));
    if (!one_pass) {
      ref = detail::max_log_weight<false>(s.local.data(), s.plain.data(), lists.plain, in, v,
                                          detail::splat(-std::numeric_limits<float>::infinity()));
      ref = detail::max_log_weight<true>(rec, s.wrapped.data(), lists.wrapped, in, v, ref);
    }
    s.ref[std::size_t(v)] = ref;
    s.sums[std::size_t(v)] = LaneSums{};
  }
  list_sums<false>(s.local.data(), s.plain.data(), lists.plain, s, nv);
  list_sums<true>(rec, s.wrapped.data(), lists.wrapped, s, nv);
  for (int w = 0; w < nv; ++w) {
    const LaneSums& sw = s.sums[std::size_t(w)];
    std::memcpy(&in.sum[0][w * kLanes], &sw.weight, sizeof(Vf));
    std::memcpy(&in.sum[1][w * kLanes], &sw.colour[0], sizeof(Vf));
    std::memcpy(&in.sum[2][w * kLanes], &sw.colour[1], sizeof(Vf));
    std::memcpy(&in.sum[3][w * kLanes], &sw.colour[2], sizeof(Vf));
  }
}

// 4a. One round of Eq. (11) on the affine weights of the light and view triangles of
// wl0, wv0 (tl, tv): every point from `first` on still marked in s.exact that lies well inside
// both (every weight above 1e-4, so that no other triangle holds it) takes the conditional
// expectation plus the mean BRDF, in one vectorised pass, and is unmarked.
inline void affine_round(const ModelEvaluator::Impl& k, BlockScratch& s,
                         const DirectionInterpolator::Weights& wl0,
                         const DirectionInterpolator::Weights& wv0, const AffineTriangle& tl,
                         const AffineTriangle& tv, int first, int n, float* out) {
  const BlockInputs* in = s.in.get();
  float table[3][3][3];
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t b = 0; b < 3; ++b)
      for (std::size_t c = 0; c < 3; ++c)
        table[a][b][c] =
            detail::measured_mean_brdf(k.mean_brdf, k.views, wl0.index[a], wv0.index[b])[c];
  const float unit0 = float(k.unit[6]), unit1 = float(k.unit[7]), unit2 = float(k.unit[8]);
  std::uint8_t* __restrict ex = s.exact.data();
#pragma omp simd
  for (int i = first; i < n; ++i) {
    float q[2][2];
    for (int d = 0; d < 2; ++d) {
      const float x = in->dir[3 * d][i], y = in->dir[3 * d + 1][i],
                  z = std::max(in->dir[3 * d + 2][i], 0.0f);
      const float inv = 1.0f / std::sqrt(x * x + y * y + z * z);
      q[d][0] = x * inv;
      q[d][1] = y * inv;
    }
    float wl[3], wv[3];
    for (int a = 0; a < 3; ++a) {
      wl[a] = tl.c[a][0] + tl.c[a][1] * q[0][0] + tl.c[a][2] * q[0][1];
      wv[a] = tv.c[a][0] + tv.c[a][1] * q[1][0] + tv.c[a][2] * q[1][1];
    }
    const float m =
        std::min(std::min(std::min(wl[0], wl[1]), std::min(wl[2], wv[0])), std::min(wv[1], wv[2]));
    float mb[3] = {0, 0, 0};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        const float w = wl[a] * wv[b];
        for (int c = 0; c < 3; ++c) mb[c] += w * table[a][b][c];
      }
    // (Every value computed on every lane, then selected: no branches in the loop.)
    const bool done = (ex[i] != 0) & (m > 1e-4f);
    const float inv_sum = 1.0f / in->sum[0][i];
    const float c0 = detail::predicted_value(in->sum[1][i] * inv_sum, unit0, mb[0]),
                c1 = detail::predicted_value(in->sum[2][i] * inv_sum, unit1, mb[1]),
                c2 = detail::predicted_value(in->sum[3][i] * inv_sum, unit2, mb[2]);
    out[i * 3] = done ? c0 : out[i * 3];
    out[i * 3 + 1] = done ? c1 : out[i * 3 + 1];
    out[i * 3 + 2] = done ? c2 : out[i * 3 + 2];
    ex[i] = done ? std::uint8_t(0) : ex[i];
  }
}

// 4. Eq. (11): the conditional expectation plus the mean BRDF at these directions,
// interpolated over the measured directions. The block's directions vary little: in rounds,
// the light and view triangles of the first point still left (found as DirectionInterpolator
// finds them) serve every left point well inside both (affine_round); the others take the
// exact look-up (mean_brdf_at).
inline void block_colours(const ModelEvaluator::Impl& k, BlockScratch& s, const SurfacePoint* pts,
                          int n, float* out) {
  if (n < 1) return;
  std::fill(s.exact.begin(), s.exact.begin() + n, std::uint8_t(1));
  int first = 0;
  for (int round = 0; round < kAffineRounds && first < n; ++round) {
    const SurfacePoint& seed = pts[first];
    const auto wl0 =
        k.lights_interp.weights(Vec3{seed.light[0], seed.light[1], seed.light[2]}, s.hint_l);
    const auto wv0 =
        k.views_interp.weights(Vec3{seed.view[0], seed.view[1], seed.view[2]}, s.hint_v);
    const AffineTriangle tl = affine_triangle(k.light_xy, wl0.index),
                         tv = affine_triangle(k.view_xy, wv0.index);
    if (!(tl.ok && tv.ok)) break;
    affine_round(k, s, wl0, wv0, tl, tv, first, n, out);
    while (first < n && !s.exact[std::size_t(first)]) ++first;
  }
  const BlockInputs& in = *s.in;
  const float unit0 = float(k.unit[6]), unit1 = float(k.unit[7]), unit2 = float(k.unit[8]);
  for (int i = 0; i < n; ++i) {
    if (!s.exact[std::size_t(i)]) continue;
    const SurfacePoint& p = pts[i];
    const auto wl = k.lights_interp.weights(Vec3{p.light[0], p.light[1], p.light[2]}, s.hint_l);
    const auto wv = k.views_interp.weights(Vec3{p.view[0], p.view[1], p.view[2]}, s.hint_v);
    const std::array<float, 3> mb = detail::mean_brdf_at(k.mean_brdf, k.views, wl, wv);
    const float inv_sum = 1.0f / in.sum[0][i];
    float* o = &out[i * 3];
    o[0] = detail::predicted_value(in.sum[1][i] * inv_sum, unit0, mb[0]);
    o[1] = detail::predicted_value(in.sum[2][i] * inv_sum, unit1, mb[1]);
    o[2] = detail::predicted_value(in.sum[3][i] * inv_sum, unit2, mb[2]);
  }
}

// One block of n points: steps 1-4; returns the component evaluations done.
inline std::uint64_t evaluate_block(const ModelEvaluator::Impl& k, BlockScratch& s,
                                    const SurfacePoint* pts, int n,
                                    const std::array<float, 4>& angle_unit, float* out) {
  block_inputs(k, pts, n, angle_unit, *s.in);
  double r = 0.0, lmax = 0.0;
  const std::size_t kept = keep_components(k, s, n, r, lmax);
  block_sums(k, s, n, k.cull && r - lmax <= 56.0, r);
  block_colours(k, s, pts, n, out);
  return std::uint64_t(kept) * std::uint64_t(n);
}

}  // namespace

EvaluationStats ModelEvaluator::evaluate(std::span<const SurfacePoint> points, std::span<float> rgb,
                                         std::span<const std::uint32_t> groups) const {
  if (rgb.size() < points.size() * 3)
    throw Error(Error::Kind::kArgument, "evaluate: the output holds fewer than 3 floats a point");
  const auto t0 = Clock::now();
  const Impl& k = *impl_;
  if (points.size() >= (std::size_t(1) << 32))
    throw Error(Error::Kind::kArgument, "evaluate: more than 2^32 points at once; split them");
  const std::vector<std::uint32_t> bounds = group_bounds(points.size(), groups);
  const std::ptrdiff_t blocks = std::ptrdiff_t(bounds.size()) - 1;
  std::uint64_t evaluated = 0;
  int bad = 0;  // a point that is not finite or has a direction below the horizon
  const std::array<float, 4> angle_unit = {float(1.0 / k.unit[2]), float(1.0 / k.unit[3]),
                                           float(1.0 / k.unit[4]), float(1.0 / k.unit[5])};
#pragma omp parallel reduction(+ : evaluated) reduction(| : bad)
  {
    BlockScratch scratch(k.m);
#pragma omp for schedule(dynamic, 4)
    for (std::ptrdiff_t blk = 0; blk < blocks; ++blk) {
      const std::size_t p0 = bounds[std::size_t(blk)];
      const int n = int(bounds[std::size_t(blk) + 1] - p0);
      if (n == 0) continue;
      const SurfacePoint* pts = &points[p0];
      int block_bad = 0;
      for (int i = 0; i < n; ++i) block_bad |= bad_point(pts[i]);
      if (block_bad) {
        bad = 1;
        continue;
      }
      evaluated += evaluate_block(k, scratch, pts, n, angle_unit, &rgb[p0 * 3]);
    }
  }
  if (bad)
    for (const SurfacePoint& p : points)
      if (bad_point(p))
        throw Error(Error::Kind::kArgument,
                    fmt::format("evaluate: a point ({}, {}) is not finite or has a direction "
                                "below the horizon",
                                p.x, p.y));
  EvaluationStats st;
  st.points = points.size();
  st.nominal = std::uint64_t(points.size()) * std::uint64_t(k.m);
  st.evaluated = evaluated;
  st.seconds = seconds_since(t0);
  return st;
}

}  // namespace btfgmm
