// Meshes for rendering: the built-in sphere, cylinder, draped cloth and plane, Wavefront OBJ
// files (tinyobjloader), and per-vertex tangent frames from the texture coordinates.
#include "btfgmm/render/mesh.hpp"

#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <numbers>
#include <tuple>
#include <utility>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"

#include "core/vec3_ops.hpp"

namespace btfgmm {
namespace {

constexpr double kPi = std::numbers::pi;

using detail::operator+;
using detail::operator-;
using detail::operator*;
using detail::any_perpendicular;
using detail::cross;
using detail::dot;
using detail::length;

// A grid of (nu + 1) x (nv + 1) vertices from a parametric surface, two triangles per cell,
// counter-clockwise seen from the side the normal points to when (u, v) is right-handed.
// The vertices are computed in parallel, rows handed out as threads come free (`at` must be a
// pure function: the cloth's takes a few hundred operations a vertex).
template <class F>
Mesh grid_mesh(int nu, int nv, F&& at) {
  Mesh m;
  const std::size_t row = std::size_t(nu) + 1, count = row * (std::size_t(nv) + 1);
  m.position.resize(count);
  m.normal.resize(count);
  m.uv.resize(count);
#pragma omp parallel for schedule(dynamic, 8)
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      const std::size_t k = std::size_t(j) * row + std::size_t(i);
      at(double(i) / nu, double(j) / nv, m.position[k], m.normal[k], m.uv[k]);
    }
  auto id = [&](int i, int j) { return std::uint32_t(j * (nu + 1) + i); };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const std::uint32_t a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      // Triangles that collapse to a segment (at a pole) are left out.
      const auto keep = [&](std::uint32_t p, std::uint32_t q, std::uint32_t r) {
        return length(cross(m.position[q] - m.position[p], m.position[r] - m.position[p])) > 1e-14;
      };
      if (keep(a, b, c)) m.triangles.push_back({a, b, c});
      if (keep(a, c, d)) m.triangles.push_back({a, c, d});
    }
  return m;
}

// The unit vector along v (v itself when it has no length).
Vec3 direction_of(const Vec3& v) {
  const double l = length(v);
  return l > 0 ? v * (1.0 / l) : v;
}

// The cell of a point in a grid of cells `size` wide, and a vertex listed by its cell.
using CellKey = std::array<long long, 3>;
using CellEntry = std::pair<CellKey, std::uint32_t>;
CellKey cell_of(const Vec3& p, double size) {
  return {std::llround(std::floor(p.x / size)), std::llround(std::floor(p.y / size)),
          std::llround(std::floor(p.z / size))};
}

