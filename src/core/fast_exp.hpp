// A vectorisable exp for float: Cody-Waite range reduction x = n ln2 + r, |r| <= ln2 / 2,
// a degree-6 polynomial for exp(r) (Cephes' expf coefficients), and 2^n built in the
// exponent bits. Inputs below -87.3 return 0 (the sums it feeds are normalised, and
// exp(-87) is below float's normal range); NaN returns NaN. Relative error <= 3 ulp over
// [-87.3, 88] (tests/test_model.cpp measures it against std::exp in double).
#pragma once

#include <cstdint>
#include <cstring>

namespace btfgmm::detail {

inline float fast_exp(float x) {
  const float lo = -87.3f, hi = 88.0f;
  const bool under = x < lo;
  // NaN is returned as it came; the range reduction takes the clamp's lower end for it, so
  // that no NaN is converted to an integer below.
  const bool not_a_number = x != x;
  const float given = x;
  x = x >= lo ? (x > hi ? hi : x) : lo;
  // n = round(x / ln2), without a call: add and subtract 1.5 * 2^23.
  const float shifter = 12582912.0f;
  const float n = (x * 1.44269504088896341f + shifter) - shifter;
  float r = x - n * 0.693359375f;  // ln2, high part (exact product)
  r = r - n * -2.12194440e-4f;     // ln2, low part
  float p = 1.9875691500e-4f;
  p = p * r + 1.3981999507e-3f;
  p = p * r + 8.3334519073e-3f;
  p = p * r + 4.1665795894e-2f;
  p = p * r + 1.6666665459e-1f;
  p = p * r + 5.0000001201e-1f;
  p = p * r * r + r + 1.0f;
  const std::int32_t e = (static_cast<std::int32_t>(n) + 127) << 23;
  float scale;
  std::memcpy(&scale, &e, sizeof scale);
  const float y = p * scale;
  return under ? 0.0f : (not_a_number ? given : y);
}

}  // namespace btfgmm::detail
