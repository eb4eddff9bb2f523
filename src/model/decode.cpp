// Decoding, Eq. (8)-(11) on the tile's grid (docs/ALGORITHM.md, "Decoding"): Eq. (9)'s
// exponent split into tables of one input each, blocks of pixels that skip the components
// whose weight is bounded negligible over them, and the colour of Eq. (8) as products of
// tabulated factors. The equations are model/conditional.hpp's; predict.cpp evaluates them one
// query at a time.
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/model/decode.hpp"
#include "btfgmm/model/model.hpp"
#include "core/fast_exp.hpp"
#include "core/flush_denormals.hpp"
#include "model/conditional.hpp"
#include "model/mixture_internal.hpp"
#if defined(__AVX512F__)
#include "model/em_avx512.hpp"
#endif

namespace btfgmm {
namespace {

// Decoding works on blocks of kDecodeBlock x kDecodeBlock tile pixels of one image, with the
// components in vectors of 16 (decode's own order: a k-d split of their x, y means, so that
// the components a block can skip fill whole vectors).
constexpr std::size_t kDecodeBlock = 16;

// x[i] = exp(x[i]) for n (a multiple of 16) values <= 0.
void exp_in_place(float* x, std::size_t n) {
#if defined(__AVX512F__)
  for (std::size_t i = 0; i < n; i += 16)
    _mm512_storeu_ps(x + i, detail::fast_exp16(_mm512_loadu_ps(x + i)));
#else
#pragma omp simd
  for (std::size_t i = 0; i < n; ++i) x[i] = detail::fast_exp(x[i]);
#endif
}

// Eq. (8)'s sums over 16 components: (sum e, sum e mu_0, sum e mu_1, sum e mu_2), mu: 3 rows
// of st.
inline void add_weighted(const float* e, const float* mu, std::size_t st,
                         detail::ConditionalColour<float>& sums) {
  for (std::size_t j = 0; j < 16; ++j) sums.add(e[j], mu[j], mu[st + j], mu[2 * st + j]);
}

// The colour of Eq. (8): sum e mu / sum e.
inline void weighted_mean(const detail::ConditionalColour<float>& sums, float out[3]) {
  const std::array<float, 3> e = sums.expectation();
  for (std::size_t c = 0; c < 3; ++c) out[c] = e[c];
}

// One pixel in the factored form: e_k = ex[k] * ey[k] over the live vectors (offsets o =
// live[i] * 16 into ex and mu; ey compact, 16 a live vector), and the colour of Eq. (8),
// sum e mu / sum e. mu: 3 rows of st.
void factored_colour(std::size_t n_live, const std::uint32_t* live, const float* ex,
                     const float* ey, const float* mu, std::size_t st, float out[3]) {
#if defined(__AVX512F__)
  __m512 sum = _mm512_setzero_ps(), c0 = sum, c1 = sum, c2 = sum;
  for (std::size_t i = 0; i < n_live; ++i) {
    const std::size_t o = std::size_t(live[i]) * 16;
    const __m512 e = _mm512_mul_ps(_mm512_loadu_ps(ex + o), _mm512_loadu_ps(ey + i * 16));
    sum = _mm512_add_ps(sum, e);
    c0 = _mm512_fmadd_ps(e, _mm512_loadu_ps(mu + o), c0);
    c1 = _mm512_fmadd_ps(e, _mm512_loadu_ps(mu + st + o), c1);
    c2 = _mm512_fmadd_ps(e, _mm512_loadu_ps(mu + 2 * st + o), c2);
  }
  const float inv = 1.0f / detail::hsum16(sum);
  out[0] = detail::hsum16(c0) * inv;
  out[1] = detail::hsum16(c1) * inv;
  out[2] = detail::hsum16(c2) * inv;
#else
  float e[16];
  detail::ConditionalColour<float> sums;
  for (std::size_t i = 0; i < n_live; ++i) {
    const std::size_t o = std::size_t(live[i]) * 16;
    for (std::size_t j = 0; j < 16; ++j) e[j] = ex[o + j] * ey[i * 16 + j];
    add_weighted(e, mu + o, st, sums);
  }
  weighted_mean(sums, out);
#endif
}

// Four pixels of a row (columns ex[0..3]) at once: factored_colour, sharing the loads of ey
// and mu.
void factored_colour4(std::size_t n_live, const std::uint32_t* live, const float* const ex[4],
                      const float* ey, const float* mu, std::size_t st, float out[4][3]) {
#if defined(__AVX512F__)
  __m512 sum[4], c0[4], c1[4], c2[4];
  for (int p = 0; p < 4; ++p) sum[p] = c0[p] = c1[p] = c2[p] = _mm512_setzero_ps();
  for (std::size_t i = 0; i < n_live; ++i) {
    const std::size_t o = std::size_t(live[i]) * 16;
    const __m512 y = _mm512_loadu_ps(ey + i * 16), m0 = _mm512_loadu_ps(mu + o),
                 m1 = _mm512_loadu_ps(mu + st + o), m2 = _mm512_loadu_ps(mu + 2 * st + o);
    for (int p = 0; p < 4; ++p) {
      const __m512 e = _mm512_mul_ps(_mm512_loadu_ps(ex[p] + o), y);
      sum[p] = _mm512_add_ps(sum[p], e);
      c0[p] = _mm512_fmadd_ps(e, m0, c0[p]);
      c1[p] = _mm512_fmadd_ps(e, m1, c1[p]);
      c2[p] = _mm512_fmadd_ps(e, m2, c2[p]);
    }
  }
  for (int p = 0; p < 4; ++p) {
    const float inv = 1.0f / detail::hsum16(sum[p]);
    out[p][0] = detail::hsum16(c0[p]) * inv;
    out[p][1] = detail::hsum16(c1[p]) * inv;
    out[p][2] = detail::hsum16(c2[p]) * inv;
  }
#else
  for (int p = 0; p < 4; ++p) factored_colour(n_live, live, ex[p], ey, mu, st, out[p]);
#endif
}

// One pixel in the additive form, where the factors could leave float's range: t = a + x + y
// over the live vectors, each pixel's own maximum first, then sum exp(t - max) mu / sum
// exp(t - max). t: scratch of n_live * 16 floats.
void additive_colour(std::size_t n_live, const std::uint32_t* live, const float* a, const float* xr,
                     const float* yr, const float* mu, std::size_t st, float* t, float out[3]) {
  float mx = -INFINITY;
  for (std::size_t i = 0; i < n_live; ++i) {
    const std::size_t o = std::size_t(live[i]) * 16;
    for (std::size_t j = 0; j < 16; ++j) {
      t[i * 16 + j] = a[o + j] + xr[o + j] + yr[o + j];
      mx = std::max(mx, t[i * 16 + j]);
    }
  }
  for (std::size_t j = 0; j < n_live * 16; ++j) t[j] -= mx;
  exp_in_place(t, n_live * 16);
  detail::ConditionalColour<float> sums;
  for (std::size_t i = 0; i < n_live; ++i)
    add_weighted(t + i * 16, mu + std::size_t(live[i]) * 16, st, sums);
  weighted_mean(sums, out);
}

// Throws Error(kArgument) for a direction off the hemisphere or a bad tolerance, and
// Error(kLimit) where the images and the model's tables would not fit in memory.
void check_decode(const BtfModel& model, const DirectionSet& lights, const DirectionSet& views,
                  int width, int height, double tolerance) {
  for (const auto& d : lights) detail::check_direction(d, "light");
  for (const auto& d : views) detail::check_direction(d, "view");
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance))
    throw Error(
        Error::Kind::kArgument,
        fmt::format("decode tolerance {} must be a finite number of levels >= 0", tolerance));
  // The images and the model's tables, before allocating either.
  const double padded = double((model.mixture.size() + 15) / 16 * 16);
  limits::check_memory(double(lights.size()) * double(views.size()) * width * height * 12.0 +
                           double(2 * (model.width + model.height) + lights.size() + views.size()) *
                               (padded * 4.0 + 12.0),
                       fmt::format("decoding {} images of {}x{} pixels from a {}x{} tile with "
                                   "M = {}",
                                   lights.size() * views.size(), width, height, model.width,
                                   model.height, model.mixture.size()),
                       "decode a smaller size (`size`) or fewer directions (`light`, `view`)");
}

