// EM on the sample grid, Eq. (3)-(7), organised for speed (DESIGN §4).
//
// For component m and sample (pixel p, light l, view v), log w_m F(x | m) splits into
//   S[p][m]  (log w_m, the normalisation, and the x, y terms: depends on the pixel only)
// + L[l][m]  (the alpha_i, beta_i terms: the light only)
// + V[v][m]  (the alpha_v, beta_v terms: the view only)
// + the three colour terms (the sample itself).
// The tables are built once per iteration; a block is one (pixel, light) pair and its nv
// views, whose responsibilities are folded at once into the statistics:
//   per pixel, light and view: sum q            (x, y and the angles follow from these)
//   per component:             sum q d, sum q d^2 with d = colour - previous mean.
// Blocks are grouped into a fixed number of chunks of pixels whose statistics are reduced in
// chunk order, so the result is the same for any number of threads.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <numbers>

#include "btfgmm/error.hpp"
#include "btfgmm/model.hpp"
#include "fast_exp.hpp"
#include "mixture_internal.hpp"

namespace btfgmm {
namespace {

constexpr std::size_t kChunks = 16;

struct Tables {
  std::size_t m = 0;
  std::vector<float> s, l, v;               // P x M, ni x M, nv x M
  std::vector<float> mu, neg_half_inv_var;  // 3 x M each (colour)
};

Tables make_tables(const SampleSet& s, const ProductMixture& mix) {
  Tables t;
  const std::size_t m_count = t.m = mix.size();
  t.s.resize(s.pixels() * m_count);
  t.l.resize(s.lights * m_count);
  t.v.resize(s.views * m_count);
  t.mu.resize(3 * m_count);
  t.neg_half_inv_var.resize(3 * m_count);
  std::vector<double> base(m_count);
  for (std::size_t m = 0; m < m_count; ++m) {
    double b = std::log(mix.weight[m]) - 0.5 * kVariables * std::log(2.0 * std::numbers::pi);
    for (int n = 0; n < kVariables; ++n) b -= 0.5 * std::log(mix.var[m][n]);
    base[m] = b;
    for (int c = 0; c < 3; ++c) {
      t.mu[c * m_count + m] = float(mix.mean[m][6 + c]);
      t.neg_half_inv_var[c * m_count + m] = float(-0.5 / mix.var[m][6 + c]);
    }
  }
  auto gauss = [&](std::size_t m, int n, double x) {
    const double d = x - mix.mean[m][n];
    return -0.5 * d * d / mix.var[m][n];
  };
  for (std::size_t p = 0; p < s.pixels(); ++p) {
    const double x = double(p % std::size_t(s.width)), y = double(p / std::size_t(s.width));
    for (std::size_t m = 0; m < m_count; ++m)
      t.s[p * m_count + m] = float(base[m] + gauss(m, 0, x) + gauss(m, 1, y));
  }
  for (std::size_t l = 0; l < s.lights; ++l)
    for (std::size_t m = 0; m < m_count; ++m)
      t.l[l * m_count + m] = float(gauss(m, 2, s.light_ab[l][0]) + gauss(m, 3, s.light_ab[l][1]));
  for (std::size_t v = 0; v < s.views; ++v)
    for (std::size_t m = 0; m < m_count; ++m)
      t.v[v * m_count + m] = float(gauss(m, 4, s.view_ab[v][0]) + gauss(m, 5, s.view_ab[v][1]));
  return t;
}

struct ChunkStats {
  std::vector<double> ql, qv, c1, c2;  // ni x M, nv x M, 3 x M, 3 x M
  double ll = 0.0;
};

// The log densities of one sample for every component: t[m] = sl[m] + v[m] + colour terms.
inline void log_densities(const Tables& t, const float* sl, const float* vrow, const float* r,
                          float* out) {
  const std::size_t m_count = t.m;
  const float *mu0 = t.mu.data(), *mu1 = mu0 + m_count, *mu2 = mu1 + m_count;
  const float *h0 = t.neg_half_inv_var.data(), *h1 = h0 + m_count, *h2 = h1 + m_count;
  const float r0 = r[0], r1 = r[1], r2 = r[2];
#pragma omp simd
  for (std::size_t m = 0; m < m_count; ++m) {
    const float d0 = r0 - mu0[m], d1 = r1 - mu1[m], d2 = r2 - mu2[m];
    out[m] = sl[m] + vrow[m] + h0[m] * d0 * d0 + h1[m] * d1 * d1 + h2[m] * d2 * d2;
  }
}

// exp(t - max) in place; returns (max, sum).
inline std::pair<float, float> exp_normalise(float* t, std::size_t m_count) {
  float mx = -INFINITY;
#pragma omp simd reduction(max : mx)
  for (std::size_t m = 0; m < m_count; ++m) mx = std::max(mx, t[m]);
  float sum = 0.0f;
#pragma omp simd reduction(+ : sum)
  for (std::size_t m = 0; m < m_count; ++m) sum += (t[m] = detail::fast_exp(t[m] - mx));
  return {mx, sum};
}

// One E pass. With `stats`, folds the responsibilities into qp (P x M) and the chunks.
double e_pass(const SampleSet& s, const Tables& t, int threads, std::vector<double>* qp,
              std::vector<ChunkStats>* stats) {
  const std::size_t m_count = t.m, ni = s.lights, nv = s.views, pixels = s.pixels();
  std::vector<double> chunk_ll(kChunks, 0.0);
  std::exception_ptr failure;
#pragma omp parallel num_threads(threads)
  {
    std::vector<float> sl(m_count), e(m_count), a0(m_count), a1(3 * m_count), a2(3 * m_count);
#pragma omp for schedule(dynamic, 1)
    for (std::size_t c = 0; c < kChunks; ++c) {
      try {
        ChunkStats* cs = stats ? &(*stats)[c] : nullptr;
        double ll = 0.0;
        for (std::size_t p = c * pixels / kChunks; p < (c + 1) * pixels / kChunks; ++p) {
          for (std::size_t l = 0; l < ni; ++l) {
            const float* srow = &t.s[p * m_count];
            const float* lrow = &t.l[l * m_count];
#pragma omp simd
            for (std::size_t m = 0; m < m_count; ++m) sl[m] = srow[m] + lrow[m];
            if (cs) {
              std::fill(a0.begin(), a0.end(), 0.0f);
              std::fill(a1.begin(), a1.end(), 0.0f);
              std::fill(a2.begin(), a2.end(), 0.0f);
            }
            for (std::size_t v = 0; v < nv; ++v) {
              const float* r = &s.residual[s.index(p, l, v) * 3];
              log_densities(t, sl.data(), &t.v[v * m_count], r, e.data());
              const auto [mx, sum] = exp_normalise(e.data(), m_count);
              ll += double(mx) + std::log(double(sum));  // Eq. (3)
              if (!cs) continue;
              // Eq. (4): q = e / sum, folded into the statistics of Eq. (5)-(7) at once.
              const float inv = 1.0f / sum;
              double* qv = &cs->qv[v * m_count];
              const float* mu = t.mu.data();
              const float r0 = r[0], r1 = r[1], r2 = r[2];
#pragma omp simd
              for (std::size_t m = 0; m < m_count; ++m) {
                const float q = e[m] * inv;
                const float d0 = r0 - mu[m], d1 = r1 - mu[m_count + m],
                            d2 = r2 - mu[2 * m_count + m];
                a0[m] += q;
                a1[m] += q * d0;
                a1[m_count + m] += q * d1;
                a1[2 * m_count + m] += q * d2;
                a2[m] += q * d0 * d0;
                a2[m_count + m] += q * d1 * d1;
                a2[2 * m_count + m] += q * d2 * d2;
                qv[m] += double(q);
              }
            }
            if (!cs) continue;
            double* qpp = &(*qp)[p * m_count];
            double* qll = &cs->ql[l * m_count];
            for (std::size_t m = 0; m < m_count; ++m) {
              qpp[m] += double(a0[m]);
              qll[m] += double(a0[m]);
            }
            for (std::size_t k = 0; k < 3 * m_count; ++k) {
              cs->c1[k] += double(a1[k]);
              cs->c2[k] += double(a2[k]);
            }
          }
        }
        chunk_ll[c] = ll;
      } catch (...) {
#pragma omp critical(btfgmm_em_failure)
        if (!failure) failure = std::current_exception();
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  double total = 0.0;
  for (double v : chunk_ll) total += v;  // fixed order
  return total / double(s.size());
}

int resolve_threads(int threads) {
  return threads > 0 ? threads : omp_get_max_threads();
}

}  // namespace

EmResult fit_em(const SampleSet& s, ProductMixture& mix, const EmConfig& config,
                const EmCallback& progress) {
  detail::check_em_input(s.size(), mix, config);
  const auto t0 = std::chrono::steady_clock::now();
  const int threads = resolve_threads(config.threads);
  const std::size_t pixels = s.pixels(), ni = s.lights, nv = s.views;
  EmResult result;
  for (int it = 1; it <= config.max_iterations; ++it) {
    const std::size_t m_count = mix.size();
    const Tables t = make_tables(s, mix);
    std::vector<double> qp(pixels * m_count, 0.0);
    std::vector<ChunkStats> chunks(kChunks);
    for (auto& c : chunks) {
      c.ql.assign(ni * m_count, 0.0);
      c.qv.assign(nv * m_count, 0.0);
      c.c1.assign(3 * m_count, 0.0);
      c.c2.assign(3 * m_count, 0.0);
    }
    const double ll = e_pass(s, t, threads, &qp, &chunks);
    // Reduce the chunks in order.
    std::vector<double> ql(ni * m_count, 0.0), qv(nv * m_count, 0.0), c1(3 * m_count, 0.0),
        c2(3 * m_count, 0.0);
    for (const auto& c : chunks) {
      for (std::size_t k = 0; k < ql.size(); ++k) ql[k] += c.ql[k];
      for (std::size_t k = 0; k < qv.size(); ++k) qv[k] += c.qv[k];
      for (std::size_t k = 0; k < c1.size(); ++k) c1[k] += c.c1[k];
      for (std::size_t k = 0; k < c2.size(); ++k) c2[k] += c.c2[k];
    }
    // Sufficient statistics in the form of the reference path: sum q, and the sums of
    // q (x - mu_old), q (x - mu_old)^2 for each variable.
    std::vector<double> s0(m_count, 0.0);
    std::vector<std::array<double, kVariables>> s1(m_count), s2(m_count);
    for (std::size_t m = 0; m < m_count; ++m) {
      s1[m].fill(0.0);
      s2[m].fill(0.0);
      const auto& mu = mix.mean[m];
      auto add = [&](int n, double q, double x) {
        const double d = x - mu[n];
        s1[m][n] += q * d;
        s2[m][n] += q * d * d;
      };
      for (std::size_t p = 0; p < pixels; ++p) {
        const double q = qp[p * m_count + m];
        s0[m] += q;
        add(0, q, double(p % std::size_t(s.width)));
        add(1, q, double(p / std::size_t(s.width)));
      }
      for (std::size_t l = 0; l < ni; ++l) {
        add(2, ql[l * m_count + m], s.light_ab[l][0]);
        add(3, ql[l * m_count + m], s.light_ab[l][1]);
      }
      for (std::size_t v = 0; v < nv; ++v) {
        add(4, qv[v * m_count + m], s.view_ab[v][0]);
        add(5, qv[v * m_count + m], s.view_ab[v][1]);
      }
      for (int c = 0; c < 3; ++c) {
        s1[m][6 + c] = c1[c * m_count + m];
        s2[m][6 + c] = c2[c * m_count + m];
      }
    }
    result.dropped += detail::m_step(mix, s0, s1, s2, double(s.size()), config.variance_floor,
                                     config.min_component_samples);
    detail::record_iteration(result, ll, it, config, mix.size(), t0, progress);
    if (result.converged) break;
  }
  result.final_log_likelihood = e_pass(s, make_tables(s, mix), threads, nullptr, nullptr);
  return result;
}

}  // namespace btfgmm
