// The float pass of the fit for the prediction, skipping the chunks of negligible components
// (model/refine_pass.hpp; docs/ALGORITHM.md, "Fitting for the prediction").
#include "model/refine_pass.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/fast_exp.hpp"
#include "model/conditional.hpp"

namespace btfgmm::detail {

namespace {

// Exponents of absent (padding) columns: their exp is exactly 0.
constexpr float kAbsentExponent = -1e30f;
constexpr std::size_t kAlign = 64;
// The values a loop of the tables or of the fold must have to be shared between threads.
constexpr std::size_t kParallelWork = std::size_t(1) << 18;

// The sum of a chunk's lane sums in a fixed order (halving), whatever the vector width.
float fold_lanes(float (&lane)[kChunk]) {
  for (std::size_t width = kChunk / 2; width >= 1; width /= 2)
    for (std::size_t i = 0; i < width; ++i) lane[i] += lane[i + width];
  return lane[0];
}

// The median standard deviation of input n over the components.
double median_deviation(const ProductMixture& mix, std::size_t n) {
  std::vector<double> sd(mix.size());
  for (std::size_t k = 0; k < mix.size(); ++k) sd[k] = std::sqrt(mix.var[k][n]);
  std::nth_element(sd.begin(), sd.begin() + std::ptrdiff_t(sd.size() / 2), sd.end());
  return sd[sd.size() / 2] > 0.0 ? sd[sd.size() / 2] : 1.0;
}

}  // namespace

SparsePass::Scratch::Scratch(std::size_t views, std::size_t stride)
    : t_storage(stride + kAlign / sizeof(float)),
      chunk_max(stride / kChunk),
      live(stride / kChunk) {
  taken.reserve(views);
}

float* SparsePass::Scratch::t() {
  const auto at = reinterpret_cast<std::uintptr_t>(t_storage.data());
  return t_storage.data() + ((kAlign - at % kAlign) % kAlign) / sizeof(float);
}

SparsePass::SparsePass(const SampleSet& s, std::size_t m, int threads)
    : s_(s),
      m_(m),
      stride_((m + kChunk - 1) / kChunk * kChunk),
      threads_(threads > 0 ? threads : omp_get_max_threads()),
      margin_(float(std::log(double(std::max<std::size_t>(m, 1))) + kSkipMargin)),
      periods_(variable_periods({double(s.width), double(s.height)})),
      pixel_(s.pixels() * stride_),
      light_(s.lights * stride_),
      view_(s.views * stride_),
      colour_(3 * stride_),
      spatial_(4 * stride_),
      per_light_(s.held_lights()),
      scratch_(std::size_t(threads_), Scratch(s.views, stride_)) {}

ColourNormalEquations SparsePass::normal_equations(const ProductMixture& mix, std::size_t stride,
                                                   const std::atomic<bool>* stop,
                                                   const std::function<void(double)>& progress) {
  return colour_normal_equations(s_, mix, threads_, stride, true, stop, progress);
}

PredictionGradient SparsePass::operator()(const ProductMixture& mix, const Selection& selection,
                                          bool gradient) {
  selection_ = selection;
  gradient_ = gradient;
  set_order(mix);
  set_tables(mix);
  sum_over_lights();
  return result(mix);
}

// The k-d order of the components' six input means, each input in units of its median
// standard deviation (so that no input's units decide the splits).
void SparsePass::set_order(const ProductMixture& mix) {
  ProductMixture scaled = mix;
  for (std::size_t n = 0; n < std::size_t(kInputs); ++n) {
    const double sd = median_deviation(mix, n);
    for (std::size_t k = 0; k < mix.size(); ++k) scaled.mean[k][n] = mix.mean[k][n] / sd;
  }
  order_ = kd_order(scaled, {0, 1, 2, 3, 4, 5}, kChunk);
}

// The exponents' parts t_m = pixel + light + view of Eq. (9)-(10) (grid_weights.hpp,
// exponent_parts) in the columns of the order, computed in double and kept in float.
void SparsePass::set_tables(const ProductMixture& mix) {
  const std::size_t st = stride_, width = std::size_t(s_.width);
  std::fill(pixel_.begin(), pixel_.end(), kAbsentExponent);
  std::fill(light_.begin(), light_.end(), 0.0f);
  std::fill(view_.begin(), view_.end(), 0.0f);
  std::fill(colour_.begin(), colour_.end(), 0.0f);
  std::fill(spatial_.begin(), spatial_.end(), 0.0f);
  // Threads only where the tables are large: a parallel region costs more than small ones.
  const bool large = s_.pixels() * m_ >= kParallelWork;
#pragma omp parallel for num_threads(threads_) schedule(static) if (large)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(m_); ++i) {
    const std::size_t k = std::size_t(i), c = order_[k];
    const double base = log_weight_base(mix, c);
    const auto& mu = mix.mean[c];
    const auto& var = mix.var[c];
    for (std::size_t p = 0; p < s_.pixels(); ++p)
      pixel_[p * st + k] =
          float(base + log_marginal_term(double(p % width), mu[0], var[0], periods_[0]) +
                log_marginal_term(double(p / width), mu[1], var[1], periods_[1]));
    for (std::size_t l = 0; l < s_.lights; ++l)
      light_[l * st + k] = float(log_marginal_term(s_.light_ab[l][0], mu[2], var[2], 0.0) +
                                 log_marginal_term(s_.light_ab[l][1], mu[3], var[3], 0.0));
    for (std::size_t v = 0; v < s_.views; ++v)
      view_[v * st + k] = float(log_marginal_term(s_.view_ab[v][0], mu[4], var[4], 0.0) +
                                log_marginal_term(s_.view_ab[v][1], mu[5], var[5], 0.0));
    for (std::size_t n = 0; n < 3; ++n) colour_[n * st + k] = float(mu[6 + n]);
    for (std::size_t n = 0; n < 2; ++n) {
      spatial_[n * st + k] = float(mu[n]);
      spatial_[(2 + n) * st + k] = float(1.0 / var[n]);
    }
  }
}

