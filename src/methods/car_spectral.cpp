// The CAR model solved exactly on a torus by FFT, and its spectral stability test
// (car.hpp: synthesise_car_spectral, stabilise_car_spectrum).
#include <algorithm>
#include <cmath>
#include <complex>

#include "core/eigen_dense.hpp"
#include "core/random.hpp"
#include "methods/car.hpp"
#include "methods/fft.hpp"

namespace btfgmm::detail {
namespace {

constexpr int kSpectrumGrid = 64;
using Matrix = Eigen::MatrixXcd;

// A(w) = I - sum_s gamma_s exp(i (w1 dx + w2 dy)).
Matrix transfer(const CarModel& m, double w1, double w2) {
  const Eigen::Index d = m.d;
  const std::size_t n = std::size_t(d) * m.eta();
  Matrix a = Matrix::Identity(d, d);
  for (std::size_t k = 0; k < m.eta(); ++k) {
    const Offset& s = m.neighbourhood[k];
    const std::complex<double> phase = std::polar(1.0, w1 * s.dx + w2 * s.dy);
    for (Eigen::Index r = 0; r < d; ++r)
      for (Eigen::Index c = 0; c < d; ++c)
        a(r, c) -= m.gamma[std::size_t(r) * n + k * std::size_t(d) + std::size_t(c)] * phase;
  }
  return a;
}

double smallest_singular_value(const Matrix& a) {
  if (a.rows() == 1) return std::abs(a(0, 0));
  if (a.rows() == 3) {  // sqrt of the smallest eigenvalue of A^H A, fixed-size
    const Eigen::Matrix3cd a3 = a;
    const Eigen::Matrix3cd g = a3.adjoint() * a3;
    const double lo = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3cd>(g, Eigen::EigenvaluesOnly)
                          .eigenvalues()
                          .minCoeff();
    return std::sqrt(std::max(lo, 0.0));
  }
  return Eigen::JacobiSVD<Matrix>(a).singularValues().minCoeff();
}

CarModel scaled(const CarModel& m, double t) {
  CarModel out = m;
  for (double& g : out.gamma) g *= t;
  return out;
}

// trace(A^-1 Sigma A^-H) averaged over the torus's frequencies but 0: the field's covariance
// trace.
double torus_trace(const CarModel& m, int width, int height) {
  const Eigen::Index d = m.d;
  const Eigen::MatrixXd sigma = Eigen::Map<const Eigen::MatrixXd>(m.sigma.data(), d, d);
  double sum = 0.0;
  for (int k2 = 0; k2 < height; ++k2)
    for (int k1 = 0; k1 < width; ++k1) {
      if (k1 == 0 && k2 == 0) continue;
      const Matrix inv =
          transfer(m, angular_frequency(k1, width), angular_frequency(k2, height)).inverse();
      sum += (inv * sigma.cast<std::complex<double>>() * inv.adjoint()).trace().real();
    }
  return sum / double(std::size_t(width) * std::size_t(height));
}

}  // namespace

double smallest_car_spectrum(const CarModel& m) {
  double lo = 1e300;
  for (int k2 = 0; k2 < kSpectrumGrid; ++k2)
    for (int k1 = 0; k1 < kSpectrumGrid; ++k1)
      lo = std::min(lo, smallest_singular_value(transfer(m, angular_frequency(k1, kSpectrumGrid),
                                                         angular_frequency(k2, kSpectrumGrid))));
  // Next to zero, where a near-unit-root model has its gain, on the sides a synthesis takes.
  for (int side = 2 * kSpectrumGrid; side <= 1024; side *= 2)
    for (const auto& [k1, k2] : {std::pair{1, 0}, {0, 1}, {1, 1}, {1, -1}})
      lo = std::min(lo, smallest_singular_value(
                            transfer(m, angular_frequency(k1, side), angular_frequency(k2, side))));
  return lo;
}

double stabilise_car_spectrum(CarModel& m, double data_trace, int width, int height) {
  double factor = 1.0;
  if (smallest_car_spectrum(m) < kMinCarSpectrum) {
    // Bisection for the largest t with the bound kept (t = 0, white noise, keeps it).
    double lo = 0.0, hi = 1.0;
    for (int step = 0; step < 16; ++step) {
      const double t = (lo + hi) / 2;
      (smallest_car_spectrum(scaled(m, t)) >= kMinCarSpectrum ? lo : hi) = t;
    }
    m = scaled(m, lo);
    factor = lo;
  }
  const double trace = torus_trace(m, width, height);
  if (trace > 0.0 && data_trace > 0.0)
    for (double& s : m.sigma) s *= data_trace / trace;
  return factor;
}

Field synthesise_car_spectral(const CarModel& m, int width, int height, std::uint64_t seed) {
  const int d = m.d;
  const std::vector<double> l = cholesky_factor(m.sigma, d);
  const std::vector<double> eps =
      white_noise(std::size_t(width) * std::size_t(height) * std::size_t(d), mix64(seed));
  std::vector<std::vector<std::complex<double>>> spectra;
  for (int c = 0; c < d; ++c) {  // DFT of channel c of L eps
    Field e(width, height, 1);
    for (std::size_t p = 0; p < e.pixels(); ++p)
      for (int j = 0; j <= c; ++j)
        e.values[p] += l[std::size_t(c * d + j)] * eps[p * std::size_t(d) + std::size_t(j)];
    spectra.push_back(forward_dft(e));
  }
  Eigen::VectorXcd v(d);
  for (int k2 = 0; k2 < height; ++k2)
    for (int k1 = 0; k1 < width; ++k1) {
      const std::size_t k = std::size_t(k2) * std::size_t(width) + std::size_t(k1);
      for (int c = 0; c < d; ++c) v(c) = spectra[std::size_t(c)][k];
      const Eigen::VectorXcd y = k == 0 ? Eigen::VectorXcd::Zero(d)
                                        : Eigen::VectorXcd(transfer(m, angular_frequency(k1, width),
                                                                    angular_frequency(k2, height))
                                                               .partialPivLu()
                                                               .solve(v));
      for (int c = 0; c < d; ++c) spectra[std::size_t(c)][k] = y(c);
    }
  Field out(width, height, d);
  for (int c = 0; c < d; ++c) {
    const Field f = inverse_dft(spectra[std::size_t(c)], width, height);
    for (std::size_t p = 0; p < out.pixels(); ++p)
      out.values[p * std::size_t(d) + std::size_t(c)] = f.values[p] + m.mean[std::size_t(c)];
  }
  return out;
}

}  // namespace btfgmm::detail
