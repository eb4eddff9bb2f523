// Prediction, Eq. (8)-(11): the conditional weights W_m(x_I) of the six inputs (Eq. 9-10),
// the conditional expectation of the colour sum_m W_m mu_m,7..9 (Eq. 8 integrated), plus the
// mean BRDF (Eq. 11), interpolated between measured directions where needed.
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/predict.hpp"
#include "core/fast_exp.hpp"
#include "core/flush_denormals.hpp"
#include "model/mixture_internal.hpp"
#if defined(__AVX512F__)
#include "model/em_avx512.hpp"
#endif

namespace btfgmm {
namespace {

double wrap(double x, int period) {
  double r = std::fmod(x, double(period));
  if (r < 0) r += period;
  return r >= period ? 0.0 : r;
}

void check_direction(const Direction& d, const char* what) {
  if (!std::isfinite(d.theta_deg) || !std::isfinite(d.phi_deg) || d.theta_deg < 0.0 ||
      d.theta_deg > 90.0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} direction theta={} phi={} is not on the upper hemisphere; give "
                            "theta in [0, 90] degrees and a finite phi",
                            what, d.theta_deg, d.phi_deg));
}

// Mean BRDF at any (light, view): the barycentric weights of both over the measured sets.
struct MeanBrdfInterpolator {
  const BtfModel& model;
  DirectionInterpolator lights, views;
  explicit MeanBrdfInterpolator(const BtfModel& m) : model(m), lights(m.lights), views(m.views) {}
  std::array<float, 3> at(const Direction& l, const Direction& v) const {
    const auto wl = lights.weights(l), wv = views.weights(v);
    std::array<double, 3> rgb{0, 0, 0};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        const double w = wl.weight[a] * wv.weight[b];
        if (w == 0.0) continue;
        const float* mb = &model.mean_brdf[(wl.index[a] * model.views.size() + wv.index[b]) * 3];
        for (int c = 0; c < 3; ++c) rgb[c] += w * mb[c];
      }
    return {float(rgb[0]), float(rgb[1]), float(rgb[2])};
  }
};

// log w_m - 1/2 sum_{n in I} log sigma^2 (the normalisation common to Eq. 9's numerator).
std::vector<double> input_base(const ProductMixture& mix) {
  std::vector<double> b(mix.size());
  for (std::size_t m = 0; m < mix.size(); ++m) {
    b[m] = std::log(mix.weight[m]);
    for (int n = 0; n < kInputs; ++n) b[m] -= 0.5 * std::log(mix.var[m][n]);
  }
  return b;
}

}  // namespace

void predict(const BtfModel& model, std::span<const Query> queries, std::span<float> rgb) {
  if (rgb.size() < queries.size() * 3)
    throw Error(Error::Kind::kArgument, "predict: the output holds fewer than 3 floats a query");
  for (const Query& q : queries) {
    check_direction(q.light, "light");
    check_direction(q.view, "view");
    if (!std::isfinite(q.x) || !std::isfinite(q.y))
      throw Error(Error::Kind::kArgument,
                  fmt::format("pixel position x={} y={} is not finite; give finite x and y "
                              "(any real number: the tile repeats)",
                              q.x, q.y));
  }
  const MeanBrdfInterpolator mean(model);
  const ProductMixture& mix = model.mixture;
  const std::vector<double> base = input_base(mix);
  const auto& u = model.scaling.unit;
  const std::ptrdiff_t n = std::ptrdiff_t(queries.size());
#pragma omp parallel
  {
    std::vector<double> t(mix.size());
#pragma omp for schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      const Query& q = queries[std::size_t(i)];
      const OnionSlice ol = to_onion_slice(q.light), ov = to_onion_slice(q.view);
      const double x[kInputs] = {wrap(q.x, model.width), wrap(q.y, model.height), ol.alpha / u[2],
                                 ol.beta / u[3],         ov.alpha / u[4],         ov.beta / u[5]};
      double mx = -INFINITY;
      for (std::size_t m = 0; m < mix.size(); ++m) {
        double l = base[m];
        for (int k = 0; k < kInputs; ++k) {
          const double d = x[k] - mix.mean[m][k];
          l -= 0.5 * d * d / mix.var[m][k];
        }
        t[m] = l;
        mx = std::max(mx, l);
      }
      double sum = 0, c0 = 0, c1 = 0, c2 = 0;
      for (std::size_t m = 0; m < mix.size(); ++m) {
        const double w = std::exp(t[m] - mx);  // Eq. (9), unnormalised
        sum += w;
        c0 += w * mix.mean[m][6];
        c1 += w * mix.mean[m][7];
        c2 += w * mix.mean[m][8];
      }
      const auto mb = mean.at(q.light, q.view);
      float* out = &rgb[std::size_t(i) * 3];
      out[0] = float(c0 / sum * u[6] + mb[0]);  // Eq. (11)
      out[1] = float(c1 / sum * u[7] + mb[1]);
      out[2] = float(c2 / sum * u[8] + mb[2]);
    }
  }
}

