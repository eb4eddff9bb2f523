// PLM RF's fit (Filip, Haindl 2004): a Lafortune lobe per texel, view and channel (step 1),
// then a polynomial per image and channel mapping the stored lobes' values to the data's
// (step 2).
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <vector>
#include "core/eigen_dense.hpp"

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/plm_rf.hpp"
#include "methods/factors.hpp"
#include "methods/plm_rf_lobe.hpp"

namespace btfgmm {
namespace {

constexpr int kDefaultIterations = 30, kMaxIterations = 1000;

struct PlmOptions {
  std::size_t degree = PlmRf::kDefaultDegree;
  int iterations = kDefaultIterations;
  int threads = 1;
};

PlmOptions check_settings(const Btf& tile, const FitOptions& s) {
  const auto not_here = [](std::string_view option, std::size_t value) {
    throw Error(Error::Kind::kArgument,
                fmt::format("{} {}: plm-rf's size is set by `degree` (the degree l of its "
                            "per-image polynomial, 1..{}); leave {} out",
                            option, value, PlmRf::kMaxDegree, option));
  };
  if (s.components != 0) not_here("`components`", s.components);
  if (s.clusters != 0) not_here("`clusters`", s.clusters);
  if (s.degree > PlmRf::kMaxDegree)
    throw Error(Error::Kind::kArgument,
                fmt::format("`degree` {}: plm-rf takes 1..{} (the degree l of the polynomial "
                            "per image; {} when not given)",
                            s.degree, PlmRf::kMaxDegree, PlmRf::kDefaultDegree));
  if (s.iterations < 0 || s.iterations > kMaxIterations)
    throw Error(Error::Kind::kArgument,
                fmt::format("`iterations` {}: plm-rf takes 1..{} Levenberg-Marquardt steps per "
                            "lobe ({} when not given)",
                            s.iterations, kMaxIterations, kDefaultIterations));
  if (tile.lights().size() < PlmRf::kLobeParameters)
    throw Error(Error::Kind::kArgument,
                fmt::format("plm-rf needs at least {} light directions to fit its {}-parameter "
                            "Lafortune lobe per texel; this BTF has {}",
                            PlmRf::kLobeParameters, PlmRf::kLobeParameters, tile.lights().size()));
  PlmOptions o;
  if (s.degree != 0) o.degree = s.degree;
  if (s.iterations != 0) o.iterations = s.iterations;
  o.threads = s.threads > 0 ? s.threads : omp_get_max_threads();
  return o;
}

// The data's largest value: the polynomials' variable is Y / scale, in [0, 1] on the data.
float data_scale(const Btf& tile) {
  float hi = 0.0f;
  for (float v : tile.data())
    if (std::isfinite(v)) hi = std::max(hi, v);
  return hi > 0.0f ? hi : 1.0f;
}

// Step 1 for one view: the lobes of every texel and channel, written as the view's five rows
// (rho, Cx, Cy, Cz, n) of W*H*3 values.
void fit_lobes(const Btf& tile, std::size_t view, const PlmOptions& o, float* out) {
  const std::size_t n = tile.image_floats(), ni = tile.lights().size();
  std::vector<Vec3> w(ni);
  for (std::size_t i = 0; i < ni; ++i) w[i] = to_vector(tile.lights()[i]);
#pragma omp parallel num_threads(o.threads)
  {
    std::vector<double> y(ni);
#pragma omp for schedule(dynamic, 16)
    for (std::ptrdiff_t jj = 0; jj < std::ptrdiff_t(n); ++jj) {
      const auto j = std::size_t(jj);
      for (std::size_t i = 0; i < ni; ++i) y[i] = double(tile.image(i, view)[j]);
      const detail::LobeParameters p = detail::fit_lafortune_lobe(w, y, o.iterations);
      out[j] = float(p.rho);
      out[n + j] = float(p.cx);
      out[2 * n + j] = float(p.cy);
      out[3 * n + j] = float(p.cz);
      out[4 * n + j] = float(p.n);
    }
  }
}

// The ridge that keeps step 2's polynomials near the identity where the data cannot tell
// them apart (a grazing light where every lobe is nearly dark, say): a deviation of the
// coefficients by d (in the data's units) costs kRidge * d^2 per texel, as much as that
// much less mean squared error. Without it such coefficients grow without bound, fit the
// rounding of the lobes, and explode at unmeasured lights and in 8-bit storage (a generated
// 16 x 16 knit tile: 32.0 dB at f32 but 14.7 dB at q8); with 1e-5 it gives 31.9 dB at f32
// and at q8.
constexpr double kRidge = 1e-5;

// Step 2 for one view: per light and channel, the least-squares polynomial of degree l from
// the stored lobes' values x = Y / scale (computed as decoding computes them) to the data,
// ridge-regularised toward the identity Yhat = scale * x (kRidge); written as (l+1) rows of
// ni*3 values.
void fit_polynomials(const Btf& tile, const float* lobes, std::size_t view, float scale,
                     const PlmOptions& o, float* out) {
  const std::size_t n = tile.image_floats(), ni = tile.lights().size(), pixels = n / 3;
  const std::size_t row = ni * 3, terms = o.degree + 1;
  const float inv = 1.0f / scale;
  const double ridge = std::sqrt(kRidge * double(pixels));
#pragma omp parallel num_threads(o.threads)
  {
    std::vector<float> y(n);
    const auto rows = Eigen::Index(pixels + terms), cols = Eigen::Index(terms);
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, cols);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(rows);
    a.bottomRows(cols).diagonal().setConstant(ridge);
    if (terms > 1) b(Eigen::Index(pixels) + 1) = ridge * double(scale);
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(rows, cols);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t ii = 0; ii < std::ptrdiff_t(ni); ++ii) {
      const auto i = std::size_t(ii);
      detail::lobe_image(lobes, n, to_vector(tile.lights()[i]), y.data());
      const float* d = tile.image(i, view);
      for (std::size_t c = 0; c < 3; ++c) {
        for (std::size_t p = 0; p < pixels; ++p) {
          const double x = double(y[p * 3 + c] * inv);
          const auto r = Eigen::Index(p);
          a(r, 0) = 1.0;
          for (Eigen::Index j = 1; j < cols; ++j) a(r, j) = a(r, j - 1) * x;
          b(r) = double(d[p * 3 + c]);
        }
        qr.compute(a);
        const Eigen::VectorXd coef = qr.solve(b);
        for (std::size_t j = 0; j < terms; ++j)
          out[j * row + i * 3 + c] = float(coef(Eigen::Index(j)));
      }
    }
  }
}

