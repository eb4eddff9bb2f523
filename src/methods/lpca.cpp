// LPCA (Mueller, Meseth & Klein 2003): a local PCA of the texels' apparent BRDFs.
#include "btfgmm/methods/lpca.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "btfgmm/core/error.hpp"
#include "methods/factors.hpp"
#include "methods/lpca_fit.hpp"
#include "methods/pca_methods.hpp"

namespace btfgmm {
namespace {

constexpr std::string_view kMethod = "lpca";
// Cluster indices are stored in 8 bits up to 256 clusters, in 16 bits beyond.
constexpr std::size_t kMaxClusters = 65535;

// Components: no more than a BRDF's values, nor than the texels less one (a single cluster's
// centred texels span no more).
std::size_t max_components(std::size_t texels, std::size_t dims) {
  return std::min(texels - 1, dims);
}

std::size_t max_clusters(std::size_t texels) {
  return std::min(texels, kMaxClusters);
}

std::string tile_text(const ModelFrame& f) {
  return fmt::format("this tile of {} texels ({} values each)", f.pixels(),
                     f.lights.size() * f.views.size() * 3);
}

std::size_t clusters_setting(const FitOptions& s, const ModelFrame& f) {
  if (s.clusters == 0) return std::min<std::size_t>(8, max_clusters(f.pixels()));
  if (s.clusters > max_clusters(f.pixels()))
    throw Error(Error::Kind::kArgument,
                fmt::format("`clusters` {}: lpca takes 1..{} for {}", s.clusters,
                            max_clusters(f.pixels()), tile_text(f)));
  return s.clusters;
}

int rounds_setting(const FitOptions& s) {
  if (s.iterations < 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("`iterations` {}: lpca takes 1 or more re-assignment rounds (0: the "
                            "default, 20)",
                            s.iterations));
  return s.iterations > 0 ? s.iterations : 20;
}

// The stored factors of a local PCA: means and components as `e`, then each texel's weights
// fitted (least squares) to its cluster's stored mean and components, so that they make up
// for what the encoding rounded.
struct StoredFactors {
  std::vector<float> means, basis, weights;
};

StoredFactors store(const detail::LocalPca& l, std::span<const float> x, FactorEncoding e) {
  const std::size_t k = l.clusters, c = l.components, dims = l.dims, texels = l.texels;
  StoredFactors f;
  for (const detail::Pca& p : l.pcas) {
    const auto m = detail::to_floats(p.mean), b = detail::to_floats(p.directions);
    f.means.insert(f.means.end(), m.begin(), m.end());
    f.basis.insert(f.basis.end(), b.begin(), b.end());
  }
  detail::quantise_factors(f.means, dims, e);
  detail::quantise_factors(f.basis, dims, e);
  f.weights.assign(c * texels, 0.0f);
  for (std::size_t a = 0; a < k; ++a) {
    std::vector<std::size_t> members;
    for (std::size_t t = 0; t < texels; ++t)
      if (l.cluster[t] == a) members.push_back(t);
    std::vector<float> rows(members.size() * dims);
    for (std::size_t i = 0; i < members.size(); ++i)
      std::copy_n(x.data() + members[i] * dims, dims, rows.data() + i * dims);
    const auto w = detail::fit_coordinates(rows, members.size(), dims,
                                           std::span(f.means).subspan(a * dims, dims),
                                           std::span(f.basis).subspan(a * c * dims, c * dims), c);
    for (std::size_t i = 0; i < members.size(); ++i)
      for (std::size_t j = 0; j < c; ++j) f.weights[j * texels + members[i]] = float(w[i * c + j]);
  }
  detail::quantise_factors(f.weights, texels, e);
  return f;
}

}  // namespace

Lpca::Lpca(ModelFrame frame, std::size_t clusters, std::size_t components, FactorEncoding encoding,
           std::vector<std::uint32_t> cluster_of, std::vector<float> means,
           std::vector<float> basis, std::vector<float> weights, LpcaRounds rounds)
    : MeasuredImages(std::move(frame)),
      clusters_(clusters),
      components_(components),
      encoding_(encoding),
      cluster_(std::move(cluster_of)),
      means_(std::move(means)),
      basis_(std::move(basis)),
      weights_(std::move(weights)),
      rounds_(rounds) {}

std::string_view Lpca::method() const {
  return kMethod;
}

std::string Lpca::size_text() const {
  return fmt::format("k = {}, c = {}", clusters_, components_);
}

std::uint64_t lpca_parameter_count(const ModelFrame& f, std::size_t k, std::size_t c) {
  const std::uint64_t dims = f.lights.size() * f.views.size() * 3;
  return k * (c + 1) * dims + f.pixels() * (c + 1);
}

std::uint64_t Lpca::parameter_count() const {
  return lpca_parameter_count(frame(), clusters_, components_);
}

void Lpca::measured_pixel(std::size_t light, std::size_t view, int x, int y, float* rgb) const {
  const std::size_t dims = frame().lights.size() * frame().views.size() * 3,
                    o = (light * frame().views.size() + view) * 3,
                    t = std::size_t(y) * std::size_t(frame().width) + std::size_t(x),
                    a = cluster_[t], c = components_;
  detail::mean_plus_components(means_.data() + a * dims + o, basis_.data() + a * c * dims + o, dims,
                               weights_.data() + t, frame().pixels(), c, 3, rgb);
}

// Each cluster's mean and components at this pair first (3 values each), then per texel its
// cluster's mean + Σ_k w_k component_k, as measured_pixel.
void Lpca::measured_image(std::size_t light, std::size_t view, float* rgb) const {
  const std::size_t dims = frame().lights.size() * frame().views.size() * 3,
                    o = (light * frame().views.size() + view) * 3, c = components_,
                    texels = frame().pixels(), stride = (c + 1) * 3;
  std::vector<float> slice(clusters_ * stride);
  for (std::size_t a = 0; a < clusters_; ++a) {
    std::copy_n(means_.data() + a * dims + o, 3, slice.data() + a * stride);
    for (std::size_t k = 0; k < c; ++k)
      std::copy_n(basis_.data() + (a * c + k) * dims + o, 3, slice.data() + a * stride + 3 + k * 3);
  }
  for (std::size_t t = 0; t < texels; ++t) {
    const float* s = slice.data() + cluster_[t] * stride;
    detail::mean_plus_components(s, s + 3, 3, weights_.data() + t, texels, c, 3, rgb + t * 3);
  }
}

Btf Lpca::decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
                 double tolerance) const {
  const auto li = detail::measured_indices(frame().lights, lights),
             vi = detail::measured_indices(frame().views, views);
  if (!li || !vi || width != frame().width || height != frame().height)
    return MeasuredImages::decode(lights, views, width, height, tolerance);
  Btf out(lights, views, width, height, frame().format);
  out.set_origin(frame().origin);
  const std::size_t dims = frame().lights.size() * frame().views.size() * 3, c = components_,
                    texels = frame().pixels();
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t a = 0; a < std::ptrdiff_t(clusters_); ++a) {
    std::vector<std::size_t> members;
    for (std::size_t t = 0; t < texels; ++t)
      if (cluster_[t] == std::size_t(a)) members.push_back(t);
    if (members.empty()) continue;
    std::vector<float> w(members.size() * c), brdfs(members.size() * dims);
    for (std::size_t i = 0; i < members.size(); ++i)
      for (std::size_t k = 0; k < c; ++k) w[i * c + k] = weights_[k * texels + members[i]];
    detail::affine_product(w.data(), basis_.data() + std::size_t(a) * c * dims,
                           means_.data() + std::size_t(a) * dims, members.size(), c, dims,
                           brdfs.data(), dims);
    for (std::size_t l = 0; l < li->size(); ++l)
      for (std::size_t v = 0; v < vi->size(); ++v) {
        const std::size_t o = ((*li)[l] * frame().views.size() + (*vi)[v]) * 3;
        float* image = out.image(l, v);
        for (std::size_t i = 0; i < members.size(); ++i)
          std::copy_n(brdfs.data() + i * dims + o, 3, image + members[i] * 3);
      }
  }
  return out;
}

