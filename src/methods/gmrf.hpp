// The Gaussian Markov random field of Haindl & Filip (PAMI 2007) on one Karhunen-Loeve band
// (internal): with a symmetric neighbourhood I = I+ u -I+,
//   Y_r = sum_{s in I+} a_s (Y_{r+s} + Y_{r-s}) + e_r,   var(Y_r | rest) = sigma^2,
// estimated by least squares (the pseudo-likelihood estimate, Besag 1975, for a Gaussian
// field), synthesised exactly on a torus by FFT: with
//   mu_k = 1 - 2 sum_{s in I+} a_s cos(2 pi (k1 s1 / W + k2 s2 / H)),
// Y = IDFT(DFT(eps) sqrt(sigma^2 / mu_k)), eps white; every mu_k must be > 0.
#pragma once

#include <cstdint>
#include <vector>

#include "methods/car.hpp"
#include "methods/texture_field.hpp"

namespace btfgmm::detail {

// Half of a symmetric neighbourhood, growing with `order` (1: right and below, the 4-
// neighbourhood; 2: + the diagonals, the 8-neighbourhood; 3: + two away on the axes;
// 4: + the knight's moves; 5: the half-square of radius 3).
std::vector<Offset> symmetric_half(int order);
constexpr int kMaxGmrfOrder = 5;

// The smallest mu_k the field's spectrum may hold: a_s are shrunk until every mu >= this.
constexpr double kMinSpectrum = 0.02;

struct GmrfModel {
  std::vector<Offset> half;  // I+
  std::vector<double> a;     // a_s, s in I+
  double sigma2 = 1.0;       // the conditional variance
  double mean = 0.0;         // removed before the estimate, restored in synthesis
  double shrink = 1.0;       // the factor the estimate's a_s were multiplied by (1: none)

  std::size_t parameter_count() const { return a.size() + 2; }
};

// mu at the angular frequency (w1, w2): 1 - 2 sum a_s cos(w1 s1 + w2 s2).
double gmrf_spectrum(const GmrfModel& m, double w1, double w2);

// Least squares over the pixels whose neighbourhood lies inside the band (no wrap), then the
// a_s shrunk (shrink < 1) when the smallest mu on a 64 x 64 grid of frequencies falls below
// kMinSpectrum, then sigma^2 set so that the exact synthesis at the band's size has the
// band's variance (moment matching). Asserts a one-channel field larger than the
// neighbourhood.
GmrfModel estimate_gmrf(const Field& band, const std::vector<Offset>& half);

// The order in 1 .. max_order whose estimate leaves the smallest conditional variance by more
// than 1% per added parameter (a simple penalised choice), an order too large skipped.
GmrfModel select_gmrf(const Field& band, int max_order = kMaxGmrfOrder);

// Exact synthesis on the width x height torus; mu_k below kMinSpectrum / 4 are raised to it,
// and the field's mean (the k = 0 term) is the model's.
// Deterministic from `seed`.
Field synthesise_gmrf(const GmrfModel& m, int width, int height, std::uint64_t seed);

}  // namespace btfgmm::detail
