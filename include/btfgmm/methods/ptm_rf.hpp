// PTM RF: a polynomial texture map per view (Malzbender, Gelb, Wolters 2001, "Polynomial
// texture maps"), the reflectance field of each measured view. Per texel, view and channel
//   L(lu, lv) = a0 lu^2 + a1 lv^2 + a2 lu lv + a3 lu + a4 lv + a5,
// (lu, lv) = (sin theta_i cos phi_i, sin theta_i sin phi_i), the light direction projected on
// the tangent plane. The six coefficients are fitted by linear least squares: the ni x 6
// design matrix depends only on the lights, so one pseudo-inverse serves every texel of every
// view. The map is analytic in the light: any light is evaluated exactly, views are
// interpolated (MeasuredImages).
//
// Stored: nv * W*H * 3 * 6 values; Table 2 counts 3 ni / 18 = 13.5 for 81 lights.
// Payload (after the model file's method tag): the frame (methods/factors.hpp), u32 6 (the
// coefficients), then the coefficients as factors (nv*6 rows of W*H*3 values: row
// view*6 + k holds a_k of every texel and channel, texel-major, RGB interleaved).
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

class PtmRf final : public MeasuredImages {
 public:
  static constexpr std::size_t kCoefficients = 6;

  // `coefficients`: nv * 6 * W*H*3 floats in the payload's order, already quantised to
  // `encoding` (quantise_factors). Asserts the size.
  PtmRf(ModelFrame frame, std::vector<float> coefficients, FactorEncoding encoding);

  // The biquadratic's terms at a light: (lu^2, lv^2, lu lv, lu, lv, 1).
  static std::array<double, kCoefficients> basis(const Direction& light);

  std::span<const float> coefficients() const { return coefficients_; }
  FactorEncoding encoding() const override { return encoding_; }

  std::string_view method() const override;
  std::string size_text() const override { return "6 coefficients"; }
  double size_order() const override { return double(parameter_count()); }
  std::uint64_t parameter_count() const override;

  void measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const override;
  void measured_image(std::size_t light, std::size_t view, float* rgb) const override;
  // Exact at any light: the polynomial evaluated there.
  void light_pixels(const Direction& light, std::span<const ViewPixel> samples,
                    float* rgb) const override;
  void light_image(const Direction& light, std::size_t view, float* rgb) const override;

  std::vector<std::uint8_t> payload() const override;
  std::vector<std::pair<std::string, std::string>> details() const override;

 private:
  void image_at(const std::array<double, kCoefficients>& terms, std::size_t view, float* rgb) const;
  void pixel_at(const std::array<double, kCoefficients>& terms, std::size_t view, int x, int y,
                float* rgb) const;

  std::vector<float> coefficients_;
  FactorEncoding encoding_;
};

// nv * W*H * 3 * 6: the values PTM RF stores for a tile of `frame`, as Table 2 counts them.
std::uint64_t ptm_rf_parameter_count(const ModelFrame& frame);

// Fits the maps. Throws Error(kArgument) for fewer than 6 lights, lights that do not
// determine the biquadratic (e.g. all at one elevation), and any size setting
// (--components, --clusters, --degree, --iterations): PTM RF has a fixed size.
std::unique_ptr<Representation> fit_ptm_rf(const Btf& tile, const FitOptions& s);
// Reads the payload; Error(kFormat) naming `name`.
std::unique_ptr<Representation> read_ptm_rf(std::span<const std::uint8_t> payload,
                                            std::uint32_t flags, const std::string& name);

}  // namespace btfgmm
