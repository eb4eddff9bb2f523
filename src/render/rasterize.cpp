// The renderer's geometry pass (docs/RENDERING.md, "The geometry pass"): the mesh projected
// with a pinhole camera, its triangles binned into bands of rows, and each band rasterised
// into a visibility buffer (triangle and perspective-correct barycentric coordinates per
// pixel), set up (set_up.cpp) and its lit points stored in screen blocks.
#include "btfgmm/render/rasterize.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"

#include "core/vec3_ops.hpp"
#include "render/set_up.hpp"

namespace btfgmm {
namespace {

constexpr double kPi = std::numbers::pi;

using detail::operator-;
using detail::any_perpendicular;
using detail::cross;
using detail::dot;
using detail::length;
using detail::normalized;
using detail::SetUpScene;

// Rows a band: each band is one row of screen blocks, rasterised and set up by one thread.
constexpr int kBand = 16;
constexpr int B = SurfaceBuffer::kBlockSize;
static_assert(B == kBand, "a band is one row of screen blocks");

// A vertex in camera space and on the screen.
struct Projected {
  double sx = 0, sy = 0;  // screen position, pixels (y down)
  double depth = 0;       // distance along the view axis
};

// The pinhole camera: its frame (right, up, forward), focal length in pixels, near plane.
struct View {
  int width = 0, height = 0;
  Vec3 eye, right, up, forward;
  double focal = 0, near = 0;
};

void check_arguments(const Mesh& mesh, const RenderSettings& settings, int tile_width,
                     int tile_height) {
  const int W = settings.width, H = settings.height;
  if (W < 1 || H < 1 || W > 16384 || H > 16384)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("render size {}x{} is out of range; give 1..16384 pixels a side", W, H));
  if (tile_width < 1 || tile_height < 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("render: the tile {}x{} is empty", tile_width, tile_height));
  if (!(settings.repeat > 0.0) || !std::isfinite(settings.repeat))
    throw Error(Error::Kind::kArgument,
                fmt::format("`repeat` {} must be a positive number of tiles", settings.repeat));
  if (mesh.triangles.empty() || mesh.position.empty())
    throw Error(Error::Kind::kArgument, "render: the mesh has no triangles");
}

// The mesh with its tangent frames: `mesh` itself, or its copy `framed` with the frames
// computed where it has none.
const Mesh& with_tangent_frames(const Mesh& mesh, Mesh& framed) {
  const Mesh* m = &mesh;
  if (mesh.tangent.size() != mesh.position.size() ||
      mesh.bitangent.size() != mesh.position.size() || mesh.normal.size() != mesh.position.size()) {
    framed = mesh;
    compute_tangent_frames(framed);
    m = &framed;
  }
  for (const auto& t : m->triangles)
    for (std::uint32_t i : t)
      if (i >= m->position.size())
        throw Error(Error::Kind::kArgument,
                    fmt::format("render: a triangle names vertex {} of {}", i, m->position.size()));
  return *m;
}

View camera_view(const Camera& camera, int W, int H) {
  const Vec3 forward_raw = camera.target - camera.eye;
  if (!(length(forward_raw) > 0.0))
    throw Error(Error::Kind::kArgument,
                "camera: the eye is at the target; give a target away from the eye");
  if (!(camera.fov_deg > 0.0 && camera.fov_deg < 180.0))
    throw Error(Error::Kind::kArgument,
                fmt::format("camera: field of view {} degrees is not in (0, 180)", camera.fov_deg));
  View v;
  v.width = W;
  v.height = H;
  v.eye = camera.eye;
  v.forward = normalized(forward_raw);
  Vec3 right = cross(v.forward, camera.up);
  if (length(right) < 1e-9 * std::max(1.0, length(camera.up))) right = any_perpendicular(v.forward);
  v.right = normalized(right);
  v.up = cross(v.right, v.forward);
  v.focal = 0.5 * H / std::tan(0.5 * camera.fov_deg * kPi / 180.0);
  v.near = 1e-6 * std::max(1.0, length(forward_raw));
  return v;
}

std::vector<Projected> project_vertices(const Mesh& m, const View& v) {
  std::vector<Projected> pv(m.position.size());
  for (std::size_t i = 0; i < pv.size(); ++i) {
    const Vec3 d = m.position[i] - v.eye;
    const double cz = dot(d, v.forward);
    pv[i].depth = cz;
    if (cz > v.near) {
      pv[i].sx = 0.5 * v.width + v.focal * dot(d, v.right) / cz;
      pv[i].sy = 0.5 * v.height - v.focal * dot(d, v.up) / cz;
    }
  }
  return pv;
}

// The triangles on the screen binned into bands of kBand rows.
std::vector<std::vector<std::uint32_t>> bin_triangles(const Mesh& m,
                                                      const std::vector<Projected>& pv,
                                                      const View& v, int bands) {
  const int W = v.width, H = v.height;
  std::vector<std::vector<std::uint32_t>> band_tris(static_cast<std::size_t>(bands));
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    const Projected &a = pv[tri[0]], &b = pv[tri[1]], &c = pv[tri[2]];
    // Triangles crossing the camera's near plane are left out (the camera is meant outside
    // the object).
    if (!(a.depth > v.near && b.depth > v.near && c.depth > v.near)) continue;
    const double ylo = std::min({a.sy, b.sy, c.sy}), yhi = std::max({a.sy, b.sy, c.sy});
    const double xlo = std::min({a.sx, b.sx, c.sx}), xhi = std::max({a.sx, b.sx, c.sx});
    if (yhi < 0 || ylo > H || xhi < 0 || xlo > W) continue;
    const int b0 = std::clamp(int(std::floor(ylo)) / kBand, 0, bands - 1);
    const int b1 = std::clamp(int(std::floor(yhi)) / kBand, 0, bands - 1);
    for (int k = b0; k <= b1; ++k) band_tris[std::size_t(k)].push_back(t);
  }
  return band_tris;
}