// Groups of vertices at one position (within 1e-9 of the mesh's extent; the sphere's seam
// vertices differ by rounding), each listed once, in vertex order; a group's vertices in the
// order of their cells of that size (x, then y, then z), then of their indices.
//
// The candidates come from the vertices sorted by cells 64 times as large: a vertex takes
// those of its own cell, beside it in that order, and looks a neighbouring cell up only along
// an axis where it lies near a face (rarely), not 27 cells in a map.
std::vector<std::vector<std::uint32_t>> coincident_vertices(const Mesh& m) {
  double extent = 0.0;
  for (const Vec3& p : m.position)
    extent = std::max({extent, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  const double cell = std::max(extent, 1e-300) * 1e-9, coarse = 64.0 * cell;
  const std::size_t n = m.position.size();
  std::vector<CellEntry> sorted(n);
  for (std::size_t i = 0; i < n; ++i)
    sorted[i] = {cell_of(m.position[i], coarse), std::uint32_t(i)};
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::uint32_t> rank(n);
  for (std::size_t r = 0; r < n; ++r) rank[sorted[r].second] = std::uint32_t(r);
  std::vector<std::vector<std::uint32_t>> groups;
  std::vector<std::uint8_t> grouped(n, 0);
  std::vector<CellEntry> g;
  for (std::size_t i = 0; i < n; ++i) {
    if (grouped[i]) continue;
    g.clear();
    const Vec3& p = m.position[i];
    const CellKey k = sorted[rank[i]].first, fine = cell_of(p, cell);
    const auto take = [&](std::vector<CellEntry>::const_iterator it, const CellKey& key) {
      for (; it != sorted.end() && it->first == key; ++it) {
        const std::uint32_t j = it->second;
        const CellKey fj = cell_of(m.position[j], cell);
        const bool adjacent = std::abs(fj[0] - fine[0]) <= 1 && std::abs(fj[1] - fine[1]) <= 1 &&
                              std::abs(fj[2] - fine[2]) <= 1;
        if (!grouped[j] && adjacent && length(m.position[j] - p) <= cell) g.push_back({fj, j});
      }
    };
    // The own cell from its first entry; a neighbour along an axis only where p lies within
    // 0.03 of a cell of its face (a vertex within `cell` lies within 1/64, with room for
    // rounding).
    auto first = sorted.begin() + std::ptrdiff_t(rank[i]);
    while (first != sorted.begin() && std::prev(first)->first == k) --first;
    const double q[3] = {p.x / coarse, p.y / coarse, p.z / coarse};
    std::array<std::array<long long, 2>, 3> range{};
    for (std::size_t a = 0; a < 3; ++a) {
      const double f = q[a] - std::floor(q[a]);
      range[a] = {f < 0.03 ? -1 : 0, f > 0.97 ? 1 : 0};
    }
    for (long long a = range[0][0]; a <= range[0][1]; ++a)
      for (long long b = range[1][0]; b <= range[1][1]; ++b)
        for (long long c = range[2][0]; c <= range[2][1]; ++c) {
          const CellKey nk{k[0] + a, k[1] + b, k[2] + c};
          take(nk == k ? first : std::lower_bound(sorted.begin(), sorted.end(), CellEntry{nk, 0u}),
               nk);
        }
    for (const CellEntry& e : g) grouped[e.second] = 1;
    if (g.size() < 2) continue;
    std::sort(g.begin(), g.end());
    std::vector<std::uint32_t> group;
    for (const CellEntry& e : g) group.push_back(e.second);
    groups.push_back(std::move(group));
  }
  return groups;
}

// Tangents shared across seams of the texture coordinates where the texture continues (the
// sphere's and the cylinder's u = 0 / u = 2 meridian, an OBJ's UV seams): each vertex of a
// group at one position adds the summed dP/du and dP/dv of the others whose normal and both
// directions agree with its own (within 60 degrees: a seam that translates the UVs), so that
// the frame, and with it the light and view directions handed to the BTF, does not jump
// across the seam (one-sided sums differ by the angle of a slice, 5.6 degrees on a sphere of 64
// slices). Mirrored or rotated UV islands keep their own frames.
void share_seam_tangents(const Mesh& m, std::vector<Vec3>& tu, std::vector<Vec3>& tv) {
  for (const auto& group : coincident_vertices(m)) {
    const std::size_t n = group.size();
    std::vector<Vec3> su(n), sv(n), dn(n), du(n), dv(n);
    for (std::size_t a = 0; a < n; ++a) {
      dn[a] = direction_of(m.normal[group[a]]);
      du[a] = direction_of(tu[group[a]]);
      dv[a] = direction_of(tv[group[a]]);
    }
    for (std::size_t a = 0; a < n; ++a)
      for (std::size_t b = 0; b < n; ++b) {
        const bool agree =
            dot(dn[a], dn[b]) > 0.5 && dot(du[a], du[b]) > 0.5 && dot(dv[a], dv[b]) > 0.5;
        if (a == b || agree) {
          su[a] = su[a] + tu[group[b]];
          sv[a] = sv[a] + tv[group[b]];
        }
      }
    for (std::size_t a = 0; a < group.size(); ++a) {
      tu[group[a]] = su[a];
      tv[group[a]] = sv[a];
    }
  }
}

void check_resolution(int n, int lo, const char* what) {
  if (n < lo || n > 4096)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} resolution {} is out of range; give {}..4096", what, n, lo));
}

}  // namespace

double Mesh::radius() const {
  const Vec3 c = center();
  double r = 0.0;
  for (const Vec3& p : position) r = std::max(r, length(p - c));
  return r;
}

Vec3 Mesh::center() const {
  if (position.empty()) return {};
  Vec3 lo = position[0], hi = position[0];
  for (const Vec3& p : position) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return (lo + hi) * 0.5;
}

