// The renderer's evaluator of the measured data: the images interpolated in space and over the
// measured directions (docs/RENDERING.md).
#pragma once

#include <memory>
#include <span>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/render/model_evaluator.hpp"

namespace btfgmm {

struct SurfacePoint;  // render.hpp: a visible, lit surface point

// The measured data: bilinear between the four nearest pixels (the tile wraps), and over the
// measured directions with DirectionInterpolator's weights (3 lights x 3 views). It keeps a
// reference to `btf`, which must outlive it.
class DataEvaluator {
 public:
  explicit DataEvaluator(const Btf& btf);
  ~DataEvaluator();
  DataEvaluator(DataEvaluator&&) noexcept;
  DataEvaluator& operator=(DataEvaluator&&) noexcept;

  EvaluationStats evaluate(std::span<const SurfacePoint> points, std::span<float> rgb) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace btfgmm
