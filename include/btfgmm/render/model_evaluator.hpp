// The renderer's evaluator of the model, Eq. (8)-(11), for many surface points at once
// (docs/RENDERING.md, "The kernel"), and the statistics of an evaluation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>

#include "btfgmm/model/model.hpp"

namespace btfgmm {

struct SurfacePoint;  // render.hpp: a visible, lit surface point

// How much work an evaluation did (for the data: pixel reads, 36 a point).
struct EvaluationStats {
  std::uint64_t points = 0;
  std::uint64_t nominal = 0;    // points x M: what evaluating every component costs
  std::uint64_t evaluated = 0;  // component evaluations actually done
  double seconds = 0.0;
};

// The model, Eq. (8)-(11), for many points at once (docs/RENDERING.md, "The kernel"): per
// group of up to kGroup points, every component's log weight (Eq. 9) is bounded over the
// group's box of inputs; a component is skipped when the bound proves that all skipped
// components together change no point's colour by more than `tolerance` levels. The others
// are evaluated in float with a vectorised exp2: the colour equals predict()'s within
// tolerance + 1e-3 levels. Points close together (a screen block) make tight boxes.
class ModelEvaluator {
 public:
  explicit ModelEvaluator(const BtfModel& model, double tolerance = 0.1);
  ~ModelEvaluator();
  ModelEvaluator(ModelEvaluator&&) noexcept;
  ModelEvaluator& operator=(ModelEvaluator&&) noexcept;

  static constexpr std::size_t kGroup = 256;

  // RGB (levels of the data's scale, 3 floats a point) of every point. Points with x, y
  // outside the tile are wrapped (as predict() does). `groups`: where each group of points
  // begins, ascending, each group at most kGroup points (SurfaceBuffer::block_start); empty:
  // consecutive groups of kGroup.
  EvaluationStats evaluate(std::span<const SurfacePoint> points, std::span<float> rgb,
                           std::span<const std::uint32_t> groups = {}) const;
  std::size_t components() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace btfgmm
