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

Btf decode(const BtfModel& model, const DirectionSet& lights, const DirectionSet& views, int width,
           int height) {
  for (const auto& d : lights) check_direction(d, "light");
  for (const auto& d : views) check_direction(d, "view");
  // The images and the model's per-pixel table, before allocating either.
  const double padded = double((model.mixture.size() + 15) / 16 * 16);
  limits::check_memory(double(lights.size()) * double(views.size()) * width * height * 12.0 +
                           double(model.width) * model.height * (padded * 4.0 + 12.0),
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
  // Grid-factored log conditional weights, as in the fit: S (tile pixel), L (light), V (view).
  const std::vector<double> base = input_base(mix);
  auto g = [&](std::size_t m, int k, double x) {
    const double d = x - mix.mean[m][k];
    return -0.5 * d * d / mix.var[m][k];
  };
  // Components padded to whole vectors of 16 (a padded component's log weight is -1e30).
  const std::size_t st = (m_count + 15) / 16 * 16;
  std::vector<float> s(tw * th * st, -1e30f), lt(lights.size() * st, 0.0f),
      vt(views.size() * st, 0.0f);
  for (std::size_t p = 0; p < tw * th; ++p)
    for (std::size_t m = 0; m < m_count; ++m)
      s[p * st + m] = float(base[m] + g(m, 0, double(p % tw)) + g(m, 1, double(p / tw)));
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const OnionSlice o = to_onion_slice(lights[l]);
    for (std::size_t m = 0; m < m_count; ++m)
      lt[l * st + m] = float(g(m, 2, o.alpha / u[2]) + g(m, 3, o.beta / u[3]));
  }
  for (std::size_t v = 0; v < views.size(); ++v) {
    const OnionSlice o = to_onion_slice(views[v]);
    for (std::size_t m = 0; m < m_count; ++m)
      vt[v * st + m] = float(g(m, 4, o.alpha / u[4]) + g(m, 5, o.beta / u[5]));
  }
  std::vector<float> mu(3 * st, 0.0f);
  for (std::size_t m = 0; m < m_count; ++m)
    for (int c = 0; c < 3; ++c) mu[c * st + m] = float(mix.mean[m][6 + c]);
  // Components below the maximum log weight by more than this add less than float resolution
  // (M e^-margin = e^-17.5 relative) and are skipped a vector at a time.
  const float margin = float(std::log(double(m_count)) + 17.5);
  const MeanBrdfInterpolator mean(model);
  const std::ptrdiff_t pairs = std::ptrdiff_t(lights.size() * views.size());
#pragma omp parallel
  {
    std::vector<float> lv(st), t(st), tile(tw * th * 3);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t i = 0; i < pairs; ++i) {
      const std::size_t l = std::size_t(i) / views.size(), v = std::size_t(i) % views.size();
      for (std::size_t m = 0; m < st; ++m) lv[m] = lt[l * st + m] + vt[v * st + m];
      const auto mb = mean.at(lights[l], views[v]);
      for (std::size_t p = 0; p < tw * th; ++p) {
        float c[3];
#if defined(__AVX512F__)
        detail::conditional_colour16(st, &s[p * st], lv.data(), mu.data(), t.data(), margin, c);
#else
        const float* sp = &s[p * st];
        float mx = -INFINITY;
        for (std::size_t m = 0; m < st; ++m) mx = std::max(mx, t[m] = sp[m] + lv[m]);
        float sum = 0, c0 = 0, c1 = 0, c2 = 0;
#pragma omp simd reduction(+ : sum, c0, c1, c2)
        for (std::size_t m = 0; m < st; ++m) {
          const float w = detail::fast_exp(t[m] - mx);
          sum += w;
          c0 += w * mu[m];
          c1 += w * mu[st + m];
          c2 += w * mu[2 * st + m];
        }
        c[0] = c0 / sum;
        c[1] = c1 / sum;
        c[2] = c2 / sum;
        (void)margin;
#endif
        tile[p * 3 + 0] = float(double(c[0]) * u[6] + mb[0]);  // Eq. (11)
        tile[p * 3 + 1] = float(double(c[1]) * u[7] + mb[1]);
        tile[p * 3 + 2] = float(double(c[2]) * u[8] + mb[2]);
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