void compute_tangent_frames(Mesh& m) {
  const std::size_t n = m.position.size();
  if (m.uv.size() != n || (!m.normal.empty() && m.normal.size() != n))
    throw Error(Error::Kind::kArgument,
                "mesh: positions, normals and texture coordinates must have one entry a vertex");
  for (const auto& t : m.triangles)
    for (std::uint32_t i : t)
      if (i >= n)
        throw Error(Error::Kind::kFormat,
                    fmt::format("mesh: a triangle names vertex {} of {}", i + 1, n));
  if (m.normal.empty()) {
    m.normal.assign(n, Vec3{});
    for (const auto& t : m.triangles) {
      // Area-weighted: the cross product's length is twice the area.
      const Vec3 f =
          cross(m.position[t[1]] - m.position[t[0]], m.position[t[2]] - m.position[t[0]]);
      for (std::uint32_t i : t) m.normal[i] = m.normal[i] + f;
    }
  }
  std::vector<Vec3> tu(n), tv(n);
  for (const auto& t : m.triangles) {
    const Vec3 e1 = m.position[t[1]] - m.position[t[0]], e2 = m.position[t[2]] - m.position[t[0]];
    const double du1 = m.uv[t[1]][0] - m.uv[t[0]][0], dv1 = m.uv[t[1]][1] - m.uv[t[0]][1];
    const double du2 = m.uv[t[2]][0] - m.uv[t[0]][0], dv2 = m.uv[t[2]][1] - m.uv[t[0]][1];
    const double det = du1 * dv2 - du2 * dv1;
    const double area = 0.5 * length(cross(e1, e2));
    if (!(std::abs(det) > 1e-300) || !(area > 0.0)) continue;
    // dP/du and dP/dv of the triangle (Lengyel 2001), each weighted by the triangle's area.
    const Vec3 pu = (e1 * dv2 - e2 * dv1) * (1.0 / det), pv = (e2 * du1 - e1 * du2) * (1.0 / det);
    const double lu = length(pu), lv = length(pv);
    for (std::uint32_t i : t) {
      if (lu > 0) tu[i] = tu[i] + pu * (area / lu);
      if (lv > 0) tv[i] = tv[i] + pv * (area / lv);
    }
  }
  share_seam_tangents(m, tu, tv);
  m.tangent.resize(n);
  m.bitangent.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 nn = m.normal[i];
    const double ln = length(nn);
    nn = ln > 0 ? nn * (1.0 / ln) : Vec3{0, 0, 1};
    m.normal[i] = nn;
    Vec3 t = tu[i] - nn * dot(tu[i], nn), b = tv[i] - nn * dot(tv[i], nn);
    const double lt = length(t), lb = length(b);
    if (lt > 1e-12 * (length(tu[i]) + 1e-300)) {
      t = t * (1.0 / lt);
    } else if (lb > 1e-12 * (length(tv[i]) + 1e-300)) {
      t = cross(b * (1.0 / lb), nn);  // right-handed with the given v
    } else {
      t = any_perpendicular(nn);
    }
    b = lb > 1e-12 * (length(tv[i]) + 1e-300) ? b * (1.0 / lb) : cross(nn, t);
    m.tangent[i] = t;
    m.bitangent[i] = b;
  }
}

Mesh make_sphere(int slices, int stacks) {
  check_resolution(slices, 3, "sphere slices");
  check_resolution(stacks, 2, "sphere stacks");
  Mesh m = grid_mesh(slices, stacks, [](double s, double t, Vec3& p, Vec3& n, auto& uv) {
    const double az = 2.0 * kPi * s, polar = kPi * t;  // polar angle from the south pole
    const double r = std::sin(polar);
    p = {r * std::cos(az), r * std::sin(az), -std::cos(polar)};
    n = p;
    uv = {2.0 * s, t};
  });
  compute_tangent_frames(m);
  return m;
}

Mesh make_cylinder(int slices, int stacks) {
  check_resolution(slices, 3, "cylinder slices");
  check_resolution(stacks, 1, "cylinder stacks");
  Mesh m = grid_mesh(slices, stacks, [](double s, double t, Vec3& p, Vec3& n, auto& uv) {
    const double az = 2.0 * kPi * s;
    p = {std::cos(az), std::sin(az), kPi * (t - 0.5)};
    n = {std::cos(az), std::sin(az), 0.0};
    uv = {2.0 * s, t};
  });
  compute_tangent_frames(m);
  return m;
}

