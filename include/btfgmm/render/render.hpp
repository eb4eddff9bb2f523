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
// settings), rasterize.hpp (1. the geometry pass), model_evaluator.hpp and data_evaluator.hpp
// (2. the evaluators) and figure.hpp (the comparison of Fig. 3).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/render/camera.hpp"
#include "btfgmm/render/data_evaluator.hpp"
#include "btfgmm/render/figure.hpp"
#include "btfgmm/render/mesh.hpp"
#include "btfgmm/render/model_evaluator.hpp"
#include "btfgmm/render/rasterize.hpp"
#include "btfgmm/render/representation_evaluator.hpp"

namespace btfgmm {

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
Rendering render(const SurfaceBuffer& surface, const RepresentationEvaluator& model,
                 const RenderSettings& settings, SampleFormat format);
Rendering render(const SurfaceBuffer& surface, const DataEvaluator& data,
                 const RenderSettings& settings, SampleFormat format);

}  // namespace btfgmm
