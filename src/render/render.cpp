// The renderer's geometry pass (rasterisation, tangent frames, light and view directions in
// the local frame), composing images, the comparison metrics and figure of Fig. 3.
#include "btfgmm/render/render.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/metrics.hpp"

#include "core/vec3_ops.hpp"

namespace btfgmm {
namespace {

constexpr double kPi = std::numbers::pi;

using detail::operator+;
using detail::operator-;
using detail::operator*;
using detail::cross;
using detail::dot;
using detail::length;
Vec3 normalized(const Vec3& a) {
  const double l = length(a);
  return l > 0 ? a * (1.0 / l) : a;
}
Vec3 any_perpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  return normalized(a - n * dot(a, n));
}

// A vertex in camera space and on the screen.
struct Projected {
  double sx = 0, sy = 0;  // screen position, pixels (y down)
  double depth = 0;       // distance along the view axis
};

// The vertex attributes of the set-up, one float array each.
enum Attribute { kPx, kPy, kPz, kNx, kNy, kNz, kTx, kTy, kTz, kBx, kBy, kBz, kU, kV, kAttributes };

// What the per-pixel set-up needs of the scene: the vertex attributes, each triangle's
// vertices and (unnormalised) face normal, the light, the eye and the tile.
struct SetUpScene {
  std::array<const float*, kAttributes> attr{};
  const std::uint32_t* corner = nullptr;  // 3 a triangle
  const float* face = nullptr;            // 3 a triangle
  bool point_light = false;
  float ldx = 0, ldy = 0, ldz = 0;  // toward a directional light
  float lpx = 0, lpy = 0, lpz = 0;  // a point light's position
  float intensity = 0;
  float ex = 0, ey = 0, ez = 0;  // the eye
  float texel = 0;               // tile pixels per unit of u and v
  float tw = 0, th = 0;          // the tile
};

// The set-up's results, a float array each: x, y, light (3), view (3), irradiance.
enum SetUpResult {
  kResX,
  kResY,
  kResL0,
  kResL1,
  kResL2,
  kResV0,
  kResV1,
  kResV2,
  kResIrr,
  kResults
};

inline float interpolate(const float* __restrict v, std::uint32_t i0, std::uint32_t i1,
                         std::uint32_t i2, float l0, float l1, float l2) {
  return v[i0] * l0 + v[i1] * l1 + v[i2] * l2;
}

// Sets up n covered pixels, given the triangle and the first two perspective-correct
// barycentric coordinates of each: the surface point, its frame, the texture coordinate, and
// the light and view directions in the frame; status 1 in the dark, 2 lit. One loop over the
// pixels without calls or branches, vectorised (the vertex attributes gathered per lane).
void set_up_pixels(const SetUpScene& s, const std::int32_t* __restrict tri,
                   const float* __restrict b0, const float* __restrict b1, std::size_t n,
                   std::array<std::vector<float>, kResults>& res, std::uint8_t* __restrict st) {
  const std::uint32_t* __restrict cn = s.corner;
  const float* __restrict fc = s.face;
  const float* __restrict a_px = s.attr[kPx], * __restrict a_py = s.attr[kPy], * __restrict a_pz = s.attr[kPz], * __restrict a_nx = s.attr[kNx], * __restrict a_ny = s.attr[kNy], * __restrict a_nz = s.attr[kNz], * __restrict a_tx = s.attr[kTx], * __restrict a_ty = s.attr[kTy], * __restrict a_tz = s.attr[kTz], * __restrict a_bx = s.attr[kBx], * __restrict a_by = s.attr[kBy], * __restrict a_bz = s.attr[kBz], * __restrict a_u = s.attr[kU], * __restrict a_v = s.attr[kV];
  float* __restrict r_x = res[kResX].data();
  float* __restrict r_y = res[kResY].data();
  float* __restrict r_l0 = res[kResL0].data();
  float* __restrict r_l1 = res[kResL1].data();
  float* __restrict r_l2 = res[kResL2].data();
  float* __restrict r_v0 = res[kResV0].data();
  float* __restrict r_v1 = res[kResV1].data();
  float* __restrict r_v2 = res[kResV2].data();
  float* __restrict r_irr = res[kResIrr].data();
  const bool point_light = s.point_light;
  const float ldx = s.ldx, ldy = s.ldy, ldz = s.ldz, lpx = s.lpx, lpy = s.lpy, lpz = s.lpz,
              intensity = s.intensity, ex = s.ex, ey = s.ey, ez = s.ez, texel = s.texel, tw = s.tw,
              th = s.th;
#pragma omp simd
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t t = std::size_t(tri[k]);
    const std::uint32_t i0 = cn[3 * t], i1 = cn[3 * t + 1], i2 = cn[3 * t + 2];
    const float l0 = b0[k], l1 = b1[k], l2 = 1.0f - l0 - l1;
    const float px = interpolate(a_px, i0, i1, i2, l0, l1, l2),
                py = interpolate(a_py, i0, i1, i2, l0, l1, l2),
                pz = interpolate(a_pz, i0, i1, i2, l0, l1, l2);
    const float gx = fc[3 * t], gy = fc[3 * t + 1], gz = fc[3 * t + 2];
    // The normal (the face's where the interpolated one vanishes).
    float nx = interpolate(a_nx, i0, i1, i2, l0, l1, l2),
          ny = interpolate(a_ny, i0, i1, i2, l0, l1, l2),
          nz = interpolate(a_nz, i0, i1, i2, l0, l1, l2);
    const float nl = std::sqrt(nx * nx + ny * ny + nz * nz);
    const bool nok = nl > 1e-12f;
    const float gl = std::sqrt(gx * gx + gy * gy + gz * gz);
    const float ni = 1.0f / (nok ? nl : (gl > 0.0f ? gl : 1.0f));
    nx = (nok ? nx : gx) * ni;
    ny = (nok ? ny : gy) * ni;
    nz = (nok ? nz : gz) * ni;
    // The frame: tangent along +u made normal to the normal (any unit vector normal to it
    // where that vanishes); bitangent normal to both, on the side of +v (a mirrored UV
    // layout gives a mirrored, still consistent, frame).
    float tx = interpolate(a_tx, i0, i1, i2, l0, l1, l2),
          ty = interpolate(a_ty, i0, i1, i2, l0, l1, l2),
          tz = interpolate(a_tz, i0, i1, i2, l0, l1, l2);
    const float tn = tx * nx + ty * ny + tz * nz;
    tx -= nx * tn;
    ty -= ny * tn;
    tz -= nz * tn;
    const float tl = std::sqrt(tx * tx + ty * ty + tz * tz);
    const bool tok = tl > 1e-12f;
    const bool ax = std::abs(nx) < 0.9f;
    const float an = ax ? nx : ny;  // a . n, a = (1, 0, 0) or (0, 1, 0)
    const float qx = (ax ? 1.0f : 0.0f) - nx * an, qy = (ax ? 0.0f : 1.0f) - ny * an, qz = -nz * an;
    const float ql = std::sqrt(qx * qx + qy * qy + qz * qz);
    const float ti = 1.0f / (tok ? tl : ql);
    tx = (tok ? tx : qx) * ti;
    ty = (tok ? ty : qy) * ti;
    tz = (tok ? tz : qz) * ti;
    float bx = ny * tz - nz * ty, by = nz * tx - nx * tz, bz = nx * ty - ny * tx;
    const float bs = bx * interpolate(a_bx, i0, i1, i2, l0, l1, l2) +
                                 by * interpolate(a_by, i0, i1, i2, l0, l1, l2) +
                                 bz * interpolate(a_bz, i0, i1, i2, l0, l1, l2) <
                             0.0f
                         ? -1.0f
                         : 1.0f;
    bx *= bs;
    by *= bs;
    bz *= bs;
    // Seen from behind (an open surface such as the cloth), the back side shows the
    // material too: the normal turns toward the viewer.
    float vx = ex - px, vy = ey - py, vz = ez - pz;
    const float vl = std::sqrt(vx * vx + vy * vy + vz * vz);
    const float vi = 1.0f / (vl > 0.0f ? vl : 1.0f);
    vx *= vi;
    vy *= vi;
    vz *= vi;
    const bool flip = (gx * nx + gy * ny + gz * nz < 0.0f) != (gx * vx + gy * vy + gz * vz < 0.0f);
    const float ns = flip ? -1.0f : 1.0f;
    nx *= ns;
    ny *= ns;
    nz *= ns;
    // A point light falls off with the squared distance; where it is at the point, the point
    // is unlit.
    const float dx = lpx - px, dy = lpy - py, dz = lpz - pz;
    const float d2 = dx * dx + dy * dy + dz * dz;
    const bool at_light = !(d2 > 0.0f);
    const float di = 1.0f / std::sqrt(at_light ? 1.0f : d2);
    const float lx = point_light ? (at_light ? nx : dx * di) : ldx,
                ly = point_light ? (at_light ? ny : dy * di) : ldy,
                lz = point_light ? (at_light ? nz : dz * di) : ldz;
    const float irradiance =
        point_light ? (at_light ? 0.0f : intensity / (at_light ? 1.0f : d2)) : intensity;
    const float fl0 = lx * tx + ly * ty + lz * tz, fl1 = lx * bx + ly * by + lz * bz,
                fl2 = lx * nx + ly * ny + lz * nz;
    // In the dark: the light is below this point's horizon.
    st[k] = !(fl2 > 0.0f) || !(irradiance > 0.0f) ? 1 : 2;
    float fv0 = vx * tx + vy * ty + vz * tz, fv1 = vx * bx + vy * by + vz * bz,
          fv2 = vx * nx + vy * ny + vz * nz;
    // A shading normal may turn slightly away from the eye at a silhouette: the view is
    // taken on the horizon there.
    const float hl = std::sqrt(fv0 * fv0 + fv1 * fv1);
    const bool below = fv2 < 0.0f, flat = !(hl > 0.0f);
    const float hi = flat ? 0.0f : 1.0f / (flat ? 1.0f : hl);
    fv0 = below ? fv0 * hi : fv0;
    fv1 = below ? fv1 * hi : fv1;
    fv2 = below ? (flat ? 1.0f : 0.0f) : fv2;
    // The texture coordinate in tile pixels, wrapped into the tile.
    const float u = interpolate(a_u, i0, i1, i2, l0, l1, l2) * texel,
                w = interpolate(a_v, i0, i1, i2, l0, l1, l2) * texel;
    float sx = u - tw * std::floor(u / tw), sy = w - th * std::floor(w / th);
    sx = sx < 0.0f || sx >= tw ? 0.0f : sx;
    sy = sy < 0.0f || sy >= th ? 0.0f : sy;
    r_x[k] = sx;
    r_y[k] = sy;
    r_l0[k] = fl0;
    r_l1[k] = fl1;
    r_l2[k] = fl2;
    r_v0[k] = fv0;
    r_v1[k] = fv1;
    r_v2[k] = fv2;
    r_irr[k] = irradiance;
  }
}

}  // namespace

