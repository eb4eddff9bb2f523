// The Gaussian mixture's shader (render/shader.hpp): the paper's Eq. (8)-(11) as
// glsl/mixture.glsl evaluates them, each component's parameters as four texels.
#include <cmath>

#include "btfgmm/methods/gaussian_mixture.hpp"
#include "model/conditional.hpp"
#include "render/shader_tables.hpp"

namespace btfgmm::detail {

// Each component m as glsl/mixture.glsl reads it: the means of the six inputs (x and y
// wrapped into the tile), c_n = -1 / (2 sigma^2_mn) (Eq. 10's term), the colour means, and
// Eq. (9)'s base log w_m - 1/2 sum_n log sigma^2_mn (log_weight_base).
ShaderExport mixture_shader(const Representation& model) {
  const BtfModel& m = dynamic_cast<const GaussianMixture&>(model).model();
  const ProductMixture& mix = m.mixture;
  const auto& u = m.scaling.unit;
  const Periods periods = model_periods(m);
  ShaderBuilder b("gm");
  add_common(b, model.frame());
  add_mean_brdf(b, model.frame(), m.mean_brdf);
  const std::size_t c0 = b.align(4);
  for (std::size_t k = 0; k < mix.size(); ++k) {
    const auto& mu = mix.mean[k];
    const auto& var = mix.var[k];
    auto c = [&](int n) { return float(-0.5 / var[std::size_t(n)]); };
    b.texel(float(wrap_into_period(mu[0], periods[0])), float(wrap_into_period(mu[1], periods[1])),
            float(mu[2]), float(mu[3]));
    b.texel(float(mu[4]), float(mu[5]), c(0), c(1));
    b.texel(c(2), c(3), c(4), c(5));
    b.texel(float(mu[6]), float(mu[7]), float(mu[8]), float(log_weight_base(mix, k)));
  }
  b.constant("BTF_ANGLE_UNIT", std::array<double, 4>{u[2], u[3], u[4], u[5]});
  b.constant("BTF_COLOUR_UNIT", std::array<double, 3>{u[6], u[7], u[8]});
  b.constant("BTF_COMPONENTS", c0);
  b.constant("BTF_M", mix.size());
  b.include("mixture.glsl");
  return b.finish(true);
}

}  // namespace btfgmm::detail
