// PLM RF's shader (render/shader.hpp; Filip, Haindl 2004): every view's lobe parameters as
// images and every image's polynomial as glsl/plm_rf.glsl reads them.
#include "btfgmm/methods/plm_rf.hpp"
#include "render/shader_tables.hpp"

namespace btfgmm::detail {

ShaderExport plm_rf_shader(const Representation& model) {
  const auto& plm = dynamic_cast<const PlmRf&>(model);
  const ModelFrame& f = model.frame();
  const std::size_t nv = f.views.size(), lobes = nv * PlmRf::kLobeParameters,
                    rows = nv * (plm.degree() + 1);
  ShaderBuilder b("plm-rf");
  add_common(b, f);
  add_measured_images(b, f);
  b.constant("BTF_PLM_LOBES", add_images(b, plm.lobes(), lobes, f.pixels(), lobes));
  // A row of coefficients (every light's a_j of one view) is an "image" of the lights.
  b.constant("BTF_PLM_POLYNOMIALS", add_images(b, plm.polynomials(), rows, f.lights.size(), rows));
  b.constant("BTF_PLM_DEGREE", plm.degree());
  b.float_constant("BTF_PLM_SCALE", plm.scale());
  b.include("plm_rf.glsl");
  return b.finish(false);
}

}  // namespace btfgmm::detail
