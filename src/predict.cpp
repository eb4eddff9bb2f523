// Prediction, Eq. (8)-(11): the conditional weights W_m(x_I) of the six inputs (Eq. 9-10),
// the conditional expectation of the colour sum_m W_m mu_m,7..9 (Eq. 8 integrated), plus the
// mean BRDF (Eq. 11), interpolated between measured directions where needed.
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <exception>

#include "btfgmm/error.hpp"
#include "btfgmm/model.hpp"
#include "fast_exp.hpp"
#include "limits.hpp"
#if defined(__AVX512F__)
#include "em_avx512.hpp"
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

// Decoding works on blocks of kDecodeBlock x kDecodeBlock tile pixels of one image.
constexpr std::size_t kDecodeBlock = 16;

// The kept components of one (image, block), gathered and padded to whole vectors of 16:
// a = A_m - r, the rows X[x] and Y[y] of the block's columns and rows, the colour means.
struct DecodeScratch {
  std::vector<float> u, a, x, y, mu;
  std::vector<std::uint32_t> kept;
  std::vector<float> t;
  DecodeScratch(std::size_t stride)
      : u(stride),
        a(stride),
        x(kDecodeBlock * stride),
        y(kDecodeBlock * stride),
        mu(3 * stride),
        kept(stride),
        t(stride) {}
};

// Sum over the gathered components of e = exp(t), t = a + X[x] + Y[y] (minus the pixel's own
// maximum unless `one_pass`: t <= 0 holds already there), and of e mu: the colour of Eq. (8).
void decode_pixel(std::size_t n, const float* a, const float* xr, const float* yr, const float* mu,
                  float* t, bool one_pass, float out[3]) {
  const std::size_t st = n;
#if defined(__AVX512F__)
  __m512 mxv = _mm512_setzero_ps();
  if (!one_pass) {
    mxv = _mm512_set1_ps(-INFINITY);
    for (std::size_t j = 0; j < n; j += 16) {
      const __m512 v = _mm512_add_ps(_mm512_add_ps(_mm512_loadu_ps(a + j), _mm512_loadu_ps(xr + j)),
                                     _mm512_loadu_ps(yr + j));
      mxv = _mm512_max_ps(mxv, v);
    }
    mxv = _mm512_set1_ps(detail::hmax16(mxv));
  }
  __m512 sum = _mm512_setzero_ps(), c0 = sum, c1 = sum, c2 = sum;
  for (std::size_t j = 0; j < n; j += 16) {
    const __m512 v = _mm512_add_ps(_mm512_add_ps(_mm512_loadu_ps(a + j), _mm512_loadu_ps(xr + j)),
                                   _mm512_loadu_ps(yr + j));
    const __m512 w = detail::fast_exp16(_mm512_sub_ps(v, mxv));
    sum = _mm512_add_ps(sum, w);
    c0 = _mm512_fmadd_ps(w, _mm512_loadu_ps(mu + j), c0);
    c1 = _mm512_fmadd_ps(w, _mm512_loadu_ps(mu + st + j), c1);
    c2 = _mm512_fmadd_ps(w, _mm512_loadu_ps(mu + 2 * st + j), c2);
  }
  const float inv = 1.0f / detail::hsum16(sum);
  out[0] = detail::hsum16(c0) * inv;
  out[1] = detail::hsum16(c1) * inv;
  out[2] = detail::hsum16(c2) * inv;
  (void)t;
#else
  float mx = 0.0f;
  for (std::size_t j = 0; j < n; ++j) t[j] = a[j] + xr[j] + yr[j];
  if (!one_pass) {
    mx = -INFINITY;
    for (std::size_t j = 0; j < n; ++j) mx = std::max(mx, t[j]);
  }
  float sum = 0, c0 = 0, c1 = 0, c2 = 0;
#pragma omp simd reduction(+ : sum, c0, c1, c2)
  for (std::size_t j = 0; j < n; ++j) {
    const float w = detail::fast_exp(t[j] - mx);
    sum += w;
    c0 += w * mu[j];
    c1 += w * mu[st + j];
    c2 += w * mu[2 * st + j];
  }
  out[0] = c0 / sum;
  out[1] = c1 / sum;
  out[2] = c2 / sum;
#endif
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
  limits::check_memory(
      double(lights.size()) * double(views.size()) * width * height * 12.0 +
          double(model.width + model.height + lights.size() + views.size()) * (padded * 4.0 + 12.0),
      fmt::format("decoding {} images of {}x{} pixels from a {}x{} tile with "
                  "M = {}",
                  lights.size() * views.size(), width, height, model.width, model.height,
                  model.mixture.size()),
      "decode a smaller size (--size) or fewer directions (--light, --view)");
  Btf out(lights, views, width, height, model.format);
  const ProductMixture& mix = model.mixture;
  const std::size_t m_count = mix.size(), tw = std::size_t(model.width),
                    th = std::size_t(model.height);
  const auto& u = model.scaling.unit;
  // Eq. (9)'s exponent on the grid splits into parts that depend on one input each:
  //   t_m(x, y, l, v) = base_m + X_m(x) + Y_m(y) + L_m(l) + V_m(v).
  const std::vector<double> base = input_base(mix);
  auto g = [&](std::size_t m, int k, double x) {
    const double d = x - mix.mean[m][k];
    return -0.5 * d * d / mix.var[m][k];
  };
  const std::size_t st = (m_count + 15) / 16 * 16;
  std::vector<float> xt(tw * st, 0.0f), yt(th * st, 0.0f), lt(lights.size() * st, 0.0f),
      vt(views.size() * st, 0.0f);
  for (std::size_t x = 0; x < tw; ++x)
    for (std::size_t m = 0; m < m_count; ++m) xt[x * st + m] = float(g(m, 0, double(x)));
  for (std::size_t y = 0; y < th; ++y)
    for (std::size_t m = 0; m < m_count; ++m) yt[y * st + m] = float(g(m, 1, double(y)));
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const OnionSlice o = to_onion_slice(lights[l]);
    for (std::size_t m = 0; m < m_count; ++m)
      lt[l * st + m] = float(base[m] + g(m, 2, o.alpha / u[2]) + g(m, 3, o.beta / u[3]));
  }
  for (std::size_t v = 0; v < views.size(); ++v) {
    const OnionSlice o = to_onion_slice(views[v]);
    for (std::size_t m = 0; m < m_count; ++m)
      vt[v * st + m] = float(g(m, 4, o.alpha / u[4]) + g(m, 5, o.beta / u[5]));
  }
  // Per block of tile columns (rows): the largest and smallest X_m (Y_m) over it.
  const std::size_t bx_count = (tw + kDecodeBlock - 1) / kDecodeBlock,
                    by_count = (th + kDecodeBlock - 1) / kDecodeBlock;
  auto extremes = [&](const std::vector<float>& table, std::size_t count, std::size_t blocks) {
    std::vector<float> hi(blocks * st, -INFINITY), lo(blocks * st, INFINITY);
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t m = 0; m < st; ++m) {
        const std::size_t b = i / kDecodeBlock;
        hi[b * st + m] = std::max(hi[b * st + m], table[i * st + m]);
        lo[b * st + m] = std::min(lo[b * st + m], table[i * st + m]);
      }
    return std::pair{hi, lo};
  };
  const auto [xhi, xlo] = extremes(xt, tw, bx_count);
  const auto [yhi, ylo] = extremes(yt, th, by_count);
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
  std::vector<float> mu(3 * st, 0.0f);
  for (std::size_t m = 0; m < m_count; ++m)
    for (int c = 0; c < 3; ++c) mu[c * st + m] = float(mix.mean[m][6 + c]);
  const MeanBrdfInterpolator mean(model);
  const std::ptrdiff_t pairs = std::ptrdiff_t(lights.size() * views.size());