// The live chunks of a sample whose chunks' largest exponents sc.chunk_max holds: those
// within the margin of the largest, `top`, listed in sc.live. Returns their count.
std::size_t SparsePass::live_chunks(Scratch& sc, float& top) const {
  const std::size_t nc = chunks();
  const float* cmax = sc.chunk_max.data();
  top = -std::numeric_limits<float>::infinity();
  for (std::size_t j = 0; j < nc; ++j) top = std::max(top, cmax[j]);
  const float cut = top - margin_;
  std::size_t n_live = 0;
  for (std::size_t j = 0; j < nc; ++j) {
    sc.live[n_live] = std::uint32_t(j);
    n_live += cmax[j] >= cut ? 1 : 0;
  }
  return n_live;
}

// One sample's part (Eq. 8-10): its weights W_m = softmax(t_m) on the live chunks, the
// prediction yhat_c = sum_m W_m mu_m,6+c, its error, and with the gradient g_m = dE/dt_m.
void SparsePass::add_sample(std::size_t p, std::size_t l, std::size_t v, Scratch& sc,
                            LightSums& acc) const {
  const std::size_t st = stride_, nc = chunks();
  const float *tp = &pixel_[p * st], *tl = &light_[l * st], *tv = &view_[v * st];
  float* t = sc.t();
  for (std::size_t j = 0; j < nc; ++j) {
    const std::size_t o = j * kChunk;
    float cm = -std::numeric_limits<float>::infinity();
#pragma omp simd reduction(max : cm)
    for (std::size_t i = o; i < o + kChunk; ++i) {
      t[i] = tp[i] + tl[i] + tv[i];
      cm = cm > t[i] ? cm : t[i];
    }
    sc.chunk_max[j] = cm;
  }
  float top = 0.0f;
  const std::size_t n_live = live_chunks(sc, top);
  // e_m = exp(t_m - top), their sum and sum_m e_m mu_m,6+c in one sweep: W_m = e_m / sum.
  const float *mu0 = &colour_[0], *mu1 = &colour_[st], *mu2 = &colour_[2 * st];
  float lane[kChunk] = {}, y0[kChunk] = {}, y1[kChunk] = {}, y2[kChunk] = {};
  for (std::size_t n = 0; n < n_live; ++n) {
    const std::size_t o = std::size_t(sc.live[n]) * kChunk;
#pragma omp simd
    for (std::size_t i = 0; i < kChunk; ++i) {
      const float w = fast_exp(t[o + i] - top);
      t[o + i] = w;
      lane[i] += w;
      y0[i] += w * mu0[o + i];
      y1[i] += w * mu1[o + i];
      y2[i] += w * mu2[o + i];
    }
  }
  const float inv = 1.0f / fold_lanes(lane);
  const float y[3] = {fold_lanes(y0) * inv, fold_lanes(y1) * inv, fold_lanes(y2) * inv};
  float e[3];
  for (int c = 0; c < 3; ++c) {
    e[c] = s_.residual_of(p, l, v, c) - y[c];
    acc.error += double(e[c]) * double(e[c]);
  }
  ++acc.samples;
  acc.live_chunks += n_live;
  if (gradient_)
    add_gradient(p, v, t, inv, e, e[0] * y[0] + e[1] * y[1] + e[2] * y[2], n_live, sc, acc.sums);
}