// The vertex attributes in float, one array each (position, normal, tangent, bitangent: x,
// y, z; u, v), and each triangle's vertices and (unnormalised) face normal, for a set-up
// vectorised over the pixels.
struct SetUpArrays {
  std::array<std::vector<float>, detail::kAttributes> attr;
  std::vector<std::uint32_t> corner;  // 3 a triangle
  std::vector<float> face;            // 3 a triangle
};

SetUpArrays set_up_arrays(const Mesh& m) {
  const std::size_t nvert = m.position.size(), ntri = m.triangles.size();
  SetUpArrays s;
  for (auto& a : s.attr) a.resize(nvert);
  for (std::size_t i = 0; i < nvert; ++i) {
    const Vec3* v[4] = {&m.position[i], &m.normal[i], &m.tangent[i], &m.bitangent[i]};
    for (int k = 0; k < 4; ++k) {
      s.attr[std::size_t(3 * k)][i] = float(v[k]->x);
      s.attr[std::size_t(3 * k + 1)][i] = float(v[k]->y);
      s.attr[std::size_t(3 * k + 2)][i] = float(v[k]->z);
    }
    s.attr[detail::kU][i] = float(m.uv[i][0]);
    s.attr[detail::kV][i] = float(m.uv[i][1]);
  }
  s.corner.resize(3 * ntri);
  s.face.resize(3 * ntri);
  for (std::size_t t = 0; t < ntri; ++t) {
    const auto& tri = m.triangles[t];
    const Vec3 g =
        cross(m.position[tri[1]] - m.position[tri[0]], m.position[tri[2]] - m.position[tri[0]]);
    for (int k = 0; k < 3; ++k) s.corner[3 * t + std::size_t(k)] = tri[std::size_t(k)];
    s.face[3 * t] = float(g.x);
    s.face[3 * t + 1] = float(g.y);
    s.face[3 * t + 2] = float(g.z);
  }
  return s;
}

