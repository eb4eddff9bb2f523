// PCA RF's shader (render/shader.hpp; Sattler, Sarlette, Klein 2003): every view's mean
// image, eigen-images and the weights of its lights as glsl/pca_rf.glsl reads them.
#include "btfgmm/methods/pca_rf.hpp"
#include "render/shader_tables.hpp"

namespace btfgmm::detail {

ShaderExport pca_rf_shader(const Representation& model) {
  const auto& pca = dynamic_cast<const PcaRf&>(model);
  const ModelFrame& f = model.frame();
  const std::size_t pixels = f.pixels(), c = pca.components(), ni = f.lights.size(),
                    nv = f.views.size(), groups = (c + 3) / 4;
  ShaderBuilder b("pca-rf");
  add_common(b, f);
  add_measured_images(b, f);
  const std::size_t m0 = add_images(b, pca.mean_images(), nv, pixels, nv);
  // Each view's eigen-images up to a whole group of four (the missing ones zero).
  const auto eigen = pca.eigen_images();  // nv*c x pixels*3
  const std::size_t e0 = b.size();
  for (std::size_t v = 0; v < nv; ++v)
    add_images(b, eigen.subspan(v * c * pixels * 3, c * pixels * 3), c, pixels, 4 * groups);
  const auto weights = pca.weights();  // nv*c x ni
  auto weight = [&](std::size_t v, std::size_t k, std::size_t l) {
    return k < c ? weights[(v * c + k) * ni + l] : 0.0f;
  };
  const std::size_t w0 = b.size();
  for (std::size_t v = 0; v < nv; ++v)
    for (std::size_t l = 0; l < ni; ++l)
      for (std::size_t g = 0; g < groups; ++g)
        b.texel(weight(v, 4 * g, l), weight(v, 4 * g + 1, l), weight(v, 4 * g + 2, l),
                weight(v, 4 * g + 3, l));
  b.constant("BTF_PCA_MEAN", m0);
  b.constant("BTF_PCA_EIGEN", e0);
  b.constant("BTF_PCA_WEIGHTS", w0);
  b.constant("BTF_PCA_GROUPS", groups);
  b.include("pca_rf.glsl");
  return b.finish(false);
}

}  // namespace btfgmm::detail