std::vector<std::uint8_t> Lpca::payload() const {
  detail::ByteWriter w;
  detail::put_frame(w, frame());
  w.put<std::uint32_t>(std::uint32_t(clusters_));
  w.put<std::uint32_t>(std::uint32_t(components_));
  w.put<std::uint8_t>(std::uint8_t(encoding_));
  w.put<std::uint32_t>(rounds_.rounds);
  w.put<std::uint8_t>(rounds_.converged ? 1 : 0);
  for (std::uint32_t a : cluster_) {
    if (clusters_ <= 256)
      w.put<std::uint8_t>(std::uint8_t(a));
    else
      w.put<std::uint16_t>(std::uint16_t(a));
  }
  const std::size_t dims = frame().lights.size() * frame().views.size() * 3;
  const detail::FactorLayout brdf = detail::directions_layout(frame(), 3),
                             texels = {std::size_t(frame().width), 1};
  detail::put_factors(w, means_, dims, encoding_, brdf);
  detail::put_factors(w, basis_, dims, encoding_, brdf);
  detail::put_factors(w, weights_, frame().pixels(), encoding_, texels);
  return std::move(w.bytes);
}

std::vector<std::pair<std::string, std::string>> Lpca::details() const {
  std::vector<std::size_t> count(clusters_, 0);
  for (std::uint32_t a : cluster_) ++count[a];
  const auto [lo, hi] = std::minmax_element(count.begin(), count.end());
  return {
      {"clusters", fmt::format("{} ({} to {} texels each)", clusters_, *lo, *hi)},
      {"components per cluster", fmt::format("{}", components_)},
      {"local PCA rounds",
       fmt::format("{} ({})", rounds_.rounds,
                   rounds_.converged ? "converged: no texel moves" : "stopped at the limit")},
      {"factor encoding", std::string(to_string(encoding_))},
      {"stored values",
       fmt::format("{} (cluster means and components, per texel an index and weights)",
                   parameter_count())},
  };
}