Camera Camera::orbit(const Direction& d, double radius, const Vec3& target, double fov_deg) {
  if (!(radius > 0.0) || !(fov_deg > 0.0 && fov_deg < 180.0))
    throw Error(Error::Kind::kArgument,
                fmt::format("camera: radius {} and field of view {} degrees must be positive "
                            "(field of view below 180)",
                            radius, fov_deg));
  Camera c;
  const Vec3 dir = to_vector(d);
  // Far enough that the sphere of `radius` fits in the view with a small margin.
  const double distance = 1.08 * radius / std::sin(0.5 * fov_deg * kPi / 180.0);
  c.target = target;
  c.eye = target + dir * distance;
  c.fov_deg = fov_deg;
  const double p = d.phi_deg * kPi / 180.0;
  c.up = d.theta_deg < 1e-6           ? Vec3{-std::cos(p), -std::sin(p), 0.0}
         : d.theta_deg > 180.0 - 1e-6 ? Vec3{std::cos(p), std::sin(p), 0.0}
                                      : Vec3{0, 0, 1};
  return c;
}

Light Light::directional(const Direction& d, double intensity) {
  Light l;
  l.kind = Kind::kDirectional;
  l.direction = to_vector(d);
  l.intensity = intensity;
  return l;
}

Light Light::point(const Vec3& position, double intensity) {
  Light l;
  l.kind = Kind::kPoint;
  l.position = position;
  l.intensity = intensity;
  return l;
}

