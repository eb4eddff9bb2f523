// PCA BTF (Koudelka, Magda, Belhumeur & Kriegman 2003): one PCA of all the tile's images.
#include "btfgmm/methods/pca_btf.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "btfgmm/core/error.hpp"
#include "methods/factors.hpp"
#include "methods/pca.hpp"
#include "methods/pca_methods.hpp"

namespace btfgmm {
namespace {

constexpr std::string_view kMethod = "pca-btf";

// At most one eigen-image fewer than the images (the centred images span at most ni*nv - 1
// dimensions) and no more than an image's values.
std::size_t max_components(std::size_t images, std::size_t values) {
  return std::min(images - 1, values);
}

}  // namespace

PcaBtf::PcaBtf(ModelFrame frame, std::size_t components, FactorEncoding encoding,
               std::vector<float> mean, std::vector<float> eigen_images, std::vector<float> weights)
    : MeasuredImages(std::move(frame)),
      components_(components),
      encoding_(encoding),
      mean_(std::move(mean)),
      eigen_(std::move(eigen_images)),
      weights_(std::move(weights)) {}

std::string_view PcaBtf::method() const {
  return kMethod;
}

std::string PcaBtf::size_text() const {
  return fmt::format("c = {}", components_);
}

std::uint64_t pca_btf_parameter_count(const ModelFrame& f, std::size_t c) {
  const std::uint64_t values = f.pixels() * 3, images = f.lights.size() * f.views.size();
  return (c + 1) * values + c * images;
}

std::uint64_t PcaBtf::parameter_count() const {
  return pca_btf_parameter_count(frame(), components_);
}

void PcaBtf::measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const {
  const std::size_t images = frame().lights.size() * frame().views.size(),
                    p = light * frame().views.size() + view, d = frame().pixels() * 3,
                    o = (std::size_t(y) * std::size_t(frame().width) + std::size_t(x)) * 3;
  detail::mean_plus_components(mean_.data() + o, eigen_.data() + o, d, weights_.data() + p, images,
                               components_, 3, rgb);
}

void PcaBtf::measured_image(std::size_t light, std::size_t view, float* rgb) const {
  const std::size_t images = frame().lights.size() * frame().views.size(),
                    p = light * frame().views.size() + view, d = frame().pixels() * 3;
  detail::mean_plus_components(mean_.data(), eigen_.data(), d, weights_.data() + p, images,
                               components_, d, rgb);
}

Btf PcaBtf::decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
                   double tolerance) const {
  const auto li = detail::measured_indices(frame().lights, lights),
             vi = detail::measured_indices(frame().views, views);
  if (!li || !vi || width != frame().width || height != frame().height)
    return MeasuredImages::decode(lights, views, width, height, tolerance);
  Btf out(lights, views, width, height, frame().format);
  out.set_origin(frame().origin);
  const std::size_t images = frame().lights.size() * frame().views.size(), c = components_,
                    pairs = li->size() * vi->size();
  std::vector<float> w(pairs * c);
  for (std::size_t a = 0; a < li->size(); ++a)
    for (std::size_t b = 0; b < vi->size(); ++b) {
      const std::size_t p = (*li)[a] * frame().views.size() + (*vi)[b];
      for (std::size_t k = 0; k < c; ++k)
        w[(a * vi->size() + b) * c + k] = weights_[k * images + p];
    }
  const std::size_t d = frame().pixels() * 3;
  detail::affine_product(w.data(), eigen_.data(), mean_.data(), pairs, c, d, out.data().data(), d);
  return out;
}

std::vector<std::uint8_t> PcaBtf::payload() const {
  detail::ByteWriter w;
  detail::put_frame(w, frame());
  w.put<std::uint32_t>(std::uint32_t(components_));
  w.put<std::uint8_t>(std::uint8_t(encoding_));
  const std::size_t d = frame().pixels() * 3, images = frame().lights.size() * frame().views.size();
  detail::put_factors(w, mean_, d, encoding_, detail::image_layout(frame()));
  detail::put_factors(w, eigen_, d, encoding_, detail::image_layout(frame()));
  detail::put_factors(w, weights_, images, encoding_, detail::directions_layout(frame(), 1));
  return std::move(w.bytes);
}