std::array<float, 3> predict(const BtfModel& model, const Query& query) {
  std::array<float, 3> rgb{};
  predict(model, std::span<const Query>(&query, 1), rgb);
  return rgb;
}

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

// sums += (sum e, sum e mu_0, sum e mu_1, sum e mu_2) over 16 components (mu: 3 rows of st).
inline void add_weighted(const float* e, const float* mu, std::size_t st, float sums[4]) {
  for (std::size_t j = 0; j < 16; ++j) {
    sums[0] += e[j];
    for (std::size_t c = 0; c < 3; ++c) sums[c + 1] += e[j] * mu[c * st + j];
  }
}

// The colour of Eq. (8): sum e mu / sum e.
inline void weighted_mean(const float sums[4], float out[3]) {
  for (int c = 0; c < 3; ++c) out[c] = sums[c + 1] / sums[0];
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
  float e[16], sums[4] = {0, 0, 0, 0};
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
  float sums[4] = {0, 0, 0, 0};
  for (std::size_t i = 0; i < n_live; ++i)
    add_weighted(t + i * 16, mu + std::size_t(live[i]) * 16, st, sums);
  weighted_mean(sums, out);
}

}  // namespace

Btf decode(const BtfModel& model, const DirectionSet& lights, const DirectionSet& views, int width,
           int height, double tolerance) {
  for (const auto& d : lights) check_direction(d, "light");
  for (const auto& d : views) check_direction(d, "view");
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
                       "decode a smaller size (--size) or fewer directions (--light, --view)");
  Btf out(lights, views, width, height, model.format);
  const ProductMixture& mix = model.mixture;
  const std::size_t m_count = mix.size(), tw = std::size_t(model.width),
                    th = std::size_t(model.height);
  const auto& u = model.scaling.unit;
  // Eq. (9)'s exponent on the grid splits into parts that depend on one input each:
  //   t_m(x, y, l, v) = base_m + X_m(x) + Y_m(y) + L_m(l) + V_m(v).
  // Table column k holds component order[k]; padding columns have base = -1e30.
  const std::vector<std::size_t> order = detail::kd_order(mix, {0, 1}, 16);
  const std::vector<double> base = input_base(mix);
  auto g = [&](std::size_t k, int n, double x) {
    const std::size_t m = order[k];
    const double d = x - mix.mean[m][n];
    return -0.5 * d * d / mix.var[m][n];
  };
  const std::size_t st = (m_count + 15) / 16 * 16, chunks = st / 16;
  std::vector<float> xt(tw * st, 0.0f), yt(th * st, 0.0f), lt(lights.size() * st, -1e30f),
      vt(views.size() * st, 0.0f), mu(3 * st, 0.0f);
  for (std::size_t x = 0; x < tw; ++x)
    for (std::size_t k = 0; k < m_count; ++k) xt[x * st + k] = float(g(k, 0, double(x)));
  for (std::size_t y = 0; y < th; ++y)
    for (std::size_t k = 0; k < m_count; ++k) yt[y * st + k] = float(g(k, 1, double(y)));
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const OnionSlice o = to_onion_slice(lights[l]);
    for (std::size_t k = 0; k < m_count; ++k)
      lt[l * st + k] = float(base[order[k]] + g(k, 2, o.alpha / u[2]) + g(k, 3, o.beta / u[3]));
  }
  for (std::size_t v = 0; v < views.size(); ++v) {
    const OnionSlice o = to_onion_slice(views[v]);
    for (std::size_t k = 0; k < m_count; ++k)
      vt[v * st + k] = float(g(k, 4, o.alpha / u[4]) + g(k, 5, o.beta / u[5]));
  }
  for (std::size_t k = 0; k < m_count; ++k)
    for (int c = 0; c < 3; ++c) mu[std::size_t(c) * st + k] = float(mix.mean[order[k]][6 + c]);
  // Per block of tile columns (rows): the largest and smallest X (Y) over it, and the factor
  // exp(X(x) - largest X of x's block) of every column (row).
  const std::size_t bx_count = (tw + kDecodeBlock - 1) / kDecodeBlock,
                    by_count = (th + kDecodeBlock - 1) / kDecodeBlock;
  auto extremes = [&](const std::vector<float>& table, std::size_t count, std::size_t blocks) {
    std::vector<float> hi(blocks * st, -INFINITY), lo(blocks * st, INFINITY);
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t k = 0; k < st; ++k) {
        const std::size_t b = i / kDecodeBlock;
        hi[b * st + k] = std::max(hi[b * st + k], table[i * st + k]);
        lo[b * st + k] = std::min(lo[b * st + k], table[i * st + k]);
      }
    return std::pair{hi, lo};
  };
  const auto [xhi, xlo] = extremes(xt, tw, bx_count);
  const auto [yhi, ylo] = extremes(yt, th, by_count);
  auto factors = [&](const std::vector<float>& table, const std::vector<float>& hi,
                     std::size_t count) {
    std::vector<float> f(count * st);
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t k = 0; k < st; ++k)
        f[i * st + k] = table[i * st + k] - hi[(i / kDecodeBlock) * st + k];
    exp_in_place(f.data(), f.size());
    return f;
  };
  const std::vector<float> ex = factors(xt, xhi, tw), ey = factors(yt, yhi, th);
  // Skipping (tolerance > 0). Over a block, U_m >= t_m >= L_m, and Lmax = max_m L_m is at most
  // every pixel's largest t. A component with U_m < Lmax - T has a normalised weight below
  // e^-T at every pixel of the block; all skipped together, below M e^-T. Leaving out a set
  // of normalised weight eps moves the colour (a weighted mean of the components' colour
  // means) by at most eps times the spread R of those means, so T = ln(M R / tolerance)
  // keeps every decoded value within `tolerance` levels of the full sum.
  double spread = 0.0;
  for (int c = 0; c < 3; ++c) {
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t m = 0; m < m_count; ++m) {
      lo = std::min(lo, mix.mean[m][6 + c] * u[6 + c]);
      hi = std::max(hi, mix.mean[m][6 + c] * u[6 + c]);
    }
    spread = std::max(spread, hi - lo);
  }
  const float margin = tolerance > 0.0
                           ? float(std::max(0.0, std::log(double(m_count) * spread / tolerance)))
                           : INFINITY;
  const MeanBrdfInterpolator mean(model);
  const std::ptrdiff_t pairs = std::ptrdiff_t(lights.size() * views.size());