detail::Float3 to_float(const Vec3& v) {
  return {float(v.x), float(v.y), float(v.z)};
}

SetUpScene set_up_scene(const SetUpArrays& arrays, const Camera& camera, const Light& light,
                        const RenderSettings& settings, int tile_width, int tile_height) {
  SetUpScene scene;
  for (int a = 0; a < detail::kAttributes; ++a)
    scene.attr[std::size_t(a)] = arrays.attr[std::size_t(a)].data();
  scene.corner = arrays.corner.data();
  scene.face = arrays.face.data();
  scene.texel = float(settings.repeat * tile_width);
  scene.light.point = light.kind == Light::Kind::kPoint;
  scene.light.direction = to_float(normalized(light.direction));
  scene.light.position = to_float(light.position);
  scene.light.intensity = float(light.intensity);
  scene.eye = to_float(camera.eye);
  scene.tw = float(tile_width);
  scene.th = float(tile_height);
  return scene;
}

// One thread's buffers for a band of kBand rows of `width` pixels: the visibility buffer
// (1/depth, triangle, barycentric coordinates), the covered pixels in block order with their
// set-up, and where each block's pixels end.
struct BandBuffers {
  BandBuffers(int width, int blocks)
      : inv_depth(std::size_t(kBand) * std::size_t(width)),
        tri_of(inv_depth.size()),
        bary0(inv_depth.size()),
        bary1(inv_depth.size()),
        pix(inv_depth.size()),
        ptri(inv_depth.size()),
        b0(inv_depth.size()),
        b1(inv_depth.size()),
        status(inv_depth.size()),
        block_end(std::size_t(blocks) + 1) {
    for (auto& r : res) r.resize(inv_depth.size());
  }
  std::vector<double> inv_depth;
  std::vector<std::int32_t> tri_of;
  std::vector<float> bary0, bary1;
  std::vector<std::uint32_t> pix;
  std::vector<std::int32_t> ptri;
  std::vector<float> b0, b1;
  std::array<std::vector<float>, detail::kResults> res;
  std::vector<std::uint8_t> status;
  std::vector<std::uint32_t> block_end;
};

// A band's lit points in block order, their pixels, and how many each block has.
struct BandPoints {
  std::vector<SurfacePoint> points;
  std::vector<std::uint32_t> pixel, count;
};

// The visibility buffer of rows y0..y1 - 1 (band-relative rows), for the triangle abc (index
// ti): every pixel of a row's span computed, vectorised, the nearer kept.
inline void rasterize_triangle(const Projected& a, const Projected& b, const Projected& c,
                               std::int32_t ti, int W, int y0, int y1, BandBuffers& buf) {
  const double area = (b.sx - a.sx) * (c.sy - a.sy) - (b.sy - a.sy) * (c.sx - a.sx);
  if (!(std::abs(area) > 1e-12)) return;
  const int xa = std::max(0, int(std::floor(std::min({a.sx, b.sx, c.sx}))));
  const int xb = std::min(W - 1, int(std::ceil(std::max({a.sx, b.sx, c.sx}))));
  const int ya = std::max(y0, int(std::floor(std::min({a.sy, b.sy, c.sy}))));
  const int yb = std::min(y1 - 1, int(std::ceil(std::max({a.sy, b.sy, c.sy}))));
  const double ia = 1.0 / a.depth, ib = 1.0 / b.depth, ic = 1.0 / c.depth;
  const double inv_area = 1.0 / area;
  for (int y = ya; y <= yb; ++y) {
    const double py = y + 0.5;
    const std::size_t row = std::size_t(y - y0) * std::size_t(W);
    double* __restrict depth_row = buf.inv_depth.data() + row;
    std::int32_t* __restrict tri_row = buf.tri_of.data() + row;
    float* __restrict bary0_row = buf.bary0.data() + row;
    float* __restrict bary1_row = buf.bary1.data() + row;
#pragma omp simd
    for (int x = xa; x <= xb; ++x) {
      const double px = x + 0.5;
      // Screen-space barycentric coordinates; either winding (the mesh is two-sided).
      // (The numerators are exact functions of an edge's two ends, so a pixel on an edge
      // gets the same, zero, weight from both of its triangles.)
      const double wa = ((b.sx - px) * (c.sy - py) - (b.sy - py) * (c.sx - px)) * inv_area;
      const double wb = ((c.sx - px) * (a.sy - py) - (c.sy - py) * (a.sx - px)) * inv_area;
      const double wc = ((a.sx - px) * (b.sy - py) - (a.sy - py) * (b.sx - px)) * inv_area;
      const double h = wa * ia + wb * ib + wc * ic;
      const double iz = h / (wa + wb + wc);
      // Inside (edges shared: no holes between) and nearer (1/depth: larger is nearer).
      const bool take = !(wa < 0) && !(wb < 0) && !(wc < 0) && !(iz <= depth_row[x]);
      const double norm = 1.0 / h;
      depth_row[x] = take ? iz : depth_row[x];
      tri_row[x] = take ? ti : tri_row[x];
      bary0_row[x] = take ? float(wa * ia * norm) : bary0_row[x];
      bary1_row[x] = take ? float(wb * ib * norm) : bary1_row[x];
    }
  }
}

