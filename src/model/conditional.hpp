// The prediction of the paper's Eq. (8)-(11), one function per equation, shared by its three
// implementations: predict() (double, one query at a time), decode() (float tables on the
// tile's grid) and the renderer's ModelEvaluator (float component records, exp2, 16 points a
// vector). They differ in how they batch and vectorise, not in the mathematics
// (docs/ALGORITHM.md, "Prediction, Eq. (8)-(11)"; docs/RENDERING.md, "The kernel").
//
// For inputs x_I = (x, y, alpha_i, beta_i, alpha_v, beta_v) in model units:
//   Eq. (10)  log F(x_I | mu_m, sigma_m) = sum_{n in I} log f_n(x_n | mu_mn, sigma_mn)
//   Eq. (9)   W_m(x_I) = w_m F_m / sum_j w_j F_j, from the exponents
//             t_m = log w_m + log F_m = log_weight_base + sum_n log_marginal_term
//   Eq. (8)   E{x_n | x_I} = sum_m W_m(x_I) mu_mn, n = 7, 8, 9 (conditional_colour)
//   Eq. (11)  the prediction = E{x_n | x_I} in data units + the mean BRDF at (light, view).
// The functions are inline: each caller compiles them with its own floating-point flags, as
// it compiled the same expressions before they were named here.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <vector>

#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/error.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/predict.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {

// ---- the inputs x_I -----------------------------------------------------------------------

// Throws Error(kArgument) for a direction that is not on the upper hemisphere.
inline void check_direction(const Direction& d, const char* what) {
  if (!std::isfinite(d.theta_deg) || !std::isfinite(d.phi_deg) || d.theta_deg < 0.0 ||
      d.theta_deg > 90.0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} direction theta={} phi={} is not on the upper hemisphere; give "
                            "theta in [0, 90] degrees and a finite phi",
                            what, d.theta_deg, d.phi_deg));
}

// Throws Error(kArgument) for a decode request off the hemisphere or of a size no image takes.
inline void check_decode_request(const DirectionSet& lights, const DirectionSet& views, int width,
                                 int height) {
  for (const auto& d : lights) check_direction(d, "light");
  for (const auto& d : views) check_direction(d, "view");
  if (width < 1 || height < 1 || width > limits::kMaxImageSide || height > limits::kMaxImageSide)
    throw Error(Error::Kind::kArgument, fmt::format("decode size {}x{}: give 1..{} pixels a side",
                                                    width, height, limits::kMaxImageSide));
}

// Throws Error(kArgument) for a query off the hemisphere or at a position that is not finite.
inline void check_queries(std::span<const Query> queries) {
  for (const Query& q : queries) {
    check_direction(q.light, "light");
    check_direction(q.view, "view");
    if (!std::isfinite(q.x) || !std::isfinite(q.y))
      throw Error(Error::Kind::kArgument,
                  fmt::format("pixel position x={} y={} is not finite; give finite x and y "
                              "(any real number: the tile repeats)",
                              q.x, q.y));
  }
}

// The tile image `tile` (tw x th, RGB) repeated over an image of width x height.
inline void repeat_tile(const float* tile, int tw, int th, int width, int height, float* out) {
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::size_t p = std::size_t(y % th) * std::size_t(tw) + std::size_t(x % tw);
      for (int c = 0; c < 3; ++c)
        out[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)] =
            tile[p * 3 + std::size_t(c)];
    }
}

// A pixel coordinate modulo the tile's side (the tile repeats); one already inside is
// returned as is.
inline double tile_coordinate(double x, int period) {
  return wrap_into_period(x, double(period));
}

// The periods of the nine variables of a model: x and y wrap around its tile
// (mixture_internal.hpp, "The tile wraps"), whichever file it was read from.
inline Periods model_periods(const BtfModel& model) {
  return variable_periods({double(model.width), double(model.height)});
}

// The onion-slice angles of a direction in model units: inputs n and n + 1 of x_I (n = 2 for
// the light, 4 for the view).
struct AngleInputs {
  double alpha = 0.0, beta = 0.0;
};
inline AngleInputs angle_inputs(const Direction& d, const std::array<double, kVariables>& unit,
                                int n) {
  const OnionSlice o = to_onion_slice(d);
  return {o.alpha / unit[std::size_t(n)], o.beta / unit[std::size_t(n) + 1]};
}