#pragma omp parallel
  {
    const detail::FlushDenormals flush;
    std::vector<float> am(st), ub(st), ea(st), eay(kDecodeBlock * st), t(st), tile(tw * th * 3);
    std::vector<std::uint32_t> live(chunks);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t i = 0; i < pairs; ++i) {
      const std::size_t l = std::size_t(i) / views.size(), v = std::size_t(i) % views.size();
      for (std::size_t k = 0; k < st; ++k) am[k] = lt[l * st + k] + vt[v * st + k];
      const auto mb = mean.at(lights[l], views[v]);
      for (std::size_t by = 0; by < by_count; ++by)
        for (std::size_t bx = 0; bx < bx_count; ++bx) {
          const float* xh = &xhi[bx * st];
          const float* xl = &xlo[bx * st];
          const float* yh = &yhi[by * st];
          const float* yl = &ylo[by * st];
          const std::size_t x0 = bx * kDecodeBlock, x1 = std::min(tw, x0 + kDecodeBlock);
          const std::size_t y0 = by * kDecodeBlock, y1 = std::min(th, y0 + kDecodeBlock);
          // Bounds of t over the block: U (ub) and Lmax; r = max U.
          float lmax = -INFINITY, r = -INFINITY;
          for (std::size_t k = 0; k < st; ++k) {
            ub[k] = am[k] + xh[k] + yh[k];
            lmax = std::max(lmax, am[k] + xl[k] + yl[k]);
            r = std::max(r, ub[k]);
          }
          // The kept components: exp(U - r) (0 for the skipped), and the live vectors.
          const float keep = lmax - margin;
          for (std::size_t k = 0; k < st; ++k) ea[k] = ub[k] >= keep ? ub[k] - r : -1e30f;
          std::size_t n_live = 0;
          for (std::size_t j = 0; j < chunks; ++j) {
            bool any = false;
            for (std::size_t k = j * 16; k < j * 16 + 16; ++k) any = any || ub[k] >= keep;
            live[n_live] = std::uint32_t(j);
            n_live += any;
          }
          // One pass while r - Lmax leaves every relevant term well inside float's range:
          // exp(t - r) = exp(U - r) exp(X(x) - Xmax) exp(Y(y) - Ymax), each factor <= 1 and
          // tabulated, so a pixel costs one product per component and no exp. Otherwise each
          // pixel's own maximum first, then exp(t - max).
          const bool one_pass = r - lmax <= 60.0f;
          if (one_pass) {
            exp_in_place(ea.data(), st);
            for (std::size_t y = y0; y < y1; ++y)
              for (std::size_t n = 0; n < n_live; ++n) {
                const std::size_t o = std::size_t(live[n]) * 16;
                for (std::size_t j = 0; j < 16; ++j)
                  eay[((y - y0) * chunks + n) * 16 + j] = ea[o + j] * ey[y * st + o + j];
              }
          }
          auto put = [&](std::size_t x, std::size_t y, const float c[3]) {
            const std::size_t p = y * tw + x;
            tile[p * 3 + 0] = float(double(c[0]) * u[6] + mb[0]);  // Eq. (11)
            tile[p * 3 + 1] = float(double(c[1]) * u[7] + mb[1]);
            tile[p * 3 + 2] = float(double(c[2]) * u[8] + mb[2]);
          };
          for (std::size_t y = y0; y < y1; ++y) {
            std::size_t x = x0;
            const float* eyr = &eay[(y - y0) * chunks * 16];
            if (one_pass)
              for (; x + 4 <= x1; x += 4) {
                const float* cols[4] = {&ex[x * st], &ex[(x + 1) * st], &ex[(x + 2) * st],
                                        &ex[(x + 3) * st]};
                float c4[4][3];
                factored_colour4(n_live, live.data(), cols, eyr, mu.data(), st, c4);
                for (std::size_t p = 0; p < 4; ++p) put(x + p, y, c4[p]);
              }
            for (; x < x1; ++x) {
              float c[3];
              if (one_pass)
                factored_colour(n_live, live.data(), &ex[x * st], eyr, mu.data(), st, c);
              else
                additive_colour(n_live, live.data(), am.data(), &xt[x * st], &yt[y * st], mu.data(),
                                st, t.data(), c);
              put(x, y, c);
            }
          }
        }
      float* img = out.image(l, v);
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          const std::size_t p = std::size_t(y % model.height) * tw + std::size_t(x % model.width);
          for (int c = 0; c < 3; ++c) img[(std::size_t(y) * width + x) * 3 + c] = tile[p * 3 + c];
        }
    }
  }
  return out;
}

}  // namespace btfgmm
