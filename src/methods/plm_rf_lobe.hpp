// PLM RF's first step (Filip, Haindl 2004): one Lafortune lobe per texel, view and channel,
// fitted to the values at the measured lights by Levenberg-Marquardt; and the lobes of one
// view evaluated over a whole image, the one evaluation the fit and decoding share.
#pragma once

#include <cstddef>
#include <span>

#include "btfgmm/core/directions.hpp"

namespace btfgmm::detail {

// The largest exponent n a fitted lobe takes (sharper lobes are not resolved by the measured
// lights anyway, and a bounded n keeps 8-bit storage of n useful).
constexpr double kMaxLobeExponent = 128.0;

// rho * max(0, c . w)^n with |c| = 1, rho >= 0, 0 <= n <= kMaxLobeExponent.
struct LobeParameters {
  double rho = 0.0, cx = 0.0, cy = 0.0, cz = 1.0, n = 1.0;
};

// Least squares over the lights `w` (unit vectors) and `values`: the best of a grid of start
// values (axes toward the brightest light, the value-weighted mean light and the normal;
// exponents 0 .. 64, rho in closed form), then at most `iterations` Levenberg-Marquardt
// steps with the analytic Jacobian. Deterministic.
LobeParameters fit_lafortune_lobe(std::span<const Vec3> w, std::span<const double> values,
                                  int iterations);

// The lobe values of one view at light `w`: `lobes` holds the view's five rows (rho, Cx, Cy,
// Cz, n) of `n` values each (W*H*3, RGB interleaved); writes n floats to `out`.
void lobe_image(const float* lobes, std::size_t n, const Vec3& w, float* out);

}  // namespace btfgmm::detail