SurfaceBuffer rasterize(const Mesh& mesh_in, const Camera& camera, const Light& light,
                        const RenderSettings& settings, int tile_width, int tile_height) {
  const auto t0 = Clock::now();
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
                fmt::format("--repeat {} must be a positive number of tiles", settings.repeat));
  if (mesh_in.triangles.empty() || mesh_in.position.empty())
    throw Error(Error::Kind::kArgument, "render: the mesh has no triangles");
  const Mesh* mesh = &mesh_in;
  Mesh framed;
  if (mesh_in.tangent.size() != mesh_in.position.size() ||
      mesh_in.bitangent.size() != mesh_in.position.size() ||
      mesh_in.normal.size() != mesh_in.position.size()) {
    framed = mesh_in;
    compute_tangent_frames(framed);
    mesh = &framed;
  }
  const Mesh& m = *mesh;
  for (const auto& t : m.triangles)
    for (std::uint32_t i : t)
      if (i >= m.position.size())
        throw Error(Error::Kind::kArgument,
                    fmt::format("render: a triangle names vertex {} of {}", i, m.position.size()));

  // The camera's frame: right, up, forward.
  const Vec3 forward_raw = camera.target - camera.eye;
  if (!(length(forward_raw) > 0.0))
    throw Error(Error::Kind::kArgument,
                "camera: the eye is at the target; give a target away from the eye");
  if (!(camera.fov_deg > 0.0 && camera.fov_deg < 180.0))
    throw Error(Error::Kind::kArgument,
                fmt::format("camera: field of view {} degrees is not in (0, 180)", camera.fov_deg));
  const Vec3 fwd = normalized(forward_raw);
  Vec3 right = cross(fwd, camera.up);
  if (length(right) < 1e-9 * std::max(1.0, length(camera.up))) right = any_perpendicular(fwd);
  right = normalized(right);
  const Vec3 up = cross(right, fwd);
  const double focal = 0.5 * H / std::tan(0.5 * camera.fov_deg * kPi / 180.0);
  const double near = 1e-6 * std::max(1.0, length(forward_raw));

  std::vector<Projected> pv(m.position.size());
  for (std::size_t i = 0; i < pv.size(); ++i) {
    const Vec3 d = m.position[i] - camera.eye;
    const double cz = dot(d, fwd);
    pv[i].depth = cz;
    if (cz > near) {
      pv[i].sx = 0.5 * W + focal * dot(d, right) / cz;
      pv[i].sy = 0.5 * H - focal * dot(d, up) / cz;
    }
  }

  // Triangles binned into bands of rows; each band is rasterised by one thread.
  constexpr int kBand = 16;
  const int bands = (H + kBand - 1) / kBand;
  std::vector<std::vector<std::uint32_t>> band_tris(static_cast<std::size_t>(bands));
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    const Projected &a = pv[tri[0]], &b = pv[tri[1]], &c = pv[tri[2]];
    // Triangles crossing the camera's near plane are left out (the camera is meant outside
    // the object).
    if (!(a.depth > near && b.depth > near && c.depth > near)) continue;
    const double ylo = std::min({a.sy, b.sy, c.sy}), yhi = std::max({a.sy, b.sy, c.sy});
    const double xlo = std::min({a.sx, b.sx, c.sx}), xhi = std::max({a.sx, b.sx, c.sx});
    if (yhi < 0 || ylo > H || xhi < 0 || xlo > W) continue;
    const int b0 = std::clamp(int(std::floor(ylo)) / kBand, 0, bands - 1);
    const int b1 = std::clamp(int(std::floor(yhi)) / kBand, 0, bands - 1);
    for (int k = b0; k <= b1; ++k) band_tris[std::size_t(k)].push_back(t);
  }

  // Per pixel: the surface point, its frame, and the light and view in that frame; 0 the
  // background, 1 in the dark, 2 lit. The vertex attributes in float, one array each
  // (position, normal, tangent, bitangent: x, y, z; u, v), and each triangle's vertices and
  // (unnormalised) face normal, for a set-up vectorised over the pixels.
  const std::size_t nvert = m.position.size(), ntri = m.triangles.size();
  std::array<std::vector<float>, kAttributes> attr;
  for (auto& a : attr) a.resize(nvert);
  for (std::size_t i = 0; i < nvert; ++i) {
    const Vec3* v[4] = {&m.position[i], &m.normal[i], &m.tangent[i], &m.bitangent[i]};
    for (int k = 0; k < 4; ++k) {
      attr[std::size_t(3 * k)][i] = float(v[k]->x);
      attr[std::size_t(3 * k + 1)][i] = float(v[k]->y);
      attr[std::size_t(3 * k + 2)][i] = float(v[k]->z);
    }
    attr[kU][i] = float(m.uv[i][0]);
    attr[kV][i] = float(m.uv[i][1]);
  }
  std::vector<std::uint32_t> corner(3 * ntri);
  std::vector<float> face(3 * ntri);
  for (std::size_t t = 0; t < ntri; ++t) {
    const auto& tri = m.triangles[t];
    const Vec3 g =
        cross(m.position[tri[1]] - m.position[tri[0]], m.position[tri[2]] - m.position[tri[0]]);
    for (int k = 0; k < 3; ++k) corner[3 * t + std::size_t(k)] = tri[std::size_t(k)];
    face[3 * t] = float(g.x);
    face[3 * t + 1] = float(g.y);
    face[3 * t + 2] = float(g.z);
  }
  SetUpScene scene;
  for (int a = 0; a < kAttributes; ++a) scene.attr[std::size_t(a)] = attr[std::size_t(a)].data();
  scene.corner = corner.data();
  scene.face = face.data();
  scene.texel = float(settings.repeat * tile_width);
  const Vec3 light_dir = normalized(light.direction);
  scene.point_light = light.kind == Light::Kind::kPoint;
  scene.ldx = float(light_dir.x);
  scene.ldy = float(light_dir.y);
  scene.ldz = float(light_dir.z);
  scene.lpx = float(light.position.x);
  scene.lpy = float(light.position.y);
  scene.lpz = float(light.position.z);
  scene.intensity = float(light.intensity);
  scene.ex = float(camera.eye.x);
  scene.ey = float(camera.eye.y);
  scene.ez = float(camera.eye.z);
  scene.tw = float(tile_width);
  scene.th = float(tile_height);

  // Each band of kBand rows is a row of screen blocks of B x B pixels: rasterised, set up, and
  // its lit points stored in block order (the model evaluator bounds the model over a block).
  constexpr int B = SurfaceBuffer::kBlockSize;
  static_assert(B == kBand, "a band is one row of screen blocks");
  const int bw = (W + B - 1) / B;
  const std::size_t npix = std::size_t(W) * std::size_t(H);
  SurfaceBuffer out;
  out.width = W;
  out.height = H;
  out.coverage.assign(npix, 0);
  std::vector<std::vector<SurfacePoint>> band_points(static_cast<std::size_t>(bands));
  std::vector<std::vector<std::uint32_t>> band_pixel(static_cast<std::size_t>(bands)),
      band_count(static_cast<std::size_t>(bands));
