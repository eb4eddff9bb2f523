// PCA BTF's shader (render/shader.hpp; Koudelka, Magda, Belhumeur, Kriegman 2003): the mean
// image, the eigen-images and the weights of every measured pair as glsl/pca_btf.glsl reads
// them, with the measured directions' triangulations (methods/measured_images.hpp).
#include "btfgmm/methods/pca_btf.hpp"
#include "render/shader_tables.hpp"

namespace btfgmm::detail {

ShaderExport pca_btf_shader(const Representation& model) {
  const auto& pca = dynamic_cast<const PcaBtf&>(model);
  const ModelFrame& f = model.frame();
  const std::size_t pixels = f.pixels(), c = pca.components(),
                    pairs = f.lights.size() * f.views.size(), groups = (c + 3) / 4;
  ShaderBuilder b("pca-btf");
  add_common(b, f);
  add_direction_tables(b, f.lights, "LIGHT");
  add_direction_tables(b, f.views, "VIEW");
  const auto mean = pca.mean_image();
  const auto eigen = pca.eigen_images();
  const auto weights = pca.weights();  // c x pairs
  const std::size_t m0 = b.size();
  for (std::size_t p = 0; p < pixels; ++p) b.texel(mean[3 * p], mean[3 * p + 1], mean[3 * p + 2]);
  const std::size_t e0 = b.size();
  // Eigen-images up to a whole group of four (the missing ones zero).
  for (std::size_t k = 0; k < 4 * groups; ++k)
    for (std::size_t p = 0; p < pixels; ++p) {
      const float* e = k < c ? &eigen[k * pixels * 3 + 3 * p] : nullptr;
      b.texel(e ? e[0] : 0.0f, e ? e[1] : 0.0f, e ? e[2] : 0.0f);
    }
  const std::size_t w0 = b.size();
  auto weight = [&](std::size_t k, std::size_t p) { return k < c ? weights[k * pairs + p] : 0.0f; };
  for (std::size_t p = 0; p < pairs; ++p)
    for (std::size_t g = 0; g < groups; ++g)
      b.texel(weight(4 * g, p), weight(4 * g + 1, p), weight(4 * g + 2, p), weight(4 * g + 3, p));
  b.constant("BTF_VIEWS", f.views.size());
  b.constant("BTF_PCA_MEAN", m0);
  b.constant("BTF_PCA_EIGEN", e0);
  b.constant("BTF_PCA_WEIGHTS", w0);
  b.constant("BTF_PCA_GROUPS", groups);
  b.include("pca_btf.glsl");
  return b.finish(false);
}

}  // namespace btfgmm::detail