Mesh make_cloth(int resolution) {
  check_resolution(resolution, 2, "cloth");
  // A square cloth laid over a ball of radius R: a flat point at distance rho from the
  // centre (azimuth a) lies on the ball up to the contact circle rho_c (arc length kept),
  // then hangs in the vertical plane of its azimuth, its slope turning from the ball's
  // tangent toward the vertical; folds (a radial wave in the azimuth) deepen toward the hem.
  constexpr double R = 0.6, theta_c = 1.05, rho_c = R * theta_c, steep = 1.4, turn = 0.22;
  const auto at = [&](double x, double y) -> Vec3 {
    const double rho = std::hypot(x, y), a = std::atan2(y, x);
    const double ca = std::cos(a), sa = std::sin(a);
    if (rho <= rho_c) {
      const double th = rho / R;
      return {R * std::sin(th) * ca, R * std::sin(th) * sa, R * std::cos(th)};
    }
    // The hanging part: arc length s past the contact circle, integrated in small steps.
    const double s = rho - rho_c;
    const int steps = 48;
    double h = R * std::sin(theta_c), z = R * std::cos(theta_c);
    for (int i = 0; i < steps; ++i) {
      const double si = (i + 0.5) * s / steps;
      const double psi = steep + (theta_c - steep) * std::exp(-si / turn);  // below horizontal
      h += std::cos(psi) * s / steps;
      z -= std::sin(psi) * s / steps;
    }
    h += 0.09 * (1.0 - std::exp(-s / 0.2)) * std::sin(9.0 * a + 0.7);
    return {h * ca, h * sa, z};
  };
  Mesh m = grid_mesh(resolution, resolution, [&](double s, double t, Vec3& p, Vec3& n, auto& uv) {
    const double x = 2.0 * s - 1.0, y = 2.0 * t - 1.0, e = 1e-4;
    p = at(x, y);
    const Vec3 du = at(x + e, y) - at(x - e, y), dv = at(x, y + e) - at(x, y - e);
    n = cross(du, dv);
    const double ln = length(n);
    n = ln > 0 ? n * (1.0 / ln) : Vec3{0, 0, 1};
    uv = {s, t};
  });
  compute_tangent_frames(m);
  return m;
}

Mesh make_plane(int divisions) {
  check_resolution(divisions, 1, "plane divisions");
  Mesh m = grid_mesh(divisions, divisions, [](double s, double t, Vec3& p, Vec3& n, auto& uv) {
    p = {2.0 * s - 1.0, 2.0 * t - 1.0, 0.0};
    n = {0, 0, 1};
    uv = {s, t};
  });
  compute_tangent_frames(m);
  return m;
}