#pragma omp parallel
  {
    const std::size_t band_pixels = std::size_t(kBand) * std::size_t(W);
    std::vector<double> inv_depth(band_pixels);
    std::vector<std::int32_t> tri_of(band_pixels);
    std::vector<float> bary0(band_pixels), bary1(band_pixels);
    // The band's covered pixels in block order, and their set-up.
    std::vector<std::uint32_t> pix(band_pixels);
    std::vector<std::int32_t> ptri(band_pixels);
    std::vector<float> b0(band_pixels), b1(band_pixels);
    std::array<std::vector<float>, kResults> res;
    for (auto& r : res) r.resize(band_pixels);
    std::vector<std::uint8_t> status(band_pixels);
    std::vector<std::uint32_t> block_end(std::size_t(bw) + 1);
#pragma omp for schedule(dynamic, 1)
    for (int band = 0; band < bands; ++band) {
      const int y0 = band * kBand, y1 = std::min(H, y0 + kBand);
      std::fill(inv_depth.begin(), inv_depth.end(), 0.0);
      std::fill(tri_of.begin(), tri_of.end(), -1);
      // The visibility buffer: triangle and perspective-correct barycentric coordinates.
      for (std::uint32_t t : band_tris[std::size_t(band)]) {
        const auto& tri = m.triangles[t];
        const Projected &a = pv[tri[0]], &b = pv[tri[1]], &c = pv[tri[2]];
        const double area = (b.sx - a.sx) * (c.sy - a.sy) - (b.sy - a.sy) * (c.sx - a.sx);
        if (!(std::abs(area) > 1e-12)) continue;
        const int xa = std::max(0, int(std::floor(std::min({a.sx, b.sx, c.sx}))));
        const int xb = std::min(W - 1, int(std::ceil(std::max({a.sx, b.sx, c.sx}))));
        const int ya = std::max(y0, int(std::floor(std::min({a.sy, b.sy, c.sy}))));
        const int yb = std::min(y1 - 1, int(std::ceil(std::max({a.sy, b.sy, c.sy}))));
        const double ia = 1.0 / a.depth, ib = 1.0 / b.depth, ic = 1.0 / c.depth;
        const double inv_area = 1.0 / area;
        const std::int32_t ti = std::int32_t(t);
        for (int y = ya; y <= yb; ++y) {
          const double py = y + 0.5;
          const std::size_t row = std::size_t(y - y0) * std::size_t(W);
          double* __restrict depth_row = inv_depth.data() + row;
          std::int32_t* __restrict tri_row = tri_of.data() + row;
          float* __restrict bary0_row = bary0.data() + row;
          float* __restrict bary1_row = bary1.data() + row;
          // Vectorised over the row: every pixel of the span computed, the nearer kept.
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
      // The covered pixels, block by block, each block row by row.
      std::size_t n = 0;
      block_end[0] = 0;
      for (int bx = 0; bx < bw; ++bx) {
        for (int y = y0; y < y1; ++y)
          for (int x = bx * B; x < std::min(W, bx * B + B); ++x) {
            const std::size_t q = std::size_t(y - y0) * std::size_t(W) + std::size_t(x);
            pix[n] = std::uint32_t(std::size_t(y) * std::size_t(W) + std::size_t(x));
            ptri[n] = tri_of[q];
            b0[n] = bary0[q];
            b1[n] = bary1[q];
            n += tri_of[q] >= 0;
          }
        block_end[std::size_t(bx) + 1] = std::uint32_t(n);
      }
      set_up_pixels(scene, ptri.data(), b0.data(), b1.data(), n, res, status.data());
      // The lit points, in block order.
      std::vector<SurfacePoint>& bp = band_points[std::size_t(band)];
      std::vector<std::uint32_t>& bpix = band_pixel[std::size_t(band)];
      std::vector<std::uint32_t>& bc = band_count[std::size_t(band)];
      bc.assign(std::size_t(bw), 0);
      const std::uint8_t* st = status.data();
      std::size_t lit = 0;
      for (std::size_t k = 0; k < n; ++k) lit += st[k] == 2;
      bp.resize(lit);
      bpix.resize(lit);
      std::size_t j = 0;
      for (int bx = 0; bx < bw; ++bx)
        for (std::size_t k = block_end[std::size_t(bx)]; k < block_end[std::size_t(bx) + 1]; ++k) {
          out.coverage[pix[k]] = st[k];
          if (st[k] != 2) continue;
          SurfacePoint& sp = bp[j];
          sp.x = res[kResX][k];
          sp.y = res[kResY][k];
          sp.light = {res[kResL0][k], res[kResL1][k], res[kResL2][k]};
          sp.view = {res[kResV0][k], res[kResV1][k], res[kResV2][k]};
          sp.irradiance = res[kResIrr][k];
          bpix[j++] = pix[k];
          ++bc[std::size_t(bx)];
        }
    }
  }
  std::vector<std::size_t> offset(std::size_t(bands) + 1, 0);
  for (std::size_t b = 0; b < std::size_t(bands); ++b) {
    offset[b + 1] = offset[b] + band_points[b].size();
    std::size_t start = offset[b];
    for (const std::uint32_t c : band_count[b]) {
      if (c) out.block_start.push_back(std::uint32_t(start));
      start += c;
    }
  }
  out.block_start.push_back(std::uint32_t(offset[std::size_t(bands)]));
  out.points.resize(offset[std::size_t(bands)]);
  out.pixel.resize(offset[std::size_t(bands)]);
#pragma omp parallel for schedule(static)
  for (int b = 0; b < bands; ++b) {
    std::copy(band_points[std::size_t(b)].begin(), band_points[std::size_t(b)].end(),
              out.points.begin() + std::ptrdiff_t(offset[std::size_t(b)]));
    std::copy(band_pixel[std::size_t(b)].begin(), band_pixel[std::size_t(b)].end(),
              out.pixel.begin() + std::ptrdiff_t(offset[std::size_t(b)]));
  }
  out.seconds = seconds_since(t0);
  return out;
}

// ---- composing ----------------------------------------------------------------------------

Rendering compose(const SurfaceBuffer& s, std::span<const float> point_rgb,
                  const RenderSettings& settings, SampleFormat format) {
  if (point_rgb.size() < s.points.size() * 3)
    throw Error(Error::Kind::kArgument, "compose: fewer colours than surface points");
  Rendering r;
  r.width = s.width;
  r.height = s.height;
  const std::size_t npix = std::size_t(s.width) * std::size_t(s.height);
  r.rgb.resize(npix * 3);
  r.object.resize(npix);
  const std::ptrdiff_t np = std::ptrdiff_t(npix), npoints = std::ptrdiff_t(s.points.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t pi = 0; pi < np; ++pi) {
    const std::size_t p = std::size_t(pi);
    r.object[p] = s.coverage[p] != 0;
    for (int c = 0; c < 3; ++c)
      r.rgb[p * 3 + std::size_t(c)] =
          s.coverage[p] == 0 ? settings.background[std::size_t(c)] : 0.0f;
  }
  const double scale = std::exp2(settings.exposure);
  // Each point has a pixel of its own.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t pi = 0; pi < npoints; ++pi) {
    const std::size_t i = std::size_t(pi), p = s.pixel[i];
    for (int c = 0; c < 3; ++c) {
      double v = double(point_rgb[i * 3 + std::size_t(c)]) * s.points[i].irradiance * scale;
      if (format == SampleFormat::kHdr) {
        // Linear to sRGB levels.
        v = std::clamp(v, 0.0, 1.0);
        v = 255.0 * (v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055);
      }
      r.rgb[p * 3 + std::size_t(c)] = float(v);
    }
  }
  r.geometry_seconds = s.seconds;
  return r;
}