// g_m = -2 W_m sum_c e_c (mu_m,6+c - yhat_c) of the live chunks added to the sums of the
// light, the view, the pixel's terms and the colour means: with d the minimum image of x - mu
// for x and y (computed here from the components' means, which stay in the first level of
// cache, rather than read from a table per pixel), g d / sigma^2 and g (d^2 / sigma^2 - 1) / 2.
void SparsePass::add_gradient(std::size_t p, std::size_t v, const float* w, float inv,
                              const float (&e)[3], float base, std::size_t n_live,
                              const Scratch& sc, float* sums) const {
  const std::size_t st = stride_;
  const float e0 = e[0], e1 = e[1], e2 = e[2], minus_two_inv = -2.0f * inv;
  const float *mu0 = &colour_[0], *mu1 = &colour_[st], *mu2 = &colour_[2 * st];
  const float *mean_x = &spatial_[0], *mean_y = &spatial_[st], *inv_x = &spatial_[2 * st],
              *inv_y = &spatial_[3 * st];
  const float px = float(p % std::size_t(s_.width)), py = float(p / std::size_t(s_.width));
  const float period_x = float(periods_[0]), period_y = float(periods_[1]);
  const float inv_period_x = 1.0f / period_x, inv_period_y = 1.0f / period_y;
  float *light = sums + at_light(), *view = sums + v * st;
  float *c0 = sums + at_colour(), *c1 = c0 + st, *c2 = c1 + st;
  float *mx = sums + at_position(), *my = mx + st, *sx = my + st, *sy = sx + st;
  for (std::size_t n = 0; n < n_live; ++n) {
    const std::size_t o = std::size_t(sc.live[n]) * kChunk;
#pragma omp simd
    for (std::size_t k = o; k < o + kChunk; ++k) {
      const float w2 = minus_two_inv * w[k];
      const float g = w2 * (e0 * mu0[k] + e1 * mu1[k] + e2 * mu2[k] - base);
      float dx = px - mean_x[k], dy = py - mean_y[k];
      dx -= period_x * std::floor(dx * inv_period_x + 0.5f);
      dy -= period_y * std::floor(dy * inv_period_y + 0.5f);
      const float rx = dx * inv_x[k], ry = dy * inv_y[k];
      light[k] += g;
      view[k] += g;
      mx[k] += g * rx;
      my[k] += g * ry;
      sx[k] += g * (0.5f * (dx * rx - 1.0f));
      sy[k] += g * (0.5f * (dy * ry - 1.0f));
      c0[k] += w2 * e0;
      c1[k] += w2 * e1;
      c2[k] += w2 * e2;
    }
  }
}

// Pixel p's samples of light l in the selection.
void SparsePass::add_pixel(std::size_t p, std::size_t l, Scratch& sc, LightSums& acc) const {
  const std::size_t nv = s_.views, pairs = s_.lights * nv, modulus = selection_.modulus;
  const std::size_t first = l * nv;
  sc.taken.clear();
  const std::size_t start = (selection_.residue + modulus - (p + first) % modulus) % modulus;
  for (std::size_t v = start; v < nv; v += modulus)
    if (selection_.takes(p, first + v, pairs)) sc.taken.push_back(std::uint32_t(v));
  for (const std::uint32_t v : sc.taken) add_sample(p, l, v, sc, acc);
}