std::unique_ptr<Representation> fit_lpca(const Btf& tile, const FitOptions& s) {
  const ModelFrame frame = ModelFrame::of(tile);
  const std::size_t texels = frame.pixels(), dims = tile.image_count() * 3;
  const std::size_t k = clusters_setting(s, frame);
  const std::size_t c =
      detail::components_setting(s, kMethod, 4, max_components(texels, dims), tile_text(frame));
  const int max_rounds = rounds_setting(s);
  const detail::ThreadScope threads(s.threads);
  const std::vector<float> x = detail::texel_brdfs(tile);
  const detail::LocalPca l = detail::fit_local_pca(x, texels, dims, k, c, max_rounds, s);
  detail::check_stop(s, kMethod);
  StoredFactors f = store(l, x, stored_encoding(s));
  detail::report(s, 1.0, "done");
  return std::make_unique<Lpca>(frame, k, c, stored_encoding(s), l.cluster, std::move(f.means),
                                std::move(f.basis), std::move(f.weights),
                                LpcaRounds{std::uint32_t(l.rounds), l.converged});
}

std::unique_ptr<Representation> read_lpca(std::span<const std::uint8_t> payload,
                                          std::uint32_t flags, const std::string& name) {
  detail::ByteReader r(payload, "model file", name, "fit the model again");
  detail::expect_no_flags(r, flags);
  ModelFrame f = detail::get_frame(r);
  const std::size_t texels = f.pixels(), dims = f.lights.size() * f.views.size() * 3;
  if (texels < 2) r.fail("an LPCA needs at least 2 texels");
  const std::size_t k = detail::get_count(r, 1, max_clusters(texels), "clusters");
  const std::size_t c = detail::get_count(r, 1, max_components(texels, dims), "components");
  const FactorEncoding e = detail::get_encoding(r);
  // The cluster indices take a byte each whatever the encoding.
  if (double(texels) > double(r.remaining()))
    r.fail(fmt::format("{} texels' cluster indices do not fit the file", texels));
  detail::expect_bytes_for(
      r, double(k) * double(c + 1) * double(dims) + double(texels) * double(c + 1), e,
      fmt::format("{} clusters of {} components", k, c));
  LpcaRounds rounds;
  rounds.rounds = r.get<std::uint32_t>("rounds");
  const auto converged = r.get<std::uint8_t>("converged");
  if (converged > 1) r.fail(fmt::format("converged flag {} is neither 0 nor 1", converged));
  rounds.converged = converged == 1;
  std::vector<std::uint32_t> cluster(texels);
  for (std::uint32_t& a : cluster) {
    a = k <= 256 ? r.get<std::uint8_t>("cluster index") : r.get<std::uint16_t>("cluster index");
    if (a >= k) r.fail(fmt::format("cluster index {} of {} clusters", a, k));
  }
  const detail::FactorLayout brdf = detail::directions_layout(f, 3),
                             grid = {std::size_t(f.width), 1};
  auto means = detail::get_factors_as(r, payload, k, dims, e, "cluster means", brdf);
  auto basis = detail::get_factors_as(r, payload, k * c, dims, e, "cluster components", brdf);
  auto weights = detail::get_factors_as(r, payload, c, texels, e, "texel weights", grid);
  detail::expect_end(r);
  return std::make_unique<Lpca>(std::move(f), k, c, e, std::move(cluster), std::move(means),
                                std::move(basis), std::move(weights), rounds);
}

std::vector<FitOptions> lpca_ladder(const ModelFrame& frame) {
  const std::size_t texels = frame.pixels(), dims = frame.lights.size() * frame.views.size() * 3;
  if (texels < 2) return {};
  std::vector<std::pair<std::size_t, std::size_t>> chain;  // (k, c) by growing size
  for (std::size_t k : {1, 2, 4, 8})
    if (k <= texels) chain.emplace_back(k, 1);
  const std::size_t k = chain.back().first;
  for (std::size_t c = 2; c <= max_components(texels, dims); ++c) chain.emplace_back(k, c);
  std::vector<double> ratios;
  for (const auto& [kk, c] : chain)
    ratios.push_back(frame.data_values() / double(lpca_parameter_count(frame, kk, c)));
  std::vector<FitOptions> out;
  for (std::size_t i : detail::ladder_choice(ratios)) {
    FitOptions s;
    s.clusters = chain[i].first;
    s.components = chain[i].second;
    out.push_back(s);
  }
  return out;
}

}  // namespace btfgmm
