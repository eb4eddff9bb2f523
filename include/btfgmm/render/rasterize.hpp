// The renderer's geometry pass (docs/RENDERING.md, "The geometry pass"): the mesh rasterised
// with a z-buffer (one sample per pixel, perspective-correct interpolation), and every
// visible pixel lit by the light set up as a SurfacePoint: its texture coordinate in tile
// pixels (the tile repeated, wrapped into the tile), and the light and view directions in
// the surface's local frame (x along the texture's columns, y along its rows, z the normal;
// the frames come from the mesh's UVs).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "btfgmm/render/camera.hpp"
#include "btfgmm/render/mesh.hpp"

namespace btfgmm {

// One visible, lit surface point.
struct SurfacePoint {
  float x = 0, y = 0;  // tile pixel coordinates, wrapped into [0, W) x [0, H)
  // Unit directions toward the light and the camera in the local frame (x along the tile's
  // columns, y along its rows, z the surface normal); light z > 0, view z >= 0.
  std::array<float, 3> light{0, 0, 1}, view{0, 0, 1};
  float irradiance = 1.0f;  // the light's scale at this point
};

struct SurfaceBuffer {
  int width = 0, height = 0;
  // What each pixel shows (row-major): 0 the background, 1 the object in shadow (the light
  // below its local horizon: black), 2 a lit surface point.
  std::vector<std::uint8_t> coverage;
  // The lit points, ordered in screen blocks of kBlockSize x kBlockSize pixels (an evaluator
  // handles kBlockSize^2 consecutive points together), and the pixel each one belongs to.
  std::vector<SurfacePoint> points;
  std::vector<std::uint32_t> pixel;
  // Where each screen block's points begin in `points`, then points.size().
  std::vector<std::uint32_t> block_start;
  double seconds = 0.0;                  // time taken
  static constexpr int kBlockSize = 16;  // kBlockSize^2 <= ModelEvaluator::kGroup
};

// Rasterises the mesh and sets up every lit pixel's SurfacePoint for a tile of
// tile_width x tile_height pixels. Throws Error(kArgument) for an empty mesh, a size < 1, a
// camera at its target, or a non-positive repeat.
SurfaceBuffer rasterize(const Mesh& mesh, const Camera& camera, const Light& light,
                        const RenderSettings& settings, int tile_width, int tile_height);

}  // namespace btfgmm
