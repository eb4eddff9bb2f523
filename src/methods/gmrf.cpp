// The Gaussian Markov random field on a torus (Haindl & Filip, PAMI 2007; Besag 1974, 1975):
// least-squares estimate, positive-definiteness by shrinking, exact synthesis by FFT.
#include "methods/gmrf.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <complex>
#include <numbers>

#include "core/eigen_dense.hpp"
#include "methods/fft.hpp"

namespace btfgmm::detail {
namespace {

// The offsets of radius `radius` (Chebyshev) in the half-plane that I+ takes: dy > 0, or
// dy = 0 and dx > 0.
void add_half_ring(int radius, std::vector<Offset>& out) {
  for (int dy = 0; dy <= radius; ++dy)
    for (int dx = -radius; dx <= radius; ++dx) {
      const Offset s{dx, dy};
      if ((dy > 0 || dx > 0) && std::max(std::abs(dx), std::abs(dy)) == radius &&
          std::find(out.begin(), out.end(), s) == out.end())
        out.push_back(s);
    }
}

double smallest_spectrum(const GmrfModel& m) {
  double lo = 1e300;
  constexpr int kGrid = 64;
  for (int k2 = 0; k2 < kGrid; ++k2)
    for (int k1 = 0; k1 < kGrid; ++k1)
      lo = std::min(lo,
                    gmrf_spectrum(m, angular_frequency(k1, kGrid), angular_frequency(k2, kGrid)));
  return lo;
}

// Moment matching: sigma^2 such that the exact synthesis on the band's torus, whose variance is
// sigma^2 mean_{k != 0} 1 / mu_k, has the band's variance (the pseudo-likelihood's sigma^2 is
// a conditional variance, and the shrink lowers the marginal one).
void match_variance(GmrfModel& m, const Field& band) {
  double variance = 0.0;
  for (double v : band.values) variance += (v - m.mean) * (v - m.mean);
  variance /= double(band.pixels());
  double inverse = 0.0;
  for (int k2 = 0; k2 < band.height; ++k2)
    for (int k1 = 0; k1 < band.width; ++k1)
      if (k1 != 0 || k2 != 0)
        inverse += 1.0 / std::max(gmrf_spectrum(m, angular_frequency(k1, band.width),
                                                angular_frequency(k2, band.height)),
                                  kMinSpectrum / 4);
  inverse /= double(band.pixels());
  if (variance > 0.0 && inverse > 0.0) m.sigma2 = std::max(variance / inverse, 1e-12);
}

}  // namespace

std::vector<Offset> symmetric_half(int order) {
  std::vector<Offset> out = {{1, 0}, {0, 1}};
  if (order >= 2) out.insert(out.end(), {{1, 1}, {-1, 1}});
  if (order >= 3) out.insert(out.end(), {{2, 0}, {0, 2}});
  if (order >= 4) out.insert(out.end(), {{2, 1}, {1, 2}, {-1, 2}, {-2, 1}});
  if (order >= 5) {
    add_half_ring(2, out);
    add_half_ring(3, out);
  }
  return out;
}

double gmrf_spectrum(const GmrfModel& m, double w1, double w2) {
  double sum = 0.0;
  for (std::size_t k = 0; k < m.a.size(); ++k)
    sum += m.a[k] * std::cos(w1 * m.half[k].dx + w2 * m.half[k].dy);
  return 1.0 - 2.0 * sum;
}

GmrfModel estimate_gmrf(const Field& band, const std::vector<Offset>& half) {
  assert(band.channels == 1);
  GmrfModel m;
  m.half = half;
  for (double v : band.values) m.mean += v;
  m.mean /= double(band.pixels());
  int reach = 0;
  for (const Offset& s : half) reach = std::max({reach, std::abs(s.dx), std::abs(s.dy)});
  const int w = band.width - 2 * reach, h = band.height - 2 * reach;
  assert(w > 0 && h > 0);
  const auto n = Eigen::Index(half.size());
  Eigen::MatrixXd x(Eigen::Index(w) * h, n);
  Eigen::VectorXd y(x.rows());
  Eigen::Index row = 0;
  for (int py = reach; py < band.height - reach; ++py)
    for (int px = reach; px < band.width - reach; ++px, ++row) {
      y(row) = band.at(px, py) - m.mean;
      for (Eigen::Index k = 0; k < n; ++k) {
        const Offset& s = half[std::size_t(k)];
        x(row, k) = band.at(px + s.dx, py + s.dy) + band.at(px - s.dx, py - s.dy) - 2 * m.mean;
      }
    }
  const Eigen::VectorXd a = (x.transpose() * x).ldlt().solve(x.transpose() * y);
  m.a.assign(a.data(), a.data() + n);
  m.sigma2 = std::max((y - x * a).squaredNorm() / double(x.rows()), 1e-12);
  // Positive definiteness: mu = 1 - t S with S = 2 sum a_s cos(.), so t = (1 - min) / max S.
  const double lo = smallest_spectrum(m);
  if (lo < kMinSpectrum) {
    m.shrink = (1.0 - kMinSpectrum) / (1.0 - lo);
    for (double& v : m.a) v *= m.shrink;
  }
  match_variance(m, band);
  return m;
}

GmrfModel select_gmrf(const Field& band, int max_order) {
  GmrfModel best = estimate_gmrf(band, symmetric_half(1));
  for (int order = 2; order <= max_order; ++order) {
    const auto half = symmetric_half(order);
    int reach = 0;
    for (const Offset& s : half) reach = std::max({reach, std::abs(s.dx), std::abs(s.dy)});
    const double rows = double(band.width - 2 * reach) * double(band.height - 2 * reach);
    if (rows < 8.0 * double(half.size())) break;
    GmrfModel m = estimate_gmrf(band, half);
    const double added = double(m.a.size() - best.a.size());
    if (m.sigma2 < best.sigma2 * std::pow(0.99, added)) best = std::move(m);
  }
  return best;
}

Field synthesise_gmrf(const GmrfModel& m, int width, int height, std::uint64_t seed) {
  Field eps(width, height, 1);
  eps.values = white_noise(eps.pixels(), seed);
  std::vector<std::complex<double>> f = forward_dft(eps);
  for (int k2 = 0; k2 < height; ++k2)
    for (int k1 = 0; k1 < width; ++k1) {
      const double mu =
          std::max(gmrf_spectrum(m, angular_frequency(k1, width), angular_frequency(k2, height)),
                   kMinSpectrum / 4);
      f[std::size_t(k2) * std::size_t(width) + std::size_t(k1)] *= std::sqrt(m.sigma2 / mu);
    }
  f[0] = 0.0;  // the level's mean restored exactly: the field's own mean is the model's
  Field y = inverse_dft(f, width, height);
  for (double& v : y.values) v += m.mean;
  return y;
}

}  // namespace btfgmm::detail