// Eq. (9)'s exponent on the grid splits into parts that depend on one input each:
//   t_m(x, y, l, v) = base_m + X_m(x) + Y_m(y) + L_m(l) + V_m(v)
// (log_weight_base and the terms of Eq. 10, X and Y wrapped around the tile), one table each,
// and the colour means of Eq. (8).
// Table column k holds component order[k]; padding columns have base = -1e30.
struct GridTables {
  std::size_t stride = 0, chunks = 0;  // columns (M rounded up to 16), vectors of 16
  std::vector<float> x, y, light, view;
  std::vector<float> mu;  // 3 rows of `stride`
};

GridTables grid_tables(const BtfModel& model, const DirectionSet& lights,
                       const DirectionSet& views) {
  const ProductMixture& mix = model.mixture;
  const std::size_t m_count = mix.size(), tw = std::size_t(model.width),
                    th = std::size_t(model.height);
  const auto& u = model.scaling.unit;
  const std::vector<std::size_t> order = detail::kd_order(mix, {0, 1}, 16);
  const std::vector<double> base = detail::log_weight_bases(mix);
  const detail::Periods periods = detail::model_periods(model);
  auto g = [&](std::size_t k, int n, double x) {
    const std::size_t m = order[k];
    return detail::log_marginal_term(x, mix.mean[m][std::size_t(n)], mix.var[m][std::size_t(n)],
                                     periods[std::size_t(n)]);
  };
  GridTables t;
  const std::size_t st = t.stride = (m_count + 15) / 16 * 16;
  t.chunks = st / 16;
  t.x.assign(tw * st, 0.0f);
  t.y.assign(th * st, 0.0f);
  t.light.assign(lights.size() * st, -1e30f);
  t.view.assign(views.size() * st, 0.0f);
  t.mu.assign(3 * st, 0.0f);
  for (std::size_t x = 0; x < tw; ++x)
    for (std::size_t k = 0; k < m_count; ++k) t.x[x * st + k] = float(g(k, 0, double(x)));
  for (std::size_t y = 0; y < th; ++y)
    for (std::size_t k = 0; k < m_count; ++k) t.y[y * st + k] = float(g(k, 1, double(y)));
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const detail::AngleInputs a = detail::angle_inputs(lights[l], u, 2);
    for (std::size_t k = 0; k < m_count; ++k)
      t.light[l * st + k] = float(base[order[k]] + g(k, 2, a.alpha) + g(k, 3, a.beta));
  }
  for (std::size_t v = 0; v < views.size(); ++v) {
    const detail::AngleInputs a = detail::angle_inputs(views[v], u, 4);
    for (std::size_t k = 0; k < m_count; ++k)
      t.view[v * st + k] = float(g(k, 4, a.alpha) + g(k, 5, a.beta));
  }
  for (std::size_t k = 0; k < m_count; ++k)
    for (std::size_t c = 0; c < 3; ++c) t.mu[c * st + k] = float(mix.mean[order[k]][6 + c]);
  return t;
}

