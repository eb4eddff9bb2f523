// The 2-D DFT by FFTW3 (Frigo & Johnson 2005, "The design and implementation of FFTW3").
#include "methods/fft.hpp"

#include <fftw3.h>

#include <cassert>
#include <mutex>
#include <numbers>

namespace btfgmm::detail {
namespace {

// FFTW's planner is not thread-safe: plans are made and destroyed under one lock.
std::mutex& planner_lock() {
  static std::mutex m;
  return m;
}

void transform(std::vector<std::complex<double>>& data, int width, int height, int sign) {
  auto* p = reinterpret_cast<fftw_complex*>(data.data());
  fftw_plan plan;
  {
    std::lock_guard<std::mutex> lock(planner_lock());
    plan = fftw_plan_dft_2d(height, width, p, p, sign, FFTW_ESTIMATE);
  }
  fftw_execute(plan);
  std::lock_guard<std::mutex> lock(planner_lock());
  fftw_destroy_plan(plan);
}

}  // namespace

std::vector<std::complex<double>> forward_dft(const Field& f) {
  assert(f.channels == 1);
  std::vector<std::complex<double>> data(f.values.begin(), f.values.end());
  transform(data, f.width, f.height, FFTW_FORWARD);
  return data;
}

Field inverse_dft(const std::vector<std::complex<double>>& spectrum, int width, int height) {
  std::vector<std::complex<double>> data = spectrum;
  transform(data, width, height, FFTW_BACKWARD);
  Field out(width, height, 1);
  const double scale = 1.0 / double(out.pixels());
  for (std::size_t i = 0; i < out.pixels(); ++i) out.values[i] = data[i].real() * scale;
  return out;
}

double angular_frequency(int k, int n) {
  const int signed_k = k <= n / 2 ? k : k - n;
  return 2.0 * std::numbers::pi * double(signed_k) / double(n);
}

}  // namespace btfgmm::detail
