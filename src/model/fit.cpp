// fit_model: mean BRDF, samples, initialisation, EM.
#include "btfgmm/model/fit.hpp"

#include <chrono>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {

BtfModel fit_model(const Btf& btf, const FitConfig& config, const EmCallback& progress,
                   const FitState* resume, const EmStateCallback& after_iteration,
                   FitState* state) {
  const auto t0 = std::chrono::steady_clock::now();
  const SampleSet samples = make_sample_set(btf);
  ProductMixture mix =
      resume ? resume->mixture : initial_mixture(samples, config.components, config.seed);
  const EmResult em = fit_em(samples, mix, config.em, progress, resume ? &resume->result : nullptr,
                             after_iteration);
  if (state) *state = FitState{mix, em};
  if (em.interrupted) return BtfModel{};
  BtfModel m;
  m.lights = btf.lights();
  m.views = btf.views();
  m.width = btf.width();
  m.height = btf.height();
  m.origin = btf.origin();
  m.format = btf.format();
  m.scaling = samples.scaling;
  m.mean_brdf = samples.mean_brdf;
  m.mixture = std::move(mix);
  m.settings.components = std::uint32_t(config.components);
  m.settings.max_iterations = std::uint32_t(config.em.max_iterations);
  m.settings.epsilon = config.em.epsilon;
  m.settings.seed = config.seed;
  m.settings.iterations = std::uint32_t(em.iterations);
  m.settings.dropped = std::uint32_t(em.dropped);
  m.settings.log_likelihood = em.final_log_likelihood;
  m.settings.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

}  // namespace btfgmm
