// PLM RF: the polynomial-extended Lafortune model per view (Filip, Haindl 2004, "Non-linear
// reflectance model for bidirectional texture function synthesis", ICPR; Filip, Haindl 2009,
// "Bidirectional texture function modeling: a state of the art survey", PAMI, Sec. 5.1).
//
// Step 1, per texel r, view v and channel: one Lafortune lobe in the light direction
// w = (wx, wy, wz), Y = rho * (Cx wx + Cy wy + Cz wz)^n, the base clamped at 0. It is
// Lafortune's rho * [w^T diag(C) w_v]^n with the fixed view's w_v folded into C; the stored
// C is the lobe's unit axis (a change of rho's scale, nothing else). Fitted by
// Levenberg-Marquardt in double with an analytic Jacobian from the best of several start
// values. Five values: rho, Cx, Cy, Cz, n.
// Step 2, per image (light i, view v) and channel, shared by all texels: a polynomial of
// degree l mapping the lobes' values to the data's,
//   Yhat = sum_{j=0..l} a_j (Y / s)^j,
// fitted by linear least squares after the lobes are stored (so that it also absorbs their
// rounding), with a small ridge toward the identity Yhat = Y: where an image's lobe values
// span too little to determine the polynomial (a grazing light) its coefficients stay near
// the identity instead of growing without bound, which would wreck unmeasured lights and
// 8-bit storage. s is the data's largest value (stored once): the powers lie in [0, 1].
//
// At an unmeasured light the lobe is evaluated exactly; the polynomial's coefficients, known
// only at the measured lights, are blended with the light interpolator's barycentric weights
// (DirectionInterpolator). That equals blending the three measured lights' polynomials
// evaluated at the exact lobe value, since a polynomial is linear in its coefficients.
//
// Stored: nv * W*H * 3 * 5 + nv * ni * 3 * (l + 1) values (Table 2: 14.3 with l = 4).
// Payload: the frame (methods/factors.hpp), u32 l, u32 the LM steps of the fit, f32 s, then
// the lobes as factors (nv*5 rows of W*H*3 values: row v*5 + p holds parameter p of
// every texel and channel, RGB interleaved), then the polynomials as factors (nv*(l+1) rows
// of ni*3 values: row v*(l+1) + j holds a_j of every light and channel).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/methods/measured_images.hpp"

namespace btfgmm {

// One Lafortune lobe's value at light direction w (a unit vector with w.z >= 0):
// rho * max(0, Cx wx + Cy wy + Cz wz)^n, 0 where the base is not positive.
float lafortune_lobe(float rho, float cx, float cy, float cz, float n, const Vec3& w);

class PlmRf final : public MeasuredImages {
 public:
  static constexpr std::size_t kLobeParameters = 5;  // rho, Cx, Cy, Cz, n
  static constexpr std::size_t kMaxDegree = 8;
  static constexpr std::size_t kDefaultDegree = 4;

  // `lobes`: nv * 5 * W*H*3 floats, `polynomials`: nv * (degree+1) * ni*3 floats, in the
  // payload's order and already quantised to `encoding`; `scale` > 0. Asserts the sizes.
  PlmRf(ModelFrame frame, std::size_t degree, float scale, std::vector<float> lobes,
        std::vector<float> polynomials, FactorEncoding encoding, int iterations);

  std::size_t degree() const { return degree_; }
  float scale() const { return scale_; }
  std::span<const float> lobes() const { return lobes_; }
  std::span<const float> polynomials() const { return polynomials_; }
  FactorEncoding encoding() const override { return encoding_; }

  std::string_view method() const override;
  std::string size_text() const override;
  double size_order() const override { return double(parameter_count()); }
  std::uint64_t parameter_count() const override;

  void measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const override;
  void measured_image(std::size_t light, std::size_t view, float* rgb) const override;
  // The lobe exact at any light, the polynomial blended over the measured lights.
  void light_pixels(const Direction& light, std::span<const ViewPixel> samples,
                    float* rgb) const override;
  void light_image(const Direction& light, std::size_t view, float* rgb) const override;

  std::vector<std::uint8_t> payload() const override;
  std::vector<std::pair<std::string, std::string>> details() const override;

 private:
  // The polynomial of measured light `light` (or blended at any light): a_j of channel c at
  // [j*3 + c], j = 0..l.
  using Polynomial = std::array<float, (kMaxDegree + 1) * 3>;
  Polynomial polynomial_of(std::size_t light, std::size_t view) const;
  Polynomial polynomial_at(const Direction& light, std::size_t view) const;
  void image_at(const Vec3& w, const float* poly, std::size_t view, float* rgb) const;
  void pixel_at(const Vec3& w, const float* poly, std::size_t view, int x, int y, float* rgb) const;

  std::size_t degree_;
  float scale_;
  std::vector<float> lobes_, polynomials_;
  FactorEncoding encoding_;
  int iterations_;
};

// nv * W*H * 3 * 5 + nv * ni * 3 * (degree + 1): the values PLM RF stores for a tile of
// `frame`, as Table 2 counts them.
std::uint64_t plm_rf_parameter_count(const ModelFrame& frame, std::size_t degree);

// Fits the lobes and polynomials: s.degree = l (1..8, default 4), s.iterations = LM steps
// (1..1000, default 30). Throws Error(kArgument) for fewer than 5 lights, a setting out of
// range, or --components / --clusters.
std::unique_ptr<Representation> fit_plm_rf(const Btf& tile, const FitOptions& s);
// Reads the payload; Error(kFormat) naming `name`.
std::unique_ptr<Representation> read_plm_rf(std::span<const std::uint8_t> payload,
                                            std::uint32_t flags, const std::string& name);

}  // namespace btfgmm
