// LPCA's shader (render/shader.hpp; Mueller, Meseth, Klein 2003): every texel's cluster and
// weights, every cluster's mean BRDF and components as glsl/lpca.glsl reads them.
#include "btfgmm/methods/lpca.hpp"
#include "render/shader_tables.hpp"

namespace btfgmm::detail {

ShaderExport lpca_shader(const Representation& model) {
  const auto& lpca = dynamic_cast<const Lpca&>(model);
  const ModelFrame& f = model.frame();
  const std::size_t pixels = f.pixels(), c = lpca.components(), k = lpca.clusters(),
                    pairs = f.lights.size() * f.views.size(), groups = (c + 3) / 4;
  ShaderBuilder b("lpca");
  add_common(b, f);
  add_measured_images(b, f);
  const std::size_t c0 = b.size();
  for (const std::uint32_t a : lpca.cluster_of()) b.texel(float(a));
  const auto weights = lpca.weights();  // c x pixels
  auto weight = [&](std::size_t j, std::size_t p) {
    return j < c ? weights[j * pixels + p] : 0.0f;
  };
  const std::size_t w0 = b.size();
  for (std::size_t p = 0; p < pixels; ++p)
    for (std::size_t g = 0; g < groups; ++g)
      b.texel(weight(4 * g, p), weight(4 * g + 1, p), weight(4 * g + 2, p), weight(4 * g + 3, p));
  // A cluster's mean BRDF and its components are "images" of the pairs.
  const std::size_t m0 = add_images(b, lpca.means(), k, pairs, k);
  const auto basis = lpca.basis();  // k*c x pairs*3
  const std::size_t b0 = b.size();
  for (std::size_t a = 0; a < k; ++a)
    add_images(b, basis.subspan(a * c * pairs * 3, c * pairs * 3), c, pairs, 4 * groups);
  b.constant("BTF_LPCA_CLUSTER", c0);
  b.constant("BTF_LPCA_WEIGHTS", w0);
  b.constant("BTF_LPCA_MEAN", m0);
  b.constant("BTF_LPCA_BASIS", b0);
  b.constant("BTF_LPCA_GROUPS", groups);
  b.include("lpca.glsl");
  return b.finish(false);
}

}  // namespace btfgmm::detail
