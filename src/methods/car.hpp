// The causal autoregressive (CAR) random field of Haindl & Filip (PAMI 2007, Sec. 4.1-4.2;
// Haindl & Simberova 1992) (internal): a d-dimensional pixel Y_r (the RGB vector for 3D CAR,
// one Karhunen-Loeve band for 2D CAR) predicted from its causal neighbourhood I_r,
//   Y_r = gamma X_r + e_r,   X_r = [Y_{r-s} : s in I_r] (d eta values),   e_r ~ N(0, Sigma),
// estimated in closed form (the analytic Bayesian estimate with a flat prior, which is least
// squares), the neighbourhood chosen by the papers' decision rule, and synthesised in raster
// order on a torus from white noise, so that the result tiles.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "methods/texture_field.hpp"

namespace btfgmm::detail {

// A neighbour's position relative to the pixel: (x + dx, y + dy).
struct Offset {
  int dx = 0, dy = 0;
  bool operator==(const Offset&) const = default;
};

// Whether s precedes the pixel in raster order (an earlier row, or the same row to its left).
inline bool causal(const Offset& s) {
  return s.dy < 0 || (s.dy == 0 && s.dx < 0);
}

// The causal neighbourhoods the decision rule chooses among, growing with `order` (1: left and
// above; 2: + both upper diagonals; 3: + two to the left and two above; 4: the half-square of
// radius 2; 5: of radius 3).
std::vector<Offset> causal_neighbourhood(int order);
constexpr int kMaxCausalOrder = 5;

struct CarModel {
  int d = 3;
  std::vector<Offset> neighbourhood;  // I_r, eta causal offsets
  std::vector<double> mean;           // d: removed before the estimate, restored in synthesis
  std::vector<double> gamma;          // d x (d eta), row-major; column block k is offset k
  std::vector<double> sigma;          // d x d noise covariance
  double decision = 0.0;              // the decision rule's D for this neighbourhood

  std::size_t eta() const { return neighbourhood.size(); }
  // Stored values: gamma, Sigma's upper triangle, the mean.
  std::size_t parameter_count() const;
};

// The CAR model's estimate (Haindl & Filip, PAMI 2007, Sec. 4.1; Haindl 2012), over the pixels
// whose whole neighbourhood lies inside `y` (no wrap): with V = sum_r [Y_r; X_r][Y_r; X_r]^T,
// gamma^T = Vxx^-1 Vxy, lambda = Vyy - Vxy^T Vxx^-1 Vxy, Sigma = lambda / beta(t). Asserts
// that the neighbourhood is causal and that `y` holds more such pixels than unknowns.
// `margin`: pixels this close to the left, right or top edge are left out as well.
CarModel estimate_car(const Field& y, std::span<const Offset> neighbourhood, int margin = 0);

// The neighbourhood among causal_neighbourhood(1 .. max_order) with the largest decision D
// (Haindl & Simberova 1992, as Haindl & Filip use it), the model estimated on it; an order
// too large for the image is skipped.
CarModel select_car(const Field& y, int max_order = kMaxCausalOrder);

// A field of width x height from the model (Haindl & Filip 2007): Y_r = gamma X_r + L eps_r
// (L L^T = Sigma, eps white Gaussian), in raster order on the torus, the neighbours wrapping.
// On a torus the first pixels' neighbours are the last ones, not yet made: `passes` raster
// passes over the same noise are made (Gauss-Seidel sweeps of the model's equations on the
// torus), all but the last the discarded warm-up; each pass shrinks what the seam still
// holds of the start by the field's correlation across the image, so that the result
// satisfies the model at every pixel, the seam included, and tiles. The field's mean is then
// set to the model's (the level's mean restored). Deterministic from `seed`.
Field synthesise_car(const CarModel& m, int width, int height, std::uint64_t seed, int passes = 4);

// Shrinks gamma (by 0.95 at a time) until a synthesis of width x height (the training
// image's size) has a covariance trace within kMaxVarianceGain times the training image's
// `data_trace`: an estimate on a short image may be explosive in raster order, or so near
// its unit root that the torus synthesis inflates the low frequencies. Then Sigma is scaled
// so that this synthesis's covariance trace is `data_trace` (moment matching: the variance
// the shrink or the unit root moved restored). Returns the factor applied to gamma (1: none).
constexpr double kMaxVarianceGain = 1.25;
double stabilise_car(CarModel& m, double data_trace, int width, int height);

// The CAR model's equations solved exactly on the width x height torus (the synthesis of
// files from format version 6 on, docs/METHODS.md): with the model's transfer matrix
//   A(w) = I - sum_s gamma_s exp(i w.s)   (gamma_s the d x d block of offset s),
// Y(k) = A(w_k)^-1 DFT(L eps)(k) at every frequency but k = 0, which is the model's mean.
// Every pixel, the seam included, satisfies Y_r = gamma X_r + L eps_r with the neighbours
// wrapping: no raster order, no warm-up, nothing that can pile up along an edge. Needs A(w)
// invertible on the grid: stabilise_car_spectrum makes its smallest singular value at least
// kMinCarSpectrum everywhere. Deterministic from `seed`.
Field synthesise_car_spectral(const CarModel& m, int width, int height, std::uint64_t seed);

// The smallest singular value of A(w) over a grid of kSpectrumGrid x kSpectrumGrid
// frequencies and the frequencies next to 0 of every side up to 1024 (where a model near its
// unit root has its gain).
double smallest_car_spectrum(const CarModel& m);
constexpr double kMinCarSpectrum = 0.01;  // an amplitude gain of at most 100 over white noise

// gamma scaled by the largest factor in [0, 1] (found by bisection, to 2^-16) that makes
// smallest_car_spectrum >= kMinCarSpectrum where the estimate falls below it, then
// Sigma scaled so that the exact torus field of width x height (the training image's size)
// has the covariance trace `data_trace` (its variance computed from the spectrum, no
// sampling). Returns the factor applied to gamma (1: none). The stability test of
// synthesise_car_spectral: an estimate that passes it cannot make a field larger than the
// data's variance by more than the gain bound at any size.
double stabilise_car_spectrum(CarModel& m, double data_trace, int width, int height);

// Gaussian white noise from splitmix64 (Box-Muller), n values, deterministic from `seed`.
std::vector<double> white_noise(std::size_t n, std::uint64_t seed);

// Cholesky factor L (lower, row-major) of a d x d covariance; a covariance that is not
// positive definite gets a small ridge first.
std::vector<double> cholesky_factor(std::span<const double> sigma, int d);

std::string neighbourhood_text(std::span<const Offset> n);

}  // namespace btfgmm::detail