// Every held light's sums, each light's in its own place (in float), then folded in light
// order over the processes, each cleared as it is folded.
void SparsePass::sum_over_lights() {
  const std::size_t held = s_.held_lights();
  if (gradient_ && light_sums_.empty()) light_sums_.assign(held * sums_size(), 0.0f);
  for (std::size_t i = 0; i < held; ++i)
    per_light_[i].sums = gradient_ ? &light_sums_[i * sums_size()] : nullptr;
#pragma omp parallel num_threads(threads_)
  {
    Scratch& sc = scratch_[std::size_t(omp_get_thread_num())];
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(held); ++i) {
      const std::size_t l = s_.first_light + std::size_t(i);
      for (std::size_t p = 0; p < s_.pixels(); ++p) add_pixel(p, l, sc, per_light_[std::size_t(i)]);
    }
  }
  const std::size_t size = gradient_ ? total_size() : 3;
  total_ = fold_over_processes(s_.processes.get(), size,
                               [this](std::vector<double>& t) { fold_lights(t); });
}

// This process's lights' sums added to the totals (in double) in light order, and cleared:
// each total gets the lights' values one after the other, as in a fold light by light, the
// totals split between the threads (each takes whole blocks of them).
void SparsePass::fold_lights(std::vector<double>& t) {
  const std::size_t held = s_.held_lights(), n = t.size();
  for (LightSums& acc : per_light_) {
    t[n - 3] += acc.error;
    t[n - 2] += double(acc.samples);
    t[n - 1] += double(acc.live_chunks);
    acc.error = 0.0;
    acc.samples = acc.live_chunks = 0;
  }
  if (!gradient_) return;
  constexpr std::size_t kBlock = 4096;
  const std::size_t shared = at_light(), st = stride_, blocks = (shared + kBlock - 1) / kBlock;
  double* total = t.data();
#pragma omp parallel num_threads(threads_) if (shared * held >= kParallelWork)
  {
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < std::ptrdiff_t(blocks); ++b) {
      const std::size_t begin = std::size_t(b) * kBlock, end = std::min(shared, begin + kBlock);
      for (std::size_t i = 0; i < held; ++i) {
        float* sums = per_light_[i].sums;
#pragma omp simd
        for (std::size_t e = begin; e < end; ++e) {
          total[e] += double(sums[e]);
          sums[e] = 0.0f;
        }
      }
    }
#pragma omp for schedule(static)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(held); ++i) {
      double* light = total + shared + (s_.first_light + std::size_t(i)) * st;
      float* own = per_light_[std::size_t(i)].sums + shared;
#pragma omp simd
      for (std::size_t k = 0; k < st; ++k) {
        light[k] += double(own[k]);
        own[k] = 0.0f;
      }
    }
  }
}

PredictionGradient SparsePass::result(const ProductMixture& mix) const {
  PredictionGradient out;
  const std::size_t size = total_.size(), st = stride_;
  out.error = total_[size - 3];
  out.samples = std::size_t(total_[size - 2]);
  out.weighed = out.samples > 0 ? total_[size - 1] / (double(out.samples) * double(chunks())) : 0.0;
  if (!gradient_) return out;
  out.log_weight.assign(m_, 0.0);
  out.mean.assign(m_, {});
  out.log_var.assign(m_, {});
  const double* position = &total_[at_position()];
  auto add_angle = [&](double g, double x, std::size_t c, std::size_t n) {
    const double var = mix.var[c][n], d = x - mix.mean[c][n];
    out.mean[c][n] += g * d / var;
    out.log_var[c][n] += 0.5 * g * (d * d / var - 1.0);
  };
  for (std::size_t k = 0; k < m_; ++k) {
    const std::size_t c = order_[k];  // column k's component
    for (std::size_t n = 0; n < 2; ++n) {
      out.mean[c][n] = position[n * st + k];
      out.log_var[c][n] = position[(2 + n) * st + k];
    }
    for (std::size_t l = 0; l < s_.lights; ++l) {
      const double g = total_[at_light() + l * st + k];
      out.log_weight[c] += g;
      for (std::size_t j = 0; j < 2; ++j) add_angle(g, s_.light_ab[l][j], c, 2 + j);
    }
    for (std::size_t v = 0; v < s_.views; ++v)
      for (std::size_t j = 0; j < 2; ++j) add_angle(total_[v * st + k], s_.view_ab[v][j], c, 4 + j);
    for (std::size_t n = 0; n < 3; ++n) out.mean[c][6 + n] = total_[at_colour() + n * st + k];
  }
  return out;
}

}  // namespace btfgmm::detail
