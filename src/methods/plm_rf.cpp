// PLM RF (Filip, Haindl 2004): Lafortune lobes per texel and view, mapped by a polynomial
// per image; evaluation, the payload and reading it.
#include "btfgmm/methods/plm_rf.hpp"

#include <fmt/format.h>

#include <array>
#include <cassert>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "methods/factors.hpp"
#include "methods/plm_rf_lobe.hpp"

namespace btfgmm {
namespace {

constexpr std::string_view kMethod = "plm-rf";

std::size_t image_values(const ModelFrame& f) {
  return f.pixels() * 3;
}

// Horner's rule for sum_j a[j*3] x^j, j = 0..degree (a points at one channel's a_0).
float polynomial(const float* a, std::size_t degree, float x) {
  float v = a[degree * 3];
  for (std::size_t j = degree; j-- > 0;) v = v * x + a[j * 3];
  return v;
}

}  // namespace

PlmRf::PlmRf(ModelFrame frame, std::size_t degree, float scale, std::vector<float> lobes,
             std::vector<float> polynomials, FactorEncoding encoding, int iterations)
    : MeasuredImages(std::move(frame)),
      degree_(degree),
      scale_(scale),
      lobes_(std::move(lobes)),
      polynomials_(std::move(polynomials)),
      encoding_(encoding),
      iterations_(iterations) {
  const ModelFrame& f = this->frame();
  assert(degree_ <= kMaxDegree && scale_ > 0.0f);
  assert(lobes_.size() == f.views.size() * kLobeParameters * image_values(f));
  assert(polynomials_.size() == f.views.size() * (degree_ + 1) * f.lights.size() * 3);
  (void)f;
}

std::string_view PlmRf::method() const {
  return kMethod;
}

std::string PlmRf::size_text() const {
  return fmt::format("l = {}", degree_);
}

std::uint64_t plm_rf_parameter_count(const ModelFrame& frame, std::size_t degree) {
  const std::uint64_t nv = frame.views.size(), ni = frame.lights.size();
  return nv * std::uint64_t(image_values(frame)) * PlmRf::kLobeParameters +
         nv * ni * 3 * std::uint64_t(degree + 1);
}

std::uint64_t PlmRf::parameter_count() const {
  return plm_rf_parameter_count(frame(), degree_);
}

PlmRf::Polynomial PlmRf::polynomial_of(std::size_t light, std::size_t view) const {
  const std::size_t row = frame().lights.size() * 3;
  const float* a = polynomials_.data() + view * (degree_ + 1) * row + light * 3;
  Polynomial out{};
  for (std::size_t j = 0; j <= degree_; ++j)
    for (std::size_t c = 0; c < 3; ++c) out[j * 3 + c] = a[j * row + c];
  return out;
}

// The coefficients blended with the lights' barycentric weights (see the header).
PlmRf::Polynomial PlmRf::polynomial_at(const Direction& light, std::size_t view) const {
  const auto w = light_interpolator().weights(light);
  std::array<double, (kMaxDegree + 1) * 3> sum{};
  for (std::size_t k = 0; k < 3; ++k) {
    if (w.weight[k] == 0.0) continue;
    const Polynomial a = polynomial_of(w.index[k], view);
    for (std::size_t i = 0; i < a.size(); ++i) sum[i] += w.weight[k] * double(a[i]);
  }
  Polynomial out{};
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = float(sum[i]);
  return out;
}

void PlmRf::image_at(const Vec3& w, const float* poly, std::size_t view, float* rgb) const {
  const std::size_t n = image_values(frame());
  detail::lobe_image(lobes_.data() + view * kLobeParameters * n, n, w, rgb);
  const float inv = 1.0f / scale_;
  for (std::size_t j = 0; j < n; ++j) rgb[j] = polynomial(poly + j % 3, degree_, rgb[j] * inv);
}

void PlmRf::pixel_at(const Vec3& w, const float* poly, std::size_t view, int x, int y,
                     float* rgb) const {
  const std::size_t n = image_values(frame());
  const std::size_t at = (std::size_t(y) * std::size_t(frame().width) + std::size_t(x)) * 3;
  const float* p = lobes_.data() + view * kLobeParameters * n + at;
  const float inv = 1.0f / scale_;
  for (std::size_t c = 0; c < 3; ++c) {
    const float lobe = lafortune_lobe(p[c], p[n + c], p[2 * n + c], p[3 * n + c], p[4 * n + c], w);
    rgb[c] = polynomial(poly + c, degree_, lobe * inv);
  }
}

void PlmRf::measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const {
  pixel_at(to_vector(frame().lights[light]), polynomial_of(light, view).data(), view, x, y, rgb);
}

void PlmRf::measured_image(std::size_t light, std::size_t view, float* rgb) const {
  image_at(to_vector(frame().lights[light]), polynomial_of(light, view).data(), view, rgb);
}

// The blended polynomial is made once per view: predict gives the samples grouped by view.
void PlmRf::light_pixels(const Direction& light, std::span<const ViewPixel> samples,
                         float* rgb) const {
  const Vec3 w = to_vector(light);
  Polynomial poly{};
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const ViewPixel& s = samples[i];
    if (i == 0 || s.view != samples[i - 1].view) poly = polynomial_at(light, s.view);
    pixel_at(w, poly.data(), s.view, s.x, s.y, rgb + i * 3);
  }
}

