// The conditional weights W_m(x_I) of Eq. (9)-(10) for every sample of a sample set, on its
// (pixel, light, view) grid: the exponents t_m are the sum of a pixel's, a light's and a
// view's part (each tabulated once), and only the weights above e^-25 of a sample's largest
// are kept (the rest change no sum by more than M e^-25 of its size). Used by the fits for the
// prediction (refine.cpp).
#pragma once

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"
#include "model/conditional.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {

// Weights below this (in log, relative to a sample's largest) are left out.
constexpr double kNegligibleLogWeight = -25.0;

// One sample and its conditional weights (normalised to sum 1 over those kept).
struct SampleWeights {
  std::size_t pixel = 0, light = 0, view = 0, index = 0;  // index: SampleSet::index()
  float residual[3] = {0, 0, 0};                          // r_i, model units
  std::vector<std::uint32_t> component;                   // m, increasing
  std::vector<double> weight;                             // W_m(x_I)
};

// The exponents t_m of Eq. (9)-(10) on the sample grid as three parts, M values a row: the
// pixel's (log_weight_base and the terms of x and y), the light's and the view's; sample
// (p, l, v) has t_m = pixel[p M + m] + light[l M + m] + view[v M + m]. `Real`: the tables' type.
template <class Real>
void exponent_parts(const SampleSet& s, const ProductMixture& mix, Real* pixel, Real* light,
                    Real* view) {
  const std::size_t m = mix.size(), width = std::size_t(s.width);
  const Periods periods = variable_periods({double(s.width), double(s.height)});
  for (std::size_t k = 0; k < m; ++k) {
    const double base = log_weight_base(mix, k);
    const auto& mu = mix.mean[k];
    const auto& var = mix.var[k];
    for (std::size_t p = 0; p < s.pixels(); ++p)
      pixel[p * m + k] =
          Real(base + log_marginal_term(double(p % width), mu[0], var[0], periods[0]) +
               log_marginal_term(double(p / width), mu[1], var[1], periods[1]));
    for (std::size_t l = 0; l < s.lights; ++l)
      light[l * m + k] = Real(log_marginal_term(s.light_ab[l][0], mu[2], var[2], 0.0) +
                              log_marginal_term(s.light_ab[l][1], mu[3], var[3], 0.0));
    for (std::size_t v = 0; v < s.views; ++v)
      view[v * m + k] = Real(log_marginal_term(s.view_ab[v][0], mu[4], var[4], 0.0) +
                             log_marginal_term(s.view_ab[v][1], mu[5], var[5], 0.0));
  }
}

class GridWeights {
 public:
  // `stride`: only the samples of pixel p and (light, view) pair l nv + v whose sum p + l nv + v
  // it divides (kept()); `training`: of those, the ones not held out for validation.
  GridWeights(const SampleSet& s, const ProductMixture& mix, std::size_t stride = 1,
              bool training = false)
      : s_(s), m_(mix.size()), stride_(stride), training_(training) {
    pixel_.resize(s.pixels() * m_);
    light_.resize(s.lights * m_);
    view_.resize(s.views * m_);
    exponent_parts(s, mix, pixel_.data(), light_.data(), view_.data());
  }

  // The samples visit_light visits, over every pixel.
  std::size_t samples() const {
    std::size_t n = 0;
    const std::size_t first = s_.first_light * s_.views, end = s_.light_end() * s_.views;
    for (std::size_t p = 0; p < s_.pixels(); ++p)
      for (std::size_t j = first; j < end; ++j) n += kept(p, j) ? 1 : 0;
    return n;
  }

  // Whether sample (pixel p, (light, view) pair j = l nv + v) is in the stride's subsample:
  // (p + j) divisible by the stride, so every image keeps every stride-th pixel, and every
  // pixel every stride-th image.
  bool kept(std::size_t p, std::size_t j) const {
    return (p + j) % stride_ == 0 && !(training_ && validation_sample(p, j, s_.lights * s_.views));
  }

