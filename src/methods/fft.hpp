// The 2-D discrete Fourier transform of a real image on a torus (internal), by FFTW3 (Frigo &
// Johnson 2005): what Frankot-Chellappa integration and the GMRF's exact synthesis use.
#pragma once

#include <complex>
#include <vector>

#include "methods/texture_field.hpp"

namespace btfgmm::detail {

// The spectrum of a one-channel field, W*H complex values in the field's order:
// F(k1, k2) = sum_{x,y} f(x, y) exp(-2 pi i (k1 x / W + k2 y / H)), unnormalised.
std::vector<std::complex<double>> forward_dft(const Field& f);
// The real part of the inverse: f(x, y) = 1/(W H) sum_k F(k) exp(+2 pi i (...)).
Field inverse_dft(const std::vector<std::complex<double>>& spectrum, int width, int height);

// The signed angular frequency of index k on a period of n samples: 2 pi k / n for k <= n/2,
// 2 pi (k - n) / n above.
double angular_frequency(int k, int n);

}  // namespace btfgmm::detail