std::vector<std::pair<std::string, std::string>> PcaBtf::details() const {
  const std::size_t images = frame().lights.size() * frame().views.size();
  return {
      {"eigen-images",
       fmt::format("{} of at most {}", components_, max_components(images, frame().pixels() * 3))},
      {"images",
       fmt::format("{} ({} lights x {} views), {} x {} pixels", images, frame().lights.size(),
                   frame().views.size(), frame().width, frame().height)},
      {"factor encoding", std::string(to_string(encoding_))},
      {"stored values", fmt::format("{} (mean image, eigen-images, weights)", parameter_count())},
  };
}

std::unique_ptr<Representation> fit_pca_btf(const Btf& tile, const FitOptions& s) {
  detail::refuse_clusters(s, kMethod);
  const std::size_t n = tile.image_count(), d = tile.image_floats();
  const std::size_t c = detail::components_setting(s, kMethod, 61, max_components(n, d),
                                                   fmt::format("this tile of {} images", n));
  const detail::ThreadScope threads(s.threads);
  detail::report(s, 0.0, "PCA of the images");
  detail::check_stop(s, kMethod);
  detail::PcaSettings ps;
  ps.seed = s.seed;
  const detail::Pca p = detail::principal_components(tile.data(), n, d, c, ps);
  detail::check_stop(s, kMethod);
  detail::report(s, 0.8, "weights of the stored eigen-images");
  // The stored mean and eigen-images first, then the weights fitted to them (least squares),
  // so that the stored weights make up for what the encoding rounded.
  std::vector<float> mean = detail::to_floats(p.mean), eigen = detail::to_floats(p.directions);
  detail::quantise_factors(mean, d, stored_encoding(s));
  detail::quantise_factors(eigen, d, stored_encoding(s));
  std::vector<float> weights = detail::transposed(
      detail::to_floats(detail::fit_coordinates(tile.data(), n, d, mean, eigen, c)), n, c);
  detail::quantise_factors(weights, n, stored_encoding(s));
  detail::report(s, 1.0, "done");
  return std::make_unique<PcaBtf>(ModelFrame::of(tile), c, stored_encoding(s), std::move(mean),
                                  std::move(eigen), std::move(weights));
}

std::unique_ptr<Representation> read_pca_btf(std::span<const std::uint8_t> payload,
                                             std::uint32_t flags, const std::string& name) {
  detail::ByteReader r(payload, "model file", name, "fit the model again");
  detail::expect_no_flags(r, flags);
  ModelFrame f = detail::get_frame(r);
  const std::size_t n = f.lights.size() * f.views.size(), d = f.pixels() * 3;
  if (n < 2) r.fail("a PCA BTF needs at least 2 images");
  const std::size_t c = detail::get_count(r, 1, max_components(n, d), "eigen-images");
  const FactorEncoding e = detail::get_encoding(r);
  detail::expect_bytes_for(r, double(c + 1) * double(d) + double(c) * double(n), e,
                           fmt::format("{} eigen-images of {} values", c, d));
  const detail::FactorLayout image = detail::image_layout(f),
                             pairs = detail::directions_layout(f, 1);
  auto mean = detail::get_factors_as(r, payload, 1, d, e, "mean image", image);
  auto eigen = detail::get_factors_as(r, payload, c, d, e, "eigen-images", image);
  auto weights = detail::get_factors_as(r, payload, c, n, e, "weights", pairs);
  detail::expect_end(r);
  return std::make_unique<PcaBtf>(std::move(f), c, e, std::move(mean), std::move(eigen),
                                  std::move(weights));
}

std::vector<FitOptions> pca_btf_ladder(const ModelFrame& frame) {
  const std::size_t images = frame.lights.size() * frame.views.size();
  if (images < 2) return {};
  std::vector<double> ratios;
  for (std::size_t c = 1; c <= max_components(images, frame.pixels() * 3); ++c)
    ratios.push_back(frame.data_values() / double(pca_btf_parameter_count(frame, c)));
  std::vector<FitOptions> out;
  for (std::size_t i : detail::ladder_choice(ratios)) {
    FitOptions s;
    s.components = i + 1;
    out.push_back(s);
  }
  return out;
}

}  // namespace btfgmm