// The visibility buffer of the band's rows y0..y1 - 1: triangle and perspective-correct
// barycentric coordinates.
void rasterize_band(const Mesh& m, const std::vector<Projected>& pv,
                    const std::vector<std::uint32_t>& tris, int W, int y0, int y1,
                    BandBuffers& buf) {
  std::fill(buf.inv_depth.begin(), buf.inv_depth.end(), 0.0);
  std::fill(buf.tri_of.begin(), buf.tri_of.end(), -1);
  for (std::uint32_t t : tris) {
    const auto& tri = m.triangles[t];
    rasterize_triangle(pv[tri[0]], pv[tri[1]], pv[tri[2]], std::int32_t(t), W, y0, y1, buf);
  }
}

// The covered pixels of the band, block by block, each block row by row (pixel, triangle,
// barycentric coordinates); their number.
std::size_t gather_covered_pixels(int W, int y0, int y1, int blocks, BandBuffers& buf) {
  std::size_t n = 0;
  buf.block_end[0] = 0;
  for (int bx = 0; bx < blocks; ++bx) {
    for (int y = y0; y < y1; ++y)
      for (int x = bx * B; x < std::min(W, bx * B + B); ++x) {
        const std::size_t q = std::size_t(y - y0) * std::size_t(W) + std::size_t(x);
        buf.pix[n] = std::uint32_t(std::size_t(y) * std::size_t(W) + std::size_t(x));
        buf.ptri[n] = buf.tri_of[q];
        buf.b0[n] = buf.bary0[q];
        buf.b1[n] = buf.bary1[q];
        n += buf.tri_of[q] >= 0;
      }
    buf.block_end[std::size_t(bx) + 1] = std::uint32_t(n);
  }
  return n;
}

// The coverage of the band's n set-up pixels, and its lit points in block order.
void collect_lit_points(std::size_t n, int blocks, const BandBuffers& buf,
                        std::vector<std::uint8_t>& coverage, BandPoints& out) {
  out.count.assign(std::size_t(blocks), 0);
  const std::uint8_t* st = buf.status.data();
  const auto& res = buf.res;
  std::size_t lit = 0;
  for (std::size_t k = 0; k < n; ++k) lit += st[k] == 2;
  out.points.resize(lit);
  out.pixel.resize(lit);
  std::size_t j = 0;
  for (int bx = 0; bx < blocks; ++bx)
    for (std::size_t k = buf.block_end[std::size_t(bx)]; k < buf.block_end[std::size_t(bx) + 1];
         ++k) {
      coverage[buf.pix[k]] = st[k];
      if (st[k] != 2) continue;
      SurfacePoint& sp = out.points[j];
      sp.x = res[detail::kResX][k];
      sp.y = res[detail::kResY][k];
      sp.light = {res[detail::kResL0][k], res[detail::kResL1][k], res[detail::kResL2][k]};
      sp.view = {res[detail::kResV0][k], res[detail::kResV1][k], res[detail::kResV2][k]};
      sp.irradiance = res[detail::kResIrr][k];
      out.pixel[j++] = buf.pix[k];
      ++out.count[std::size_t(bx)];
    }
}