// Per block of tile columns (rows): the largest and smallest X (Y) over it.
struct BlockExtremes {
  std::vector<float> hi, lo;
};

BlockExtremes block_extremes(const std::vector<float>& table, std::size_t count, std::size_t blocks,
                             std::size_t st) {
  BlockExtremes e{std::vector<float>(blocks * st, -INFINITY),
                  std::vector<float>(blocks * st, INFINITY)};
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t k = 0; k < st; ++k) {
      const std::size_t b = i / kDecodeBlock;
      e.hi[b * st + k] = std::max(e.hi[b * st + k], table[i * st + k]);
      e.lo[b * st + k] = std::min(e.lo[b * st + k], table[i * st + k]);
    }
  return e;
}

// The factor exp(X(x) - largest X of x's block) of every column (row).
std::vector<float> block_factors(const std::vector<float>& table, const std::vector<float>& hi,
                                 std::size_t count, std::size_t st) {
  std::vector<float> f(count * st);
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t k = 0; k < st; ++k)
      f[i * st + k] = table[i * st + k] - hi[(i / kDecodeBlock) * st + k];
  exp_in_place(f.data(), f.size());
  return f;
}

// Skipping (tolerance > 0). Over a block, U_m >= t_m >= L_m, and Lmax = max_m L_m is at most
// every pixel's largest t. A component with U_m < Lmax - T has a normalised weight below e^-T
// at every pixel of the block; all skipped together, below M e^-T. Leaving out a set of
// normalised weight eps moves the colour by at most eps times the spread R of the components'
// colour means, so T = ln(M R / tolerance) keeps every decoded value within `tolerance`
// levels of the full sum. Returns T (infinite for tolerance 0).
float skip_margin(const BtfModel& model, double tolerance) {
  const double spread = detail::colour_spread(model.mixture, model.scaling.unit);
  return tolerance > 0.0
             ? float(std::max(0.0, std::log(double(model.mixture.size()) * spread / tolerance)))
             : INFINITY;
}