// The inputs x_I of a query in model units (the tile position wrapped into the tile).
inline void query_inputs(const BtfModel& model, const Query& q, double x[kInputs]) {
  const auto& u = model.scaling.unit;
  const AngleInputs l = angle_inputs(q.light, u, 2), v = angle_inputs(q.view, u, 4);
  x[0] = tile_coordinate(q.x, model.width);
  x[1] = tile_coordinate(q.y, model.height);
  x[2] = l.alpha;
  x[3] = l.beta;
  x[4] = v.alpha;
  x[5] = v.beta;
}

// ---- Eq. (9)-(10): the exponents t_m ------------------------------------------------------

// The part of Eq. (9)'s exponent t_m = log(w_m F_m(x_I)) that does not depend on x_I:
// log w_m - 1/2 sum_{n in I} log sigma^2_mn (Eq. 10's normalisations; the common 2 pi
// cancels in Eq. 9).
inline double log_weight_base(const ProductMixture& mix, std::size_t m) {
  double b = std::log(mix.weight[m]);
  for (int n = 0; n < kInputs; ++n) b -= 0.5 * std::log(mix.var[m][std::size_t(n)]);
  return b;
}
inline std::vector<double> log_weight_bases(const ProductMixture& mix) {
  std::vector<double> b(mix.size());
  for (std::size_t m = 0; m < mix.size(); ++m) b[m] = log_weight_base(mix, m);
  return b;
}

// Eq. (10): the term of input n in the exponent, log f_n(x_n | mu_mn, sigma_mn) less the
// constant in log_weight_base: -(x_n - mu_mn)^2 / (2 sigma^2_mn), x_n - mu_mn in the minimum
// image for x and y (`period` W or H; 0 for the angles).
inline double log_marginal_term(double x, double mu, double var, double period) {
  return gauss_exponent(x, mu, var, period);  // Eq. (2)'s term of one variable
}

// The same term in log2 units as a square, for the float kernels:
// log2(e) (x - mu)^2 / (2 sigma^2) = (x s - s mu)^2 with s^2 = log2(e) / (2 sigma^2).
// A wrapped input (period P > 0) is given to the kernels as the fraction of its period
// u = x / P in [0, 1), with the scale S = s P and the offset s mu (mu wrapped into [0, P)):
// e = u S - s mu then lies in (-S, S), and the root of the minimum image's square is
// wrapped_root(e, S) = min(|e|, S - |e|). `mean` and `scale2` are in the units the kernel's
// input has (for the bounds): mu / P and S^2 for a wrapped input.
struct Log2MarginalTerm {
  double scale2 = 0.0, scale = 0.0, offset = 0.0;  // s^2, s, s mu (S^2, S, s mu)
  double mean = 0.0;                               // mu (mu / P)
  bool wrapped = false;
};
inline Log2MarginalTerm log2_marginal_term(double mu, double var, double period) {
  const double s2 = std::numbers::log2e / (2.0 * var);
  const double s = std::sqrt(s2);
  if (!(period > 0.0)) return {s2, s, s * mu, mu, false};
  const double m = wrap_into_period(mu, period);
  return {s2 * period * period, s * period, s * m, m / period, true};
}

// The root of the minimum image's square in the float kernels' units (Log2MarginalTerm): for
// e = u S - s mu in (-S, S), min(|e|, S - |e|), whose square is
// (s * wrapped_difference(x - mu, P))^2. Four instructions more than the plain term (a sign
// flip, a max, a subtraction, a min); the render kernel takes it only where a block of points
// holds a component's antipode (render/model_kernel.hpp). T: float or a vector of floats.
template <class T>
[[gnu::always_inline]] inline T wrapped_root(T e, float period_scale) {
  const T a = e > -e ? e : -e;  // |e| as a max
  const T b = period_scale - a;
  return a < b ? a : b;
}

// Eq. (9)'s exponent t_m at x_I: the base plus the six terms of Eq. (10).
inline double log_weight(double base, const std::array<double, kVariables>& mean,
                         const std::array<double, kVariables>& var, const double x[kInputs],
                         const Periods& periods) {
  double t = base;
  for (int n = 0; n < kInputs; ++n)
    t +=
        log_marginal_term(x[n], mean[std::size_t(n)], var[std::size_t(n)], periods[std::size_t(n)]);
  return t;
}