namespace {

// Reads a Wavefront OBJ file, triangulated; throws Error naming the file where it cannot.
void read_obj(const std::filesystem::path& path, tinyobj::ObjReader& reader) {
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  config.mtl_search_path = path.parent_path().string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(Error::Kind::kIo,
                fmt::format("mesh {} does not exist or is not a file; give a Wavefront .obj file "
                            "or one of sphere, cylinder, cloth, plane",
                            path.string()));
  if (!reader.ParseFromFile(path.string(), config) || !reader.Valid())
    throw Error(Error::Kind::kFormat,
                fmt::format("mesh {} is not a readable Wavefront OBJ file: {}", path.string(),
                            reader.Error()));
}

// A mesh being built from an OBJ file: its vertices de-duplicated per (position, normal, uv)
// index triple, and the OBJ position index of each vertex.
struct ObjMesh {
  Mesh mesh;
  std::map<std::tuple<int, int, int>, std::uint32_t> index;
  std::vector<int> position_of;
  bool all_normals = true;
};

// Checks that the corner i of face f of `shape` has texture coordinates and that its
// indices exist.
void check_corner(const std::filesystem::path& path, const tinyobj::attrib_t& at,
                  const tinyobj::shape_t& shape, std::size_t f, const tinyobj::index_t& i) {
  if (i.texcoord_index < 0)
    throw Error(Error::Kind::kFormat,
                fmt::format("mesh {}: face {} of '{}' has no texture coordinates; the "
                            "renderer maps the BTF by them: export the mesh with UVs "
                            "(vt lines and f v/vt/vn)",
                            path.string(), f + 1, shape.name));
  if (i.vertex_index < 0 || std::size_t(3 * i.vertex_index + 2) >= at.vertices.size() ||
      std::size_t(2 * i.texcoord_index + 1) >= at.texcoords.size() ||
      (i.normal_index >= 0 && std::size_t(3 * i.normal_index + 2) >= at.normals.size()))
    throw Error(Error::Kind::kFormat,
                fmt::format("mesh {}: face {} of '{}' refers to a missing vertex", path.string(),
                            f + 1, shape.name));
}

// The mesh vertex of the corner i, added at its first use.
std::uint32_t corner_vertex(const tinyobj::attrib_t& at, const tinyobj::index_t& i, ObjMesh& obj) {
  Mesh& m = obj.mesh;
  obj.all_normals = obj.all_normals && i.normal_index >= 0;
  const auto key = std::make_tuple(i.vertex_index, i.normal_index, i.texcoord_index);
  auto it = obj.index.find(key);
  if (it == obj.index.end()) {
    const auto v = std::size_t(i.vertex_index), t = std::size_t(i.texcoord_index);
    m.position.push_back({at.vertices[3 * v], at.vertices[3 * v + 1], at.vertices[3 * v + 2]});
    if (i.normal_index >= 0) {
      const auto nn = std::size_t(i.normal_index);
      m.normal.push_back({at.normals[3 * nn], at.normals[3 * nn + 1], at.normals[3 * nn + 2]});
    } else {
      m.normal.push_back({});
    }
    m.uv.push_back({at.texcoords[2 * t], at.texcoords[2 * t + 1]});
    obj.position_of.push_back(i.vertex_index);
    it = obj.index.emplace(key, std::uint32_t(m.position.size() - 1)).first;
  }
  return it->second;
}

// The triangles of one shape of the file.
void add_shape(const std::filesystem::path& path, const tinyobj::attrib_t& at,
               const tinyobj::shape_t& shape, ObjMesh& obj) {
  const auto& idx = shape.mesh.indices;
  std::size_t k = 0;
  for (std::size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
    const std::size_t count = shape.mesh.num_face_vertices[f];
    if (count != 3) {  // triangulate = true leaves only triangles; skip points and lines
      k += count;
      continue;
    }
    std::array<std::uint32_t, 3> tri{};
    for (std::size_t c = 0; c < 3; ++c, ++k) {
      check_corner(path, at, shape, f, idx[k]);
      tri[c] = corner_vertex(at, idx[k], obj);
    }
    obj.mesh.triangles.push_back(tri);
  }
}

// Normals from the faces, shared by every vertex at one OBJ position (so that seams of the
// texture coordinates do not crease the shading).
void normals_from_faces(ObjMesh& obj, std::size_t positions) {
  Mesh& m = obj.mesh;
  std::vector<Vec3> acc(positions);
  for (const auto& t : m.triangles) {
    const Vec3 f = cross(m.position[t[1]] - m.position[t[0]], m.position[t[2]] - m.position[t[0]]);
    for (std::uint32_t i : t)
      acc[std::size_t(obj.position_of[i])] = acc[std::size_t(obj.position_of[i])] + f;
  }
  for (std::size_t i = 0; i < m.position.size(); ++i)
    m.normal[i] = acc[std::size_t(obj.position_of[i])];
}

}  // namespace

Mesh load_obj(const std::filesystem::path& path) {
  tinyobj::ObjReader reader;
  read_obj(path, reader);
  const tinyobj::attrib_t& at = reader.GetAttrib();
  ObjMesh obj;
  for (const auto& shape : reader.GetShapes()) add_shape(path, at, shape, obj);
  if (obj.mesh.triangles.empty())
    throw Error(Error::Kind::kFormat,
                fmt::format("mesh {} has no faces; give an OBJ file with triangles or polygons",
                            path.string()));
  if (!obj.all_normals) normals_from_faces(obj, at.vertices.size() / 3);
  compute_tangent_frames(obj.mesh);
  return std::move(obj.mesh);
}

Mesh make_mesh(const std::string& name) {
  const std::string l = lower(name);
  if (l == "sphere") return make_sphere();
  if (l == "cylinder") return make_cylinder();
  if (l == "cloth") return make_cloth();
  if (l == "plane") return make_plane();
  std::error_code ec;
  if (std::filesystem::path(name).extension().string().size() > 0 ||
      std::filesystem::exists(name, ec))
    return load_obj(name);
  throw Error(
      Error::Kind::kArgument,
      fmt::format("mesh '{}' is unknown; give sphere, cylinder, cloth, plane or the path of "
                  "a Wavefront .obj file",
                  name));
}

}  // namespace btfgmm