// The bands' points one after the other, and where each non-empty screen block begins.
void concatenate_bands(const std::vector<BandPoints>& bands, SurfaceBuffer& out) {
  std::vector<std::size_t> offset(bands.size() + 1, 0);
  for (std::size_t b = 0; b < bands.size(); ++b) {
    offset[b + 1] = offset[b] + bands[b].points.size();
    std::size_t start = offset[b];
    for (const std::uint32_t c : bands[b].count) {
      if (c) out.block_start.push_back(std::uint32_t(start));
      start += c;
    }
  }
  out.block_start.push_back(std::uint32_t(offset[bands.size()]));
  out.points.resize(offset[bands.size()]);
  out.pixel.resize(offset[bands.size()]);
  const int nbands = int(bands.size());
#pragma omp parallel for schedule(static)
  for (int b = 0; b < nbands; ++b) {
    const BandPoints& band = bands[std::size_t(b)];
    std::copy(band.points.begin(), band.points.end(),
              out.points.begin() + std::ptrdiff_t(offset[std::size_t(b)]));
    std::copy(band.pixel.begin(), band.pixel.end(),
              out.pixel.begin() + std::ptrdiff_t(offset[std::size_t(b)]));
  }
}

}  // namespace

SurfaceBuffer rasterize(const Mesh& mesh_in, const Camera& camera, const Light& light,
                        const RenderSettings& settings, int tile_width, int tile_height) {
  const auto t0 = Clock::now();
  check_arguments(mesh_in, settings, tile_width, tile_height);
  Mesh framed;
  const Mesh& m = with_tangent_frames(mesh_in, framed);
  const int W = settings.width, H = settings.height;
  const View view = camera_view(camera, W, H);
  const std::vector<Projected> pv = project_vertices(m, view);
  const int bands = (H + kBand - 1) / kBand;
  const std::vector<std::vector<std::uint32_t>> band_tris = bin_triangles(m, pv, view, bands);
  // Per pixel: the surface point, its frame, and the light and view in that frame.
  const SetUpArrays arrays = set_up_arrays(m);
  const SetUpScene scene = set_up_scene(arrays, camera, light, settings, tile_width, tile_height);

  // Each band is a row of screen blocks of B x B pixels: rasterised, set up, and its lit
  // points stored in block order (the model evaluator bounds the model over a block).
  const int blocks = (W + B - 1) / B;
  SurfaceBuffer out;
  out.width = W;
  out.height = H;
  out.coverage.assign(std::size_t(W) * std::size_t(H), 0);
  std::vector<BandPoints> band_points(static_cast<std::size_t>(bands));
#pragma omp parallel
  {
    BandBuffers buf(W, blocks);
#pragma omp for schedule(dynamic, 1)
    for (int band = 0; band < bands; ++band) {
      const int y0 = band * kBand, y1 = std::min(H, y0 + kBand);
      rasterize_band(m, pv, band_tris[std::size_t(band)], W, y0, y1, buf);
      const std::size_t n = gather_covered_pixels(W, y0, y1, blocks, buf);
      detail::set_up_pixels(scene, buf.ptri.data(), buf.b0.data(), buf.b1.data(), n, buf.res,
                            buf.status.data());
      collect_lit_points(n, blocks, buf, out.coverage, band_points[std::size_t(band)]);
    }
  }
  concatenate_bands(band_points, out);
  out.seconds = seconds_since(t0);
  return out;
}

}  // namespace btfgmm
