// PCA RF (Sattler, Sarlette & Klein 2003): a PCA of each view's images.
#include "btfgmm/methods/pca_rf.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "btfgmm/core/error.hpp"
#include "methods/factors.hpp"
#include "methods/pca.hpp"
#include "methods/pca_methods.hpp"

namespace btfgmm {
namespace {

constexpr std::string_view kMethod = "pca-rf";

// At most one eigen-image fewer than the view's images, and no more than an image's values.
std::size_t max_components(std::size_t lights, std::size_t values) {
  return std::min(lights - 1, values);
}

// One view's stored factors: mean image, c eigen-images, c x ni weights.
struct ViewFactors {
  std::vector<float> mean, eigen, weights;
};

// The PCA of view v's images, stored as `e`; the weights are fitted to the stored mean and
// eigen-images, so that they make up for what the encoding rounded.
ViewFactors fit_view(const Btf& tile, std::size_t v, std::size_t c, const FitOptions& s) {
  const std::size_t ni = tile.lights().size(), d = tile.image_floats();
  std::vector<float> images(ni * d);
  for (std::size_t l = 0; l < ni; ++l)
    std::copy(tile.image(l, v), tile.image(l, v) + d, images.begin() + std::ptrdiff_t(l * d));
  detail::PcaSettings ps;
  ps.seed = s.seed + v;
  const detail::Pca p = detail::principal_components(images, ni, d, c, ps);
  ViewFactors f{detail::to_floats(p.mean), detail::to_floats(p.directions), {}};
  detail::quantise_factors(f.mean, d, stored_encoding(s));
  detail::quantise_factors(f.eigen, d, stored_encoding(s));
  f.weights = detail::transposed(
      detail::to_floats(detail::fit_coordinates(images, ni, d, f.mean, f.eigen, c)), ni, c);
  detail::quantise_factors(f.weights, ni, stored_encoding(s));
  return f;
}

}  // namespace

PcaRf::PcaRf(ModelFrame frame, std::size_t components, FactorEncoding encoding,
             std::vector<float> means, std::vector<float> eigen_images, std::vector<float> weights)
    : MeasuredImages(std::move(frame)),
      components_(components),
      encoding_(encoding),
      means_(std::move(means)),
      eigen_(std::move(eigen_images)),
      weights_(std::move(weights)) {}

std::string_view PcaRf::method() const {
  return kMethod;
}

std::string PcaRf::size_text() const {
  return fmt::format("c = {}", components_);
}

std::uint64_t pca_rf_parameter_count(const ModelFrame& f, std::size_t c) {
  const std::uint64_t values = f.pixels() * 3, lights = f.lights.size();
  return f.views.size() * ((c + 1) * values + c * lights);
}

std::uint64_t PcaRf::parameter_count() const {
  return pca_rf_parameter_count(frame(), components_);
}

void PcaRf::measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const {
  const std::size_t ni = frame().lights.size(), d = frame().pixels() * 3, c = components_,
                    o = (std::size_t(y) * std::size_t(frame().width) + std::size_t(x)) * 3;
  detail::mean_plus_components(means_.data() + view * d + o, eigen_.data() + view * c * d + o, d,
                               weights_.data() + view * c * ni + light, ni, c, 3, rgb);
}

void PcaRf::measured_image(std::size_t light, std::size_t view, float* rgb) const {
  const std::size_t ni = frame().lights.size(), d = frame().pixels() * 3, c = components_;
  detail::mean_plus_components(means_.data() + view * d, eigen_.data() + view * c * d, d,
                               weights_.data() + view * c * ni + light, ni, c, d, rgb);
}

Btf PcaRf::decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
                  double tolerance) const {
  const auto li = detail::measured_indices(frame().lights, lights),
             vi = detail::measured_indices(frame().views, views);
  if (!li || !vi || width != frame().width || height != frame().height)
    return MeasuredImages::decode(lights, views, width, height, tolerance);
  Btf out(lights, views, width, height, frame().format);
  out.set_origin(frame().origin);
  const std::size_t ni = frame().lights.size(), d = frame().pixels() * 3, c = components_;
  const std::ptrdiff_t asked_views = std::ptrdiff_t(vi->size());
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t b = 0; b < asked_views; ++b) {
    const std::size_t v = (*vi)[std::size_t(b)];
    std::vector<float> w(li->size() * c);
    for (std::size_t a = 0; a < li->size(); ++a)
      for (std::size_t k = 0; k < c; ++k) w[a * c + k] = weights_[(v * c + k) * ni + (*li)[a]];
    // The view's images lie views.size() images apart in the light-major Btf.
    detail::affine_product(w.data(), eigen_.data() + v * c * d, means_.data() + v * d, li->size(),
                           c, d, out.image(0, std::size_t(b)), d * vi->size());
  }
  return out;
}