  // Per-thread working space of visit_light.
  struct Scratch {
    std::vector<double> pl, t;
    SampleWeights w;
    explicit Scratch(std::size_t m) : pl(m), t(m) {
      w.component.reserve(m);
      w.weight.reserve(m);
    }
  };

  // visit(const SampleWeights&) for the kept views of pixel p and light l, whose pixel and
  // light terms sc.pl holds.
  template <class Visit>
  void visit_views(std::size_t p, std::size_t l, Scratch& sc, Visit&& visit) const {
    SampleWeights& w = sc.w;
    for (std::size_t v = 0; v < s_.views; ++v) {
      if (!kept(p, l * s_.views + v)) continue;
      weights(sc.pl.data(), &view_[v * m_], sc.t.data(), w);
      w.pixel = p;
      w.light = l;
      w.view = v;
      w.index = s_.index(p, l, v);
      for (int c = 0; c < 3; ++c) w.residual[c] = s_.residual_of(p, l, v, c);
      visit(w);
    }
  }

  // Calls visit(const SampleWeights&) for every sample (of the stride) of light l (one this
  // process holds), pixels then views in increasing order.
  template <class Visit>
  void visit_light(std::size_t l, Scratch& sc, Visit&& visit) const {
    for (std::size_t p = 0; p < s_.pixels(); ++p) {
      const double* a = &pixel_[p * m_];
      const double* b = &light_[l * m_];
      bool any = false;
      for (std::size_t v = 0; v < s_.views && !any; ++v) any = kept(p, l * s_.views + v);
      if (!any) continue;
      for (std::size_t k = 0; k < m_; ++k) sc.pl[k] = a[k] + b[k];
      visit_views(p, l, sc, visit);
    }
  }

  // Sums over every sample (of the stride) of this process's lights with `threads` threads (0:
  // all cores), light by light: visit(const SampleWeights&, acc) for every sample of a light
  // (acc = make(), one per thread), then reduce(acc) for that light, in light order and one
  // thread at a time (reduce adds acc into the totals and clears it). The same bit for bit
  // with any number of threads, and, folded over processes (fold_over_processes), with any
  // number of processes. A `stop` set ends it at the next light (the lights left are not
  // visited, their reduce sees an empty acc), so that Ctrl-C is answered within a light's time.
  template <class Make, class Visit, class Reduce>
  void reduce_over_lights(int threads, Make&& make, Visit&& visit, Reduce&& reduce,
                          const std::atomic<bool>* stop = nullptr) const {
    const std::ptrdiff_t lights = std::ptrdiff_t(s_.held_lights());
    const int n_threads = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel num_threads(n_threads)
    {
      auto acc = make();
      Scratch sc(m_);
#pragma omp for ordered schedule(dynamic, 1)
      for (std::ptrdiff_t i = 0; i < lights; ++i) {
        if (!stop || !stop->load(std::memory_order_relaxed))
          visit_light(s_.first_light + std::size_t(i), sc,
                      [&](const SampleWeights& w) { visit(w, acc); });
#pragma omp ordered
        reduce(acc);
      }
    }
  }

 private:
  // t = pl + view; the kept components' weights exp(t - max) / sum.
  void weights(const double* pl, const double* view, double* t, SampleWeights& w) const {
    double mx = -INFINITY;
    for (std::size_t k = 0; k < m_; ++k) {
      t[k] = pl[k] + view[k];
      mx = t[k] > mx ? t[k] : mx;
    }
    w.component.clear();
    w.weight.clear();
    const double cut = mx + kNegligibleLogWeight;
    double sum = 0.0;
    for (std::size_t k = 0; k < m_; ++k)
      if (t[k] > cut) {
        const double e = std::exp(t[k] - mx);
        w.component.push_back(std::uint32_t(k));
        w.weight.push_back(e);
        sum += e;
      }
    for (double& e : w.weight) e /= sum;
  }

  const SampleSet& s_;
  std::size_t m_, stride_;
  bool training_;
  std::vector<double> pixel_, light_, view_;  // the exponents' parts, M a row
};

}  // namespace btfgmm::detail
