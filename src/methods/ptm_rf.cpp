// PTM RF: a polynomial texture map per view (Malzbender, Gelb, Wolters 2001), fitted by one
// pseudo-inverse of the lights' design matrix.
#include "btfgmm/methods/ptm_rf.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include "core/eigen_dense.hpp"

#include "btfgmm/core/error.hpp"
#include "methods/factors.hpp"

namespace btfgmm {
namespace {

constexpr std::string_view kMethod = "ptm-rf";

// The pixels' values that one decoded image holds (W*H*3).
std::size_t image_values(const ModelFrame& f) {
  return f.pixels() * 3;
}

}  // namespace

PtmRf::PtmRf(ModelFrame frame, std::vector<float> coefficients, FactorEncoding encoding)
    : MeasuredImages(std::move(frame)),
      coefficients_(std::move(coefficients)),
      encoding_(encoding) {
  assert(coefficients_.size() ==
         this->frame().views.size() * kCoefficients * image_values(this->frame()));
}

// Malzbender et al. 2001, Eq. (2): the biquadratic's terms in (lu, lv), their coefficient order.
std::array<double, PtmRf::kCoefficients> PtmRf::basis(const Direction& light) {
  const Vec3 v = to_vector(light);
  return {v.x * v.x, v.y * v.y, v.x * v.y, v.x, v.y, 1.0};
}

std::string_view PtmRf::method() const {
  return kMethod;
}

std::uint64_t ptm_rf_parameter_count(const ModelFrame& frame) {
  return std::uint64_t(frame.views.size()) * std::uint64_t(image_values(frame)) *
         PtmRf::kCoefficients;
}

std::uint64_t PtmRf::parameter_count() const {
  return ptm_rf_parameter_count(frame());
}

void PtmRf::image_at(const std::array<double, kCoefficients>& terms, std::size_t view,
                     float* rgb) const {
  const std::size_t n = image_values(frame());
  const float* c = coefficients_.data() + view * kCoefficients * n;
  const float t0 = float(terms[0]), t1 = float(terms[1]), t2 = float(terms[2]),
              t3 = float(terms[3]), t4 = float(terms[4]), t5 = float(terms[5]);
#pragma omp simd
  for (std::size_t j = 0; j < n; ++j)
    rgb[j] = t0 * c[j] + t1 * c[n + j] + t2 * c[2 * n + j] + t3 * c[3 * n + j] + t4 * c[4 * n + j] +
             t5 * c[5 * n + j];
}

void PtmRf::pixel_at(const std::array<double, kCoefficients>& terms, std::size_t view, int x, int y,
                     float* rgb) const {
  const std::size_t n = image_values(frame());
  const std::size_t at = (std::size_t(y) * std::size_t(frame().width) + std::size_t(x)) * 3;
  const float* c = coefficients_.data() + view * kCoefficients * n + at;
  for (std::size_t ch = 0; ch < 3; ++ch) {
    float sum = 0.0f;
    for (std::size_t k = 0; k < kCoefficients; ++k) sum += float(terms[k]) * c[k * n + ch];
    rgb[ch] = sum;
  }
}

void PtmRf::light_pixels(const Direction& light, std::span<const ViewPixel> samples,
                         float* rgb) const {
  const auto terms = basis(light);
  for (std::size_t i = 0; i < samples.size(); ++i)
    pixel_at(terms, samples[i].view, samples[i].x, samples[i].y, rgb + i * 3);
}

void PtmRf::light_image(const Direction& light, std::size_t view, float* rgb) const {
  image_at(basis(light), view, rgb);
}

void PtmRf::measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const {
  pixel_at(basis(frame().lights[light]), view, x, y, rgb);
}

void PtmRf::measured_image(std::size_t light, std::size_t view, float* rgb) const {
  image_at(basis(frame().lights[light]), view, rgb);
}

std::vector<std::uint8_t> PtmRf::payload() const {
  detail::ByteWriter w;
  detail::put_frame(w, frame());
  w.put<std::uint32_t>(std::uint32_t(kCoefficients));
  detail::put_factors(w, coefficients_, image_values(frame()), encoding_,
                      detail::image_layout(frame()));
  return std::move(w.bytes);
}

std::vector<std::pair<std::string, std::string>> PtmRf::details() const {
  return {
      {"coefficients", "6 per texel, view and channel: a biquadratic in the light's (lu, lv)"},
      {"views", fmt::format("{} maps of {} lights", frame().views.size(), frame().lights.size())},
      {"factor encoding", std::string(to_string(encoding_))},
  };
}

namespace {

void check_settings(const FitOptions& s) {
  const auto fixed = [](std::string_view option, auto value) {
    throw Error(Error::Kind::kArgument,
                fmt::format("{} {}: ptm-rf has a fixed size (6 coefficients per texel, view and "
                            "channel) and fits in closed form; leave {} out",
                            option, value, option));
  };
  if (s.components != 0) fixed("`components`", s.components);
  if (s.clusters != 0) fixed("`clusters`", s.clusters);
  if (s.degree != 0) fixed("`degree`", s.degree);
  if (s.iterations != 0) fixed("`iterations`", s.iterations);
}

// The least-squares fit's operator (Malzbender et al. 2001, Sec. 3.1): the pseudo-inverse
// (6 x ni) of the design matrix whose row i is basis(light i). Throws when the lights do not
// determine the six coefficients.
Eigen::MatrixXd pseudo_inverse(const DirectionSet& lights) {
  const auto ni = Eigen::Index(lights.size());
  if (ni < Eigen::Index(PtmRf::kCoefficients))
    throw Error(Error::Kind::kArgument,
                fmt::format("ptm-rf needs at least 6 light directions to fit its 6 coefficients "
                            "per texel; this BTF has {}",
                            ni));
  Eigen::MatrixXd a(ni, Eigen::Index(PtmRf::kCoefficients));
  for (Eigen::Index i = 0; i < ni; ++i) {
    const auto t = PtmRf::basis(lights[std::size_t(i)]);
    for (Eigen::Index k = 0; k < a.cols(); ++k) a(i, k) = t[std::size_t(k)];
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const auto rank = (sv.array() > 1e-9 * sv(0)).count();
  if (rank < a.cols())
    throw Error(Error::Kind::kArgument,
                fmt::format("ptm-rf needs light directions that determine its biquadratic in "
                            "(lu, lv); the {} lights of this BTF fix only {} of its 6 "
                            "coefficients (lights at a single elevation fix 5); give lights at "
                            "two elevations or more",
                            ni, rank));
  return svd.solve(Eigen::MatrixXd::Identity(ni, ni));
}

// One view's six coefficient images (6 x W*H*3, row-major): the pseudo-inverse times the
// view's images, in double, in blocks of values that vectorise.
void fit_view(const Btf& tile, const Eigen::MatrixXd& pinv, std::size_t view, int threads,
              float* out) {
  constexpr std::size_t kBlock = 256, kK = PtmRf::kCoefficients;
  const std::size_t n = tile.image_floats(), ni = tile.lights().size();
  const auto blocks = std::ptrdiff_t((n + kBlock - 1) / kBlock);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t b = 0; b < blocks; ++b) {
    const std::size_t j0 = std::size_t(b) * kBlock, len = std::min(kBlock, n - j0);
    double acc[kK][kBlock] = {};
    for (std::size_t i = 0; i < ni; ++i) {
      const float* d = tile.image(i, view) + j0;
      for (std::size_t k = 0; k < kK; ++k) {
        const double p = pinv(Eigen::Index(k), Eigen::Index(i));
#pragma omp simd
        for (std::size_t j = 0; j < len; ++j) acc[k][j] += p * double(d[j]);
      }
    }
    for (std::size_t k = 0; k < kK; ++k)
      for (std::size_t j = 0; j < len; ++j) out[k * n + j0 + j] = float(acc[k][j]);
  }
}

}  // namespace

std::unique_ptr<Representation> fit_ptm_rf(const Btf& tile, const FitOptions& s) {
  check_settings(s);
  const Eigen::MatrixXd pinv = pseudo_inverse(tile.lights());
  const std::size_t nv = tile.views().size(), n = tile.image_floats();
  std::vector<float> coefficients(nv * PtmRf::kCoefficients * n);
  const int threads = s.threads > 0 ? s.threads : omp_get_max_threads();
  for (std::size_t v = 0; v < nv; ++v) {
    if (s.stop && s.stop->load()) throw Error(Error::Kind::kArgument, "ptm-rf's fit was stopped");
    fit_view(tile, pinv, v, threads, coefficients.data() + v * PtmRf::kCoefficients * n);
    if (s.progress) s.progress(double(v + 1) / double(nv), "least squares per view");
  }
  detail::quantise_factors(coefficients, n, stored_encoding(s));
  return std::make_unique<PtmRf>(ModelFrame::of(tile), std::move(coefficients), stored_encoding(s));
}

std::unique_ptr<Representation> read_ptm_rf(std::span<const std::uint8_t> payload,
                                            std::uint32_t flags, const std::string& name) {
  detail::ByteReader r(payload, "model file", name, "fit the model again");
  if (flags != 0) r.fail(fmt::format("ptm-rf takes no flags, the file has {:#x}", flags));
  ModelFrame frame = detail::get_frame(r);
  detail::get_count(r, PtmRf::kCoefficients, PtmRf::kCoefficients, "ptm-rf coefficients");
  const std::size_t n = image_values(frame);
  const std::uint8_t encoding = detail::ByteReader(r).get<std::uint8_t>("factor encoding");
  std::vector<float> coefficients =
      detail::get_factors(r, frame.views.size() * PtmRf::kCoefficients, n, "ptm-rf coefficients",
                          detail::image_layout(frame));
  if (r.remaining() != 0) r.fail(fmt::format("{} bytes follow the model", r.remaining()));
  return std::make_unique<PtmRf>(std::move(frame), std::move(coefficients),
                                 FactorEncoding(encoding));
}

}  // namespace btfgmm