Rendering render(const SurfaceBuffer& surface, const ModelEvaluator& model,
                 const RenderSettings& settings, SampleFormat format) {
  std::vector<float> rgb(surface.points.size() * 3);
  const EvaluationStats st = model.evaluate(surface.points, rgb, surface.block_start);
  Rendering r = compose(surface, rgb, settings, format);
  r.stats = st;
  return r;
}

Rendering render(const SurfaceBuffer& surface, const DataEvaluator& data,
                 const RenderSettings& settings, SampleFormat format) {
  std::vector<float> rgb(surface.points.size() * 3);
  const EvaluationStats st = data.evaluate(surface.points, rgb);
  Rendering r = compose(surface, rgb, settings, format);
  r.stats = st;
  return r;
}

// ---- comparison ---------------------------------------------------------------------------

namespace {

float clamp255(float v) {
  return std::clamp(v, 0.0f, 255.0f);
}

}  // namespace

RenderComparison compare_renderings(const Rendering& a, const Rendering& b) {
  if (a.width != b.width || a.height != b.height || a.rgb.size() != b.rgb.size())
    throw Error(Error::Kind::kArgument,
                fmt::format("cannot compare renderings of {}x{} and {}x{} pixels", a.width,
                            a.height, b.width, b.height));
  const int w = a.width, h = a.height;
  const std::size_t npix = std::size_t(w) * std::size_t(h);
  RenderComparison r;
  double se = 0;
  for (std::size_t p = 0; p < npix; ++p) {
    if (!a.object[p] || !b.object[p]) continue;
    ++r.pixels;
    for (int c = 0; c < 3; ++c) {
      const double d =
          double(clamp255(a.rgb[p * 3 + std::size_t(c)])) - clamp255(b.rgb[p * 3 + std::size_t(c)]);
      se += d * d;
    }
  }
  if (r.pixels == 0)
    throw Error(Error::Kind::kArgument,
                "the object covers no pixel of the renderings; point the camera at it");
  r.rmse = std::sqrt(se / double(3 * r.pixels));
  r.psnr = psnr_db(r.rmse, 255.0);
  // SSIM per channel (metrics.hpp), averaged over the windows centred on the object.
  std::vector<float> x(npix * 3), y(npix * 3);
  for (std::size_t i = 0; i < npix * 3; ++i) {
    x[i] = clamp255(a.rgb[i]);
    y[i] = clamp255(b.rgb[i]);
  }
  const int rad = ssim_radius(w, h);
  const int mw = w - 2 * rad, mh = h - 2 * rad;
  double sum = 0;
  std::size_t count = 0;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> map;
    ssim_channel(x, y, w, h, c, 255.0, {}, &map);
    for (int yy = 0; yy < mh; ++yy)
      for (int xx = 0; xx < mw; ++xx) {
        const std::size_t centre = std::size_t(yy + rad) * std::size_t(w) + std::size_t(xx + rad);
        if (!a.object[centre] || !b.object[centre]) continue;
        sum += map[std::size_t(yy) * std::size_t(mw) + std::size_t(xx)];
        ++count;
      }
  }
  r.ssim = count ? sum / double(count) : std::numeric_limits<double>::quiet_NaN();
  return r;
}