void PlmRf::light_image(const Direction& light, std::size_t view, float* rgb) const {
  image_at(to_vector(light), polynomial_at(light, view).data(), view, rgb);
}

std::vector<std::uint8_t> PlmRf::payload() const {
  detail::ByteWriter w;
  detail::put_frame(w, frame());
  w.put<std::uint32_t>(std::uint32_t(degree_));
  w.put<std::uint32_t>(std::uint32_t(iterations_));
  w.put<float>(scale_);
  detail::put_factors(w, lobes_, image_values(frame()), encoding_, detail::image_layout(frame()));
  detail::put_factors(w, polynomials_, frame().lights.size() * 3, encoding_, {0, 3});
  return std::move(w.bytes);
}

std::vector<std::pair<std::string, std::string>> PlmRf::details() const {
  return {
      {"lobes", "1 Lafortune lobe per texel, view and channel (rho, Cx, Cy, Cz, n)"},
      {"polynomial degree", fmt::format("l = {} per image and channel", degree_)},
      {"Levenberg-Marquardt steps", fmt::format("at most {} per lobe", iterations_)},
      {"value scale", fmt::format("{:g} (the polynomials' variable is Y / {:g})", scale_, scale_)},
      {"unmeasured lights", "polynomial coefficients blended with barycentric weights"},
      {"factor encoding", std::string(to_string(encoding_))},
  };
}

std::unique_ptr<Representation> read_plm_rf(std::span<const std::uint8_t> payload,
                                            std::uint32_t flags, const std::string& name) {
  detail::ByteReader r(payload, "model file", name, "fit the model again");
  if (flags != 0) r.fail(fmt::format("plm-rf takes no flags, the file has {:#x}", flags));
  ModelFrame frame = detail::get_frame(r);
  const std::size_t degree = detail::get_count(r, 0, PlmRf::kMaxDegree, "plm-rf degree");
  const auto iterations = int(detail::get_count(r, 0, 1000000, "plm-rf LM steps"));
  const float scale = r.get<float>("plm-rf value scale");
  if (!(scale > 0.0f) || !std::isfinite(scale))
    r.fail(fmt::format("plm-rf value scale {} is not positive", scale));
  const std::size_t n = image_values(frame), ni = frame.lights.size(), nv = frame.views.size();
  const std::uint8_t encoding = detail::ByteReader(r).get<std::uint8_t>("factor encoding");
  std::vector<float> lobes = detail::get_factors(r, nv * PlmRf::kLobeParameters, n, "plm-rf lobes",
                                                 detail::image_layout(frame));
  if (detail::ByteReader(r).get<std::uint8_t>("factor encoding") != encoding)
    r.fail("plm-rf's lobes and polynomials are stored in different encodings");
  std::vector<float> polynomials =
      detail::get_factors(r, nv * (degree + 1), ni * 3, "plm-rf polynomials", {0, 3});
  if (r.remaining() != 0) r.fail(fmt::format("{} bytes follow the model", r.remaining()));
  return std::make_unique<PlmRf>(std::move(frame), degree, scale, std::move(lobes),
                                 std::move(polynomials), FactorEncoding(encoding), iterations);
}

}  // namespace btfgmm