#pragma omp parallel
  {
    DecodeScratch w(st);
    std::vector<float> tile(tw * th * 3);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t i = 0; i < pairs; ++i) {
      const std::size_t l = std::size_t(i) / views.size(), v = std::size_t(i) % views.size();
      const float* lrow = &lt[l * st];
      const float* vrow = &vt[v * st];
      const auto mb = mean.at(lights[l], views[v]);
      for (std::size_t by = 0; by < by_count; ++by)
        for (std::size_t bx = 0; bx < bx_count; ++bx) {
          const float* xh = &xhi[bx * st];
          const float* xl = &xlo[bx * st];
          const float* yh = &yhi[by * st];
          const float* yl = &ylo[by * st];
          // Bounds of t over the block, and the kept components.
          float lmax = -INFINITY, r = -INFINITY;
          for (std::size_t m = 0; m < m_count; ++m) {
            const float am = lrow[m] + vrow[m];
            w.u[m] = am + xh[m] + yh[m];
            lmax = std::max(lmax, am + xl[m] + yl[m]);
          }
          std::size_t n = 0;
          for (std::size_t m = 0; m < m_count; ++m)
            if (w.u[m] >= lmax - margin) {
              w.kept[n++] = std::uint32_t(m);
              r = std::max(r, w.u[m]);
            }
          const std::size_t np = (n + 15) / 16 * 16;
          const std::size_t x0 = bx * kDecodeBlock, x1 = std::min(tw, x0 + kDecodeBlock);
          const std::size_t y0 = by * kDecodeBlock, y1 = std::min(th, y0 + kDecodeBlock);
          // One pass (exp(t - r), no per-pixel maximum) while r - Lmax leaves every
          // relevant term well inside float's range.
          const bool one_pass = r - lmax <= 60.0f;
          const float ref = one_pass ? r : 0.0f;
          for (std::size_t k = 0; k < np; ++k) {
            const bool real = k < n;
            const std::size_t m = real ? w.kept[k] : 0;
            w.a[k] = real ? lrow[m] + vrow[m] - ref : -1e30f;
            for (std::size_t x = x0; x < x1; ++x)
              w.x[(x - x0) * np + k] = real ? xt[x * st + m] : 0.0f;
            for (std::size_t y = y0; y < y1; ++y)
              w.y[(y - y0) * np + k] = real ? yt[y * st + m] : 0.0f;
            for (std::size_t c = 0; c < 3; ++c) w.mu[c * np + k] = real ? mu[c * st + m] : 0.0f;
          }
          for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = x0; x < x1; ++x) {
              float c[3];
              decode_pixel(np, w.a.data(), &w.x[(x - x0) * np], &w.y[(y - y0) * np], w.mu.data(),
                           w.t.data(), one_pass, c);
              const std::size_t p = y * tw + x;
              tile[p * 3 + 0] = float(double(c[0]) * u[6] + mb[0]);  // Eq. (11)
              tile[p * 3 + 1] = float(double(c[1]) * u[7] + mb[1]);
              tile[p * 3 + 2] = float(double(c[2]) * u[8] + mb[2]);
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