void check_stop(const FitOptions& s) {
  if (s.stop && s.stop->load()) throw Error(Error::Kind::kArgument, "plm-rf's fit was stopped");
}

}  // namespace

std::unique_ptr<Representation> fit_plm_rf(const Btf& tile, const FitOptions& s) {
  const PlmOptions o = check_settings(tile, s);
  const std::size_t n = tile.image_floats(), ni = tile.lights().size(), nv = tile.views().size();
  const std::size_t lobe_block = PlmRf::kLobeParameters * n, poly_block = (o.degree + 1) * ni * 3;
  std::vector<float> lobes(nv * lobe_block), polynomials(nv * poly_block);
  for (std::size_t v = 0; v < nv; ++v) {
    check_stop(s);
    fit_lobes(tile, v, o, lobes.data() + v * lobe_block);
    if (s.progress) s.progress(0.9 * double(v + 1) / double(nv), "Lafortune lobes (LM)");
  }
  // Stored first, so that the polynomials map the very lobes decoding evaluates.
  detail::quantise_factors(lobes, n, stored_encoding(s));
  const float scale = data_scale(tile);
  for (std::size_t v = 0; v < nv; ++v) {
    check_stop(s);
    fit_polynomials(tile, lobes.data() + v * lobe_block, v, scale, o,
                    polynomials.data() + v * poly_block);
    if (s.progress) s.progress(0.9 + 0.1 * double(v + 1) / double(nv), "per-image polynomials");
  }
  detail::quantise_factors(polynomials, ni * 3, stored_encoding(s));
  return std::make_unique<PlmRf>(ModelFrame::of(tile), o.degree, scale, std::move(lobes),
                                 std::move(polynomials), stored_encoding(s), o.iterations);
}

}  // namespace btfgmm
