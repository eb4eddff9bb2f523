// Any representation (methods/representation.hpp) at many surface points, for the renderer:
// the Gaussian mixture through ModelEvaluator's bounded kernel (docs/RENDERING.md), every
// other method through its own predict().
#pragma once

#include <cstdint>
#include <memory>
#include <span>

#include "btfgmm/methods/representation.hpp"
#include "btfgmm/render/model_evaluator.hpp"

namespace btfgmm {

struct SurfacePoint;

class RepresentationEvaluator {
 public:
  // `tolerance` as ModelEvaluator's (levels); methods that are exact ignore it.
  RepresentationEvaluator(std::shared_ptr<const Representation> model, double tolerance);
  ~RepresentationEvaluator();
  RepresentationEvaluator(RepresentationEvaluator&&) noexcept;
  RepresentationEvaluator& operator=(RepresentationEvaluator&&) noexcept;

  // RGB (3 floats a point) of every point; `groups` as ModelEvaluator::evaluate's.
  EvaluationStats evaluate(std::span<const SurfacePoint> points, std::span<float> rgb,
                           std::span<const std::uint32_t> groups = {}) const;
  const Representation& model() const { return *model_; }

 private:
  std::shared_ptr<const Representation> model_;
  std::unique_ptr<ModelEvaluator> mixture_;  // set for a Gaussian mixture
};

}  // namespace btfgmm