namespace {

// A 5 x 7 pixel font: seven rows of five bits (bit 4 the leftmost pixel).
struct Glyph {
  char c;
  std::array<std::uint8_t, 7> rows;
};
constexpr Glyph kFont[] = {
    {'A', {14, 17, 17, 31, 17, 17, 17}}, {'B', {30, 17, 17, 30, 17, 17, 30}},
    {'C', {14, 17, 16, 16, 16, 17, 14}}, {'D', {28, 18, 17, 17, 17, 18, 28}},
    {'E', {31, 16, 16, 30, 16, 16, 31}}, {'F', {31, 16, 16, 30, 16, 16, 16}},
    {'G', {14, 17, 16, 23, 17, 17, 15}}, {'H', {17, 17, 17, 31, 17, 17, 17}},
    {'I', {14, 4, 4, 4, 4, 4, 14}},      {'J', {7, 2, 2, 2, 2, 18, 12}},
    {'K', {17, 18, 20, 24, 20, 18, 17}}, {'L', {16, 16, 16, 16, 16, 16, 31}},
    {'M', {17, 27, 21, 21, 17, 17, 17}}, {'N', {17, 17, 25, 21, 19, 17, 17}},
    {'O', {14, 17, 17, 17, 17, 17, 14}}, {'P', {30, 17, 17, 30, 16, 16, 16}},
    {'Q', {14, 17, 17, 17, 21, 18, 13}}, {'R', {30, 17, 17, 30, 20, 18, 17}},
    {'S', {15, 16, 16, 14, 1, 1, 30}},   {'T', {31, 4, 4, 4, 4, 4, 4}},
    {'U', {17, 17, 17, 17, 17, 17, 14}}, {'V', {17, 17, 17, 17, 17, 10, 4}},
    {'W', {17, 17, 17, 21, 21, 21, 10}}, {'X', {17, 17, 10, 4, 10, 17, 17}},
    {'Y', {17, 17, 17, 10, 4, 4, 4}},    {'Z', {31, 1, 2, 4, 8, 16, 31}},
    {'0', {14, 17, 19, 21, 25, 17, 14}}, {'1', {4, 12, 4, 4, 4, 4, 14}},
    {'2', {14, 17, 1, 2, 4, 8, 31}},     {'3', {31, 2, 4, 2, 1, 17, 14}},
    {'4', {2, 6, 10, 18, 31, 2, 2}},     {'5', {31, 16, 30, 1, 1, 17, 14}},
    {'6', {6, 8, 16, 30, 17, 17, 14}},   {'7', {31, 1, 2, 4, 8, 8, 8}},
    {'8', {14, 17, 17, 14, 17, 17, 14}}, {'9', {14, 17, 17, 15, 1, 2, 12}},
    {'.', {0, 0, 0, 0, 0, 12, 12}},      {',', {0, 0, 0, 0, 12, 4, 8}},
    {':', {0, 12, 12, 0, 12, 12, 0}},    {'/', {0, 1, 2, 4, 8, 16, 0}},
    {'|', {4, 4, 4, 4, 4, 4, 4}},        {'=', {0, 0, 31, 0, 31, 0, 0}},
    {'%', {24, 25, 2, 4, 8, 19, 3}},     {'+', {0, 4, 4, 31, 4, 4, 0}},
    {'-', {0, 0, 0, 31, 0, 0, 0}},       {'(', {2, 4, 8, 8, 8, 4, 2}},
    {')', {8, 4, 2, 2, 2, 4, 8}},        {' ', {0, 0, 0, 0, 0, 0, 0}},
};

const Glyph* glyph(char c) {
  const char u = char(std::toupper(static_cast<unsigned char>(c)));
  for (const Glyph& g : kFont)
    if (g.c == u) return &g;
  return nullptr;
}

}  // namespace