std::vector<std::uint8_t> PcaRf::payload() const {
  detail::ByteWriter w;
  detail::put_frame(w, frame());
  w.put<std::uint32_t>(std::uint32_t(components_));
  w.put<std::uint8_t>(std::uint8_t(encoding_));
  const std::size_t d = frame().pixels() * 3;
  detail::put_factors(w, means_, d, encoding_, detail::image_layout(frame()));
  detail::put_factors(w, eigen_, d, encoding_, detail::image_layout(frame()));
  detail::put_factors(w, weights_, frame().lights.size(), encoding_);  // a line of lights
  return std::move(w.bytes);
}

std::vector<std::pair<std::string, std::string>> PcaRf::details() const {
  const std::size_t ni = frame().lights.size();
  return {
      {"eigen-images per view",
       fmt::format("{} of at most {}", components_, max_components(ni, frame().pixels() * 3))},
      {"views", fmt::format("{}, each a PCA of {} light images of {} x {} pixels",
                            frame().views.size(), ni, frame().width, frame().height)},
      {"factor encoding", std::string(to_string(encoding_))},
      {"stored values",
       fmt::format("{} (per view: mean image, eigen-images, weights)", parameter_count())},
  };
}

std::unique_ptr<Representation> fit_pca_rf(const Btf& tile, const FitOptions& s) {
  detail::refuse_clusters(s, kMethod);
  const std::size_t ni = tile.lights().size(), nv = tile.views().size(), d = tile.image_floats();
  const std::size_t c = detail::components_setting(
      s, kMethod, 6, max_components(ni, d), fmt::format("this tile of {} lights a view", ni));
  const detail::ThreadScope threads(s.threads);
  std::vector<ViewFactors> views(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    detail::check_stop(s, kMethod);
    detail::report(s, double(v) / double(nv), "PCA of each view's images");
    views[v] = fit_view(tile, v, c, s);
  }
  std::vector<float> means, eigen, weights;
  for (const ViewFactors& f : views) {
    means.insert(means.end(), f.mean.begin(), f.mean.end());
    eigen.insert(eigen.end(), f.eigen.begin(), f.eigen.end());
    weights.insert(weights.end(), f.weights.begin(), f.weights.end());
  }
  detail::report(s, 1.0, "done");
  return std::make_unique<PcaRf>(ModelFrame::of(tile), c, stored_encoding(s), std::move(means),
                                 std::move(eigen), std::move(weights));
}

std::unique_ptr<Representation> read_pca_rf(std::span<const std::uint8_t> payload,
                                            std::uint32_t flags, const std::string& name) {
  detail::ByteReader r(payload, "model file", name, "fit the model again");
  detail::expect_no_flags(r, flags);
  ModelFrame f = detail::get_frame(r);
  const std::size_t ni = f.lights.size(), nv = f.views.size(), d = f.pixels() * 3;
  if (ni < 2) r.fail("a PCA RF needs at least 2 lights");
  const std::size_t c = detail::get_count(r, 1, max_components(ni, d), "eigen-images per view");
  const FactorEncoding e = detail::get_encoding(r);
  detail::expect_bytes_for(r, double(nv) * (double(c + 1) * double(d) + double(c) * double(ni)), e,
                           fmt::format("{} views of {} eigen-images", nv, c));
  const detail::FactorLayout image = detail::image_layout(f);
  auto means = detail::get_factors_as(r, payload, nv, d, e, "mean images", image);
  auto eigen = detail::get_factors_as(r, payload, nv * c, d, e, "eigen-images", image);
  auto weights = detail::get_factors_as(r, payload, nv * c, ni, e, "weights");
  detail::expect_end(r);
  return std::make_unique<PcaRf>(std::move(f), c, e, std::move(means), std::move(eigen),
                                 std::move(weights));
}

std::vector<FitOptions> pca_rf_ladder(const ModelFrame& frame) {
  const std::size_t ni = frame.lights.size();
  if (ni < 2) return {};
  std::vector<double> ratios;
  for (std::size_t c = 1; c <= max_components(ni, frame.pixels() * 3); ++c)
    ratios.push_back(frame.data_values() / double(pca_rf_parameter_count(frame, c)));
  std::vector<FitOptions> out;
  for (std::size_t i : detail::ladder_choice(ratios)) {
    FitOptions s;
    s.components = i + 1;
    out.push_back(s);
  }
  return out;
}

}  // namespace btfgmm
