// PTM RF's shader (render/shader.hpp; Malzbender, Gelb, Wolters 2001): every view's six
// coefficient images as glsl/ptm_rf.glsl reads them.
#include "btfgmm/methods/ptm_rf.hpp"
#include "render/shader_tables.hpp"

namespace btfgmm::detail {

ShaderExport ptm_rf_shader(const Representation& model) {
  const auto& ptm = dynamic_cast<const PtmRf&>(model);
  const ModelFrame& f = model.frame();
  const std::size_t images = f.views.size() * PtmRf::kCoefficients;
  ShaderBuilder b("ptm-rf");
  add_common(b, f);
  add_measured_images(b, f);
  b.constant("BTF_PTM", add_images(b, ptm.coefficients(), images, f.pixels(), images));
  b.include("ptm_rf.glsl");
  return b.finish(false);
}

}  // namespace btfgmm::detail
