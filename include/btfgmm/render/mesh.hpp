// Triangle meshes for rendering: the built-in sphere, cylinder, draped cloth and plane,
// Wavefront OBJ files, and per-vertex tangent frames from the texture coordinates
// (docs/RENDERING.md, "Conventions").
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "btfgmm/core/directions.hpp"

namespace btfgmm {

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

}  // namespace btfgmm
