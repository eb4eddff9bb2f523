// PCA BTF's shader (render/shader.hpp; Koudelka, Magda, Belhumeur, Kriegman 2003): the mean
// image, the eigen-images and the weights of every measured pair as glsl/pca_btf.glsl reads
// them.
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
  add_measured_images(b, f);
  const std::size_t m0 = add_images(b, pca.mean_image(), 1, pixels, 1);
  // The eigen-images up to a whole group of four (the missing ones zero).
  const std::size_t e0 = add_images(b, pca.eigen_images(), c, pixels, 4 * groups);
  const auto weights = pca.weights();  // c x pairs
  auto weight = [&](std::size_t k, std::size_t p) { return k < c ? weights[k * pairs + p] : 0.0f; };
  const std::size_t w0 = b.size();
  for (std::size_t p = 0; p < pairs; ++p)
    for (std::size_t g = 0; g < groups; ++g)
      b.texel(weight(4 * g, p), weight(4 * g + 1, p), weight(4 * g + 2, p), weight(4 * g + 3, p));
  b.constant("BTF_PCA_MEAN", m0);
  b.constant("BTF_PCA_EIGEN", e0);
  b.constant("BTF_PCA_WEIGHTS", w0);
  b.constant("BTF_PCA_GROUPS", groups);
  b.include("pca_btf.glsl");
  return b.finish(false);
}

}  // namespace btfgmm::detail
