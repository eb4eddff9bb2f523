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
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/render/data_evaluator.hpp"
#include "btfgmm/render/fast_interpolation.hpp"
#include "btfgmm/render/model_evaluator.hpp"

namespace btfgmm {

// ---- meshes -------------------------------------------------------------------------------

// A triangle mesh with texture coordinates and a tangent frame per vertex. Texture
// coordinates (u, v) are in "tile repeats per RenderSettings::repeat": the renderer maps
// (u, v) to the tile pixel (u, v) * repeat * tile width, so u runs along the tile's columns
// (x) and v along its rows (y).
struct Mesh {
  std::vector<Vec3> position;             // per vertex
  std::vector<Vec3> normal;               // per vertex, unit
  std::vector<std::array<double, 2>> uv;  // per vertex
  std::vector<Vec3> tangent;              // per vertex, unit, along dP/du, normal to `normal`
  std::vector<Vec3> bitangent;            // per vertex, unit, along dP/dv, normal to `normal`
  std::vector<std::array<std::uint32_t, 3>> triangles;

  // The radius of the smallest sphere around `center()` holding every vertex.
  double radius() const;
  // The centre of the vertices' bounding box.
  Vec3 center() const;
};

// Per-vertex tangent frames from the texture coordinates (Lengyel 2001: each triangle's
// dP/du and dP/dv, summed per vertex, made normal to the vertex normal). Vertex normals are
// computed from the faces (area-weighted) where `normal` is empty. Where the UVs give no
// direction (a degenerate UV triangle, a pole), any unit tangent normal to the normal is used.
void compute_tangent_frames(Mesh& mesh);

// The built-in meshes, each with u spanning 2 around and v spanning 1 along, so an integer
// repeat wraps seamlessly around the closed ones:
// A unit sphere around the origin, poles on the z axis; u = azimuth / pi, v from the south
// pole (0) to the north pole (1).
Mesh make_sphere(int slices = 192, int stacks = 96);
// A cylinder of radius 1 and height pi around the z axis, centred at the origin, without
// caps; u = azimuth / pi, v = (z + pi/2) / pi.
Mesh make_cylinder(int slices = 192, int stacks = 16);
// A square cloth (2 x 2 before draping) laid over a ball of radius 0.6 and hanging from it
// in folds, seen from both sides; u, v = (x + 1) / 2, (y + 1) / 2 of the flat cloth, lengths
// from the centre kept (the folds take up the circumference).
Mesh make_cloth(int resolution = 160);
// The square [-1, 1]^2 in z = 0, normal +z, u, v = (x + 1) / 2, (y + 1) / 2; two triangles
// per division.
Mesh make_plane(int divisions = 1);
// A Wavefront OBJ file (tinyobjloader): triangulated, vertices de-duplicated per
// (position, normal, uv) triple, normals from the faces where the file has none. Throws
// Error(kIo/kFormat) naming the file when it cannot be read, has no faces or no texture
// coordinates.
Mesh load_obj(const std::filesystem::path& path);
// "sphere", "cylinder", "cloth", "plane", or the path of an .obj file.
Mesh make_mesh(const std::string& name_or_path);

// ---- camera, light, settings --------------------------------------------------------------

struct Camera {
  Vec3 eye{0, 0, 4}, target{0, 0, 0}, up{0, 0, 1};
  double fov_deg = 30.0;  // vertical field of view

  // On a sphere around `target`, in the world direction `d` (theta in [0, 180]: from below
  // too), far enough that a sphere of `radius` around the target fills the view. Up is +z
  // (straight above or below, the limit of the neighbouring directions of the same phi).
  static Camera orbit(const Direction& d, double radius, const Vec3& target = {},
                      double fov_deg = 30.0);
};

struct Light {
  enum class Kind { kDirectional, kPoint };
  Kind kind = Kind::kDirectional;
  Vec3 direction{0, 0, 1};  // directional: the world direction toward the light
  Vec3 position{0, 0, 4};   // point: the light's position
  // Scale of the BTF values: directional, the irradiance (1 = as measured); point, the
  // irradiance at distance 1 (it falls off with the squared distance).
  double intensity = 1.0;

  static Light directional(const Direction& d, double intensity = 1.0);
  static Light point(const Vec3& position, double intensity);
};

struct RenderSettings {
  int width = 800, height = 800;
  double repeat = 4.0;    // tiles per unit of u (and of v, at the tile's width)
  double exposure = 0.0;  // stops: values are scaled by 2^exposure
  std::array<float, 3> background{40, 40, 40};  // 0-255 levels
  // ModelEvaluator: the largest colour error, in levels, that skipping components may cause
  // (0: evaluate every component at every point).
  double tolerance = 0.1;
};

// ---- 1. the geometry pass -----------------------------------------------------------------

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

// ---- 2. evaluators ------------------------------------------------------------------------

// EvaluationStats and ModelEvaluator: btfgmm/render/model_evaluator.hpp; DataEvaluator:
// btfgmm/render/data_evaluator.hpp; FastDirectionInterpolator:
// btfgmm/render/fast_interpolation.hpp (all included above).

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

// ---- the comparison of Fig. 3 -------------------------------------------------------------

// RMSE (levels, over the pixels on the object and the three channels, values clamped to
// 0-255 as displayed), PSNR = 20 log10(255 / RMSE), and the mean SSIM (Wang et al. 2004: an
// 11 x 11 Gaussian window, sigma 1.5, K1 = 0.01, K2 = 0.03, L = 255, no padding; per channel;
// averaged over the windows whose centre pixel is on the object).
struct RenderComparison {
  double rmse = 0.0, psnr = 0.0, ssim = 0.0;
  std::size_t pixels = 0;  // object pixels compared
};
RenderComparison compare_renderings(const Rendering& reference, const Rendering& test);

// data | model | difference x `difference_scale` side by side, with the metrics written in a
// strip under them. Values clamped to 0-255.
Image comparison_figure(const Rendering& data, const Rendering& model,
                        const RenderComparison& metrics, double difference_scale = 10.0);

// A line of text (upper-case letters, digits, . , : / | = % x + - and space) drawn with a
// 5 x 7 pixel font at `scale`, in levels `rgb`, into an image; for labels.
void draw_text(Image& image, int x, int y, const std::string& text, int scale,
               std::array<float, 3> rgb);

}  // namespace btfgmm