// What every thread reads: the tables, the extremes and factors of X and Y per block.
struct DecodeGrid {
  GridTables t;
  std::size_t tw = 0, th = 0, bx_count = 0, by_count = 0;
  BlockExtremes x_ext, y_ext;
  std::vector<float> ex, ey;
  float margin = INFINITY;
  std::array<double, kVariables> unit{};
};

DecodeGrid decode_grid(const BtfModel& model, const DirectionSet& lights, const DirectionSet& views,
                       double tolerance) {
  DecodeGrid g;
  g.t = grid_tables(model, lights, views);
  g.tw = std::size_t(model.width);
  g.th = std::size_t(model.height);
  g.bx_count = (g.tw + kDecodeBlock - 1) / kDecodeBlock;
  g.by_count = (g.th + kDecodeBlock - 1) / kDecodeBlock;
  const std::size_t st = g.t.stride;
  g.x_ext = block_extremes(g.t.x, g.tw, g.bx_count, st);
  g.y_ext = block_extremes(g.t.y, g.th, g.by_count, st);
  g.ex = block_factors(g.t.x, g.x_ext.hi, g.tw, st);
  g.ey = block_factors(g.t.y, g.y_ext.hi, g.th, st);
  g.margin = skip_margin(model, tolerance);
  g.unit = model.scaling.unit;
  return g;
}

// A thread's scratch: am = L(l) + V(v) of the image, the bounds and kept factors of a block,
// its live vectors, and the decoded tile.
struct TileScratch {
  std::vector<float> am, ub, ea, eay, t, tile;
  std::vector<std::uint32_t> live;
  explicit TileScratch(const DecodeGrid& g)
      : am(g.t.stride),
        ub(g.t.stride),
        ea(g.t.stride),
        eay(kDecodeBlock * g.t.stride),
        t(g.t.stride),
        tile(g.tw * g.th * 3),
        live(g.t.chunks) {}
};

// A block's bounds of t: U (ub), Lmax and r = max U; the kept components' exp(U - r) exponents
// in ea (-1e30 for the skipped) and the live vectors.
struct BlockBounds {
  float lmax = -INFINITY, r = -INFINITY;
  std::size_t n_live = 0;
};

inline BlockBounds bound_block(const DecodeGrid& g, TileScratch& s, std::size_t bx,
                               std::size_t by) {
  const std::size_t st = g.t.stride;
  const float* xh = &g.x_ext.hi[bx * st];
  const float* xl = &g.x_ext.lo[bx * st];
  const float* yh = &g.y_ext.hi[by * st];
  const float* yl = &g.y_ext.lo[by * st];
  BlockBounds b;
  float lmax = -INFINITY, r = -INFINITY;
  for (std::size_t k = 0; k < st; ++k) {
    s.ub[k] = s.am[k] + xh[k] + yh[k];
    lmax = std::max(lmax, s.am[k] + xl[k] + yl[k]);
    r = std::max(r, s.ub[k]);
  }
  // The kept components: exp(U - r) (0 for the skipped), and the live vectors.
  const float keep = lmax - g.margin;
  for (std::size_t k = 0; k < st; ++k) s.ea[k] = s.ub[k] >= keep ? s.ub[k] - r : -1e30f;
  std::size_t n_live = 0;
  for (std::size_t j = 0; j < g.t.chunks; ++j) {
    bool any = false;
    for (std::size_t k = j * 16; k < j * 16 + 16; ++k) any = any || s.ub[k] >= keep;
    s.live[n_live] = std::uint32_t(j);
    n_live += any;
  }
  b.lmax = lmax;
  b.r = r;
  b.n_live = n_live;
  return b;
}

// The one-pass form: exp(t - r) = exp(U - r) exp(X(x) - Xmax) exp(Y(y) - Ymax), each factor
// <= 1 and tabulated, so a pixel costs one product per component and no exp. Here the product
// of the first and the third for the block's rows y0..y1 (eay, compact over the live vectors).
inline void block_row_factors(const DecodeGrid& g, TileScratch& s, std::size_t n_live,
                              std::size_t y0, std::size_t y1) {
  const std::size_t st = g.t.stride, chunks = g.t.chunks;
  exp_in_place(s.ea.data(), st);
  for (std::size_t y = y0; y < y1; ++y)
    for (std::size_t n = 0; n < n_live; ++n) {
      const std::size_t o = std::size_t(s.live[n]) * 16;
      for (std::size_t j = 0; j < 16; ++j)
        s.eay[((y - y0) * chunks + n) * 16 + j] = s.ea[o + j] * g.ey[y * st + o + j];
    }
}