void draw_text(Image& image, int x, int y, const std::string& text, int scale,
               std::array<float, 3> rgb) {
  scale = std::max(1, scale);
  int cx = x;
  for (char ch : text) {
    const Glyph* g = glyph(ch);
    if (g)
      for (int row = 0; row < 7; ++row)
        for (int col = 0; col < 5; ++col) {
          if (!((g->rows[std::size_t(row)] >> (4 - col)) & 1)) continue;
          for (int dy = 0; dy < scale; ++dy)
            for (int dx = 0; dx < scale; ++dx) {
              const int px = cx + col * scale + dx, py = y + row * scale + dy;
              if (px < 0 || py < 0 || px >= image.width || py >= image.height) continue;
              float* o =
                  &image.rgb[(std::size_t(py) * std::size_t(image.width) + std::size_t(px)) * 3];
              o[0] = rgb[0];
              o[1] = rgb[1];
              o[2] = rgb[2];
            }
        }
    cx += 6 * scale;
  }
}

Image comparison_figure(const Rendering& data, const Rendering& model,
                        const RenderComparison& metrics, double difference_scale) {
  if (data.width != model.width || data.height != model.height)
    throw Error(Error::Kind::kArgument, "comparison figure: the renderings differ in size");
  const int w = data.width, h = data.height, gap = std::max(2, w / 200);
  const int scale = std::max(1, std::min(w, 900) / 260);
  const int line = 9 * scale, strip = 3 * line + 2 * scale;
  Image img;
  img.width = 3 * w + 2 * gap;
  img.height = h + strip;
  img.rgb.assign(std::size_t(img.width) * std::size_t(img.height) * 3, 255.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t p = (std::size_t(y) * std::size_t(w) + std::size_t(x)) * 3;
      for (int c = 0; c < 3; ++c) {
        const float a = clamp255(data.rgb[p + std::size_t(c)]),
                    b = clamp255(model.rgb[p + std::size_t(c)]);
        const float d = clamp255(float(difference_scale) * std::abs(a - b));
        const std::size_t row = std::size_t(y) * std::size_t(img.width);
        img.rgb[(row + std::size_t(x)) * 3 + std::size_t(c)] = a;
        img.rgb[(row + std::size_t(x + w + gap)) * 3 + std::size_t(c)] = b;
        img.rgb[(row + std::size_t(x + 2 * (w + gap))) * 3 + std::size_t(c)] = d;
      }
    }
  const std::array<float, 3> ink{0, 0, 0};
  const int ty = h + scale;
  draw_text(img, scale, ty, "DATA", scale, ink);
  draw_text(img, w + gap + scale, ty, "MODEL", scale, ink);
  draw_text(img, 2 * (w + gap) + scale, ty, fmt::format("DIFFERENCE X{:g}", difference_scale),
            scale, ink);
  draw_text(img, scale, ty + line,
            fmt::format("RMSE {:.2f}   PSNR {:.2f} DB   SSIM {:.3f}", metrics.rmse, metrics.psnr,
                        metrics.ssim),
            scale, ink);
  return img;
}

}  // namespace btfgmm