// Eq. (9): the conditional weights from the exponents, in place and up to their common
// normaliser: t_m becomes e_m = exp(t_m - max_j t_j) = W_m sum_j e_j (the largest 1, so that
// nothing overflows). ConditionalColour divides by sum_j e_j.
inline void conditional_weights(std::span<double> t) {
  double mx = -INFINITY;
  for (double v : t) mx = std::max(mx, v);
  for (double& v : t) v = std::exp(v - mx);
}

// ---- Eq. (8): the conditional expectation of the colour -----------------------------------

// E{x_n | x_I} = sum_m W_m mu_mn (n = 7, 8, 9), from unnormalised weights e_m = c W_m:
// add() each component's e_m and colour means, then sum e mu / sum e. T: double, float or a
// vector of floats (one lane a point).
template <class T>
struct ConditionalColour {
  T weight{};
  T colour[3]{};

  template <class M>
  [[gnu::always_inline]] inline void add(T e, M mu0, M mu1, M mu2) {
    weight += e;
    colour[0] += e * mu0;
    colour[1] += e * mu1;
    colour[2] += e * mu2;
  }
  std::array<T, 3> expectation() const {
    return {colour[0] / weight, colour[1] / weight, colour[2] / weight};
  }
};

// The spread R of the components' colour means in data units (the largest over the three
// channels): leaving out components of normalised weight eps moves Eq. (8)'s colour by at
// most eps R. The bound behind the skipping of decode() and the render kernel.
inline double colour_spread(const ProductMixture& mix, const std::array<double, kVariables>& unit) {
  double spread = 0.0;
  for (int c = 0; c < 3; ++c) {
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t m = 0; m < mix.size(); ++m) {
      lo = std::min(lo, mix.mean[m][std::size_t(6 + c)] * unit[std::size_t(6 + c)]);
      hi = std::max(hi, mix.mean[m][std::size_t(6 + c)] * unit[std::size_t(6 + c)]);
    }
    spread = std::max(spread, hi - lo);
  }
  return spread;
}

// ---- Eq. (11): the prediction -------------------------------------------------------------

// The mean BRDF of the measured light `l` and view `v` (3 floats; `views`: the number of
// measured views).
inline const float* measured_mean_brdf(std::span<const float> mean_brdf, std::size_t views,
                                       std::size_t l, std::size_t v) {
  return &mean_brdf[(l * views + v) * 3];
}

// The mean BRDF at any (light, view): the products of their barycentric weights over the
// measured directions (9 terms).
inline std::array<float, 3> mean_brdf_at(std::span<const float> mean_brdf, std::size_t views,
                                         const DirectionInterpolator::Weights& wl,
                                         const DirectionInterpolator::Weights& wv) {
  std::array<double, 3> rgb{0, 0, 0};
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t b = 0; b < 3; ++b) {
      const double w = wl.weight[a] * wv.weight[b];
      if (w == 0.0) continue;
      const float* mb = measured_mean_brdf(mean_brdf, views, wl.index[a], wv.index[b]);
      for (std::size_t c = 0; c < 3; ++c) rgb[c] += w * mb[c];
    }
  return {float(rgb[0]), float(rgb[1]), float(rgb[2])};
}

// mean_brdf_at() with DirectionInterpolator's weights over the model's direction sets.
struct MeanBrdfInterpolator {
  const BtfModel& model;
  DirectionInterpolator lights, views;
  explicit MeanBrdfInterpolator(const BtfModel& m) : model(m), lights(m.lights), views(m.views) {}
  std::array<float, 3> at(const Direction& l, const Direction& v) const {
    return mean_brdf_at(model.mean_brdf, model.views.size(), lights.weights(l), views.weights(v));
  }
};

// Eq. (11): one channel of the prediction, the conditional expectation (Eq. 8, model units)
// times the channel's unit plus the mean BRDF.
template <class T>
[[gnu::always_inline]] inline T predicted_value(T expectation, T unit, T mean_brdf) {
  return expectation * unit + mean_brdf;
}

}  // namespace btfgmm::detail