// One block of the tile: the bounds, then every pixel's colour of Eq. (8) and the prediction of
// Eq. (11). One pass while r - Lmax leaves every relevant term well inside float's range;
// otherwise each pixel's own maximum first, then exp(t - max).
inline void decode_block(const DecodeGrid& g, TileScratch& s, const std::array<float, 3>& mb,
                         std::size_t bx, std::size_t by) {
  const std::size_t st = g.t.stride, chunks = g.t.chunks, tw = g.tw;
  const std::size_t x0 = bx * kDecodeBlock, x1 = std::min(tw, x0 + kDecodeBlock);
  const std::size_t y0 = by * kDecodeBlock, y1 = std::min(g.th, y0 + kDecodeBlock);
  const BlockBounds b = bound_block(g, s, bx, by);
  const std::size_t n_live = b.n_live;
  const bool one_pass = b.r - b.lmax <= 60.0f;
  if (one_pass) block_row_factors(g, s, n_live, y0, y1);
  const auto& u = g.unit;
  auto put = [&](std::size_t x, std::size_t y, const float c[3]) {
    const std::size_t p = y * tw + x;
    for (std::size_t k = 0; k < 3; ++k)
      s.tile[p * 3 + k] = float(detail::predicted_value(double(c[k]), u[6 + k], double(mb[k])));
  };
  const float* mu = g.t.mu.data();
  for (std::size_t y = y0; y < y1; ++y) {
    std::size_t x = x0;
    const float* eyr = &s.eay[(y - y0) * chunks * 16];
    if (one_pass)
      for (; x + 4 <= x1; x += 4) {
        const float* cols[4] = {&g.ex[x * st], &g.ex[(x + 1) * st], &g.ex[(x + 2) * st],
                                &g.ex[(x + 3) * st]};
        float c4[4][3];
        factored_colour4(n_live, s.live.data(), cols, eyr, mu, st, c4);
        for (std::size_t p = 0; p < 4; ++p) put(x + p, y, c4[p]);
      }
    for (; x < x1; ++x) {
      float c[3];
      if (one_pass)
        factored_colour(n_live, s.live.data(), &g.ex[x * st], eyr, mu, st, c);
      else
        additive_colour(n_live, s.live.data(), s.am.data(), &g.t.x[x * st], &g.t.y[y * st], mu, st,
                        s.t.data(), c);
      put(x, y, c);
    }
  }
}

// The tile of light l and view v, block by block, into s.tile.
inline void decode_tile(const DecodeGrid& g, TileScratch& s, std::size_t l, std::size_t v,
                        const std::array<float, 3>& mb) {
  const std::size_t st = g.t.stride;
  for (std::size_t k = 0; k < st; ++k) s.am[k] = g.t.light[l * st + k] + g.t.view[v * st + k];
  for (std::size_t by = 0; by < g.by_count; ++by)
    for (std::size_t bx = 0; bx < g.bx_count; ++bx) decode_block(g, s, mb, bx, by);
}

}  // namespace

Btf decode(const BtfModel& model, const DirectionSet& lights, const DirectionSet& views, int width,
           int height, double tolerance) {
  check_decode(model, lights, views, width, height, tolerance);
  Btf out(lights, views, width, height, model.format);
  const DecodeGrid grid = decode_grid(model, lights, views, tolerance);
  const detail::MeanBrdfInterpolator mean(model);
  const std::ptrdiff_t pairs = std::ptrdiff_t(lights.size() * views.size());
#pragma omp parallel
  {
    const detail::FlushDenormals flush;
    TileScratch scratch(grid);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t i = 0; i < pairs; ++i) {
      const std::size_t l = std::size_t(i) / views.size(), v = std::size_t(i) % views.size();
      decode_tile(grid, scratch, l, v, mean.at(lights[l], views[v]));
      detail::repeat_tile(scratch.tile.data(), model.width, model.height, width, height,
                          out.image(l, v));
    }
  }
  return out;
}

}  // namespace btfgmm
