// Rendering a BTF material on a 3D object, from the model or from the measured data, and the
// side-by-side comparison of the paper's Fig. 3 (data | model | 10x difference).
//
// The pipeline (docs/RENDERING.md):
//  1. rasterize(): the mesh is rasterised with a z-buffer (one sample per pixel, perspective-
//     correct interpolation). Every visible pixel lit by the light becomes a SurfacePoint:
//     its texture coordinate in tile pixels (the tile repeated, wrapped into the tile), and
//     the light and view directions in the surface's local frame (x along the texture's
//     columns, y along its rows, z the normal; the frames come from the mesh's UVs).
//  2. An evaluator gives the BTF value of every point: ModelEvaluator (the Gaussian mixture,
//     Eq. 8-11, with a fast kernel that equals predict() within a stated tolerance) or
//     DataEvaluator (the measured images, bilinear in space, interpolated over the measured
//     directions with DirectionInterpolator's barycentric weights).
//  3. compose(): the values times the light's irradiance and the exposure, on a background.
//
// Coordinates: the world is right-handed with z up. Directions given as (theta, phi) are
// world directions in the convention of directions.hpp: theta from +z, phi from +x toward +y.
// The built-in plane lies in z = 0 facing +z with its texture x along +x and y along +y, so a
// plane lit from (theta_i, phi_i) and seen from (theta_v, phi_v) shows the BTF at exactly
// those directions.
//
// This header includes the render layer's others: mesh.hpp (meshes), camera.hpp (camera, light,
// settings), rasterize.hpp (the geometry pass) and figure.hpp (the comparison of Fig. 3).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/render/camera.hpp"
#include "btfgmm/render/figure.hpp"
#include "btfgmm/render/mesh.hpp"
#include "btfgmm/render/rasterize.hpp"

namespace btfgmm {

// ---- 2. evaluators ------------------------------------------------------------------------

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

// DirectionInterpolator's weights, the same numbers, found through a grid over the disk
// instead of a scan over every triangle (for millions of look-ups).
class FastDirectionInterpolator {
 public:
  explicit FastDirectionInterpolator(const DirectionSet& set);
  DirectionInterpolator::Weights weights(const Vec3& v) const;
  // The same, trying first the triangle `hint` (set to the triangle used, or to a value past
  // the triangles where none was): for coherent queries such as neighbouring pixels.
  DirectionInterpolator::Weights weights(const Vec3& v, std::uint32_t& hint) const;

 private:
  DirectionInterpolator::Weights weights_at(double qx, double qy, std::uint32_t* hint) const;

  DirectionInterpolator slow_;  // used where the set has no triangle
  std::vector<std::array<double, 2>> points_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
  std::vector<std::array<std::uint32_t, 2>> hull_edges_;
  int grid_ = 0;
  std::vector<std::uint32_t> cell_start_, cell_triangles_;
};

// ---- 3. composing images ------------------------------------------------------------------

// A rendered image: RGB levels (0-255 scale, not clamped) and which pixels show the object.
struct Rendering {
  int width = 0, height = 0;
  std::vector<float> rgb;
  std::vector<std::uint8_t> object;  // 1 where the object covers the pixel
  EvaluationStats stats;
  double geometry_seconds = 0.0;
};

// Values times irradiance times 2^exposure on the background. HDR values (format kHdr) are
// taken as linear and encoded to sRGB levels.
Rendering compose(const SurfaceBuffer& surface, std::span<const float> point_rgb,
                  const RenderSettings& settings, SampleFormat format);

Rendering render(const SurfaceBuffer& surface, const ModelEvaluator& model,
                 const RenderSettings& settings, SampleFormat format);
Rendering render(const SurfaceBuffer& surface, const DataEvaluator& data,
                 const RenderSettings& settings, SampleFormat format);

}  // namespace btfgmm
