// The per-pixel set-up of the geometry pass: each stage a function inlined into one loop
// over the pixels, vectorised (compiled with -fno-math-errno -fno-trapping-math, as every
// source of src/render: see CMakeLists.txt).
#include "render/set_up.hpp"

#include <cmath>

namespace btfgmm::detail {
namespace {

// A vertex attribute interpolated at the pixel: at the triangle's corners i0, i1, i2 with
// the barycentric coordinates l0, l1, l2.
[[gnu::always_inline]] inline float interpolate(const float* __restrict v, std::uint32_t i0,
                                                std::uint32_t i1, std::uint32_t i2, float l0,
                                                float l1, float l2) {
  return v[i0] * l0 + v[i1] * l1 + v[i2] * l2;
}

// The unit shading normal n: the interpolated normal, or the face's g where that vanishes.
[[gnu::always_inline]] inline void shading_normal(float& nx, float& ny, float& nz, float gx,
                                                  float gy, float gz) {
  const float nl = std::sqrt(nx * nx + ny * ny + nz * nz);
  const bool nok = nl > 1e-12f;
  const float gl = std::sqrt(gx * gx + gy * gy + gz * gz);
  const float ni = 1.0f / (nok ? nl : (gl > 0.0f ? gl : 1.0f));
  nx = (nok ? nx : gx) * ni;
  ny = (nok ? ny : gy) * ni;
  nz = (nok ? nz : gz) * ni;
}

// The frame's x: the interpolated tangent t along +u made normal to the unit normal n (any
// unit vector normal to n where that vanishes).
[[gnu::always_inline]] inline void frame_tangent(float& tx, float& ty, float& tz, float nx,
                                                 float ny, float nz) {
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
}

// The frame's y, b: normal to n and t, on the side of +v, the interpolated bitangent (given
// in b; a mirrored UV layout gives a mirrored, still consistent, frame).
[[gnu::always_inline]] inline void frame_bitangent(float& bx, float& by, float& bz, float nx,
                                                   float ny, float nz, float tx, float ty,
                                                   float tz) {
  const float cx = ny * tz - nz * ty, cy = nz * tx - nx * tz, cz = nx * ty - ny * tx;
  const float bs = cx * bx + cy * by + cz * bz < 0.0f ? -1.0f : 1.0f;
  bx = cx * bs;
  by = cy * bs;
  bz = cz * bs;
}

// v: the unit direction from the point (given in v) toward the eye e.
[[gnu::always_inline]] inline void toward_eye(float& vx, float& vy, float& vz, float ex, float ey,
                                              float ez) {
  vx = ex - vx;
  vy = ey - vy;
  vz = ez - vz;
  const float vl = std::sqrt(vx * vx + vy * vy + vz * vz);
  const float vi = 1.0f / (vl > 0.0f ? vl : 1.0f);
  vx *= vi;
  vy *= vi;
  vz *= vi;
}

// Seen from behind (an open surface such as the cloth), the back side shows the material
// too: the normal n turns toward the viewer v (g the face normal).
[[gnu::always_inline]] inline void face_viewer(float& nx, float& ny, float& nz, float gx, float gy,
                                               float gz, float vx, float vy, float vz) {
  const bool flip = (gx * nx + gy * ny + gz * nz < 0.0f) != (gx * vx + gy * vy + gz * vz < 0.0f);
  const float ns = flip ? -1.0f : 1.0f;
  nx *= ns;
  ny *= ns;
  nz *= ns;
}

// The light at the point p: l the unit direction toward it; returns the irradiance. A point
// light falls off with the squared distance; where it is at the point, the point is unlit
// (n the normal).
[[gnu::always_inline]] inline float light_at(const SetUpLight& light, float px, float py, float pz,
                                             float nx, float ny, float nz, float& lx, float& ly,
                                             float& lz) {
  const float dx = light.position.x - px, dy = light.position.y - py, dz = light.position.z - pz;
  const float d2 = dx * dx + dy * dy + dz * dz;
  const bool at_light = !(d2 > 0.0f);
  const float di = 1.0f / std::sqrt(at_light ? 1.0f : d2);
  const bool point = light.point;
  lx = point ? (at_light ? nx : dx * di) : light.direction.x;
  ly = point ? (at_light ? ny : dy * di) : light.direction.y;
  lz = point ? (at_light ? nz : dz * di) : light.direction.z;
  return point ? (at_light ? 0.0f : light.intensity / (at_light ? 1.0f : d2)) : light.intensity;
}

// The component of the direction a along the frame's axis e.
[[gnu::always_inline]] inline float along(float ax, float ay, float az, float ex, float ey,
                                          float ez) {
  return ax * ex + ay * ey + az * ez;
}

// A shading normal may turn slightly away from the eye at a silhouette: the view v (local
// frame) is taken on the horizon there.
[[gnu::always_inline]] inline void view_above_horizon(float& v0, float& v1, float& v2) {
  const float hl = std::sqrt(v0 * v0 + v1 * v1);
  const bool below = v2 < 0.0f, flat = !(hl > 0.0f);
  const float hi = flat ? 0.0f : 1.0f / (flat ? 1.0f : hl);
  v0 = below ? v0 * hi : v0;
  v1 = below ? v1 * hi : v1;
  v2 = below ? (flat ? 1.0f : 0.0f) : v2;
}

// A texture coordinate in tile pixels wrapped into the tile's [0, size).
[[gnu::always_inline]] inline float wrap_into_tile(float u, float size) {
  const float s = u - size * std::floor(u / size);
  return s < 0.0f || s >= size ? 0.0f : s;
}

}  // namespace

void set_up_pixels(const SetUpScene& s, const std::int32_t* __restrict tri,
                   const float* __restrict b0, const float* __restrict b1, std::size_t n,
                   std::array<std::vector<float>, kResults>& res, std::uint8_t* __restrict st) {
  const std::uint32_t* __restrict cn = s.corner;
  const float* __restrict fc = s.face;
  const float* __restrict a_px = s.attr[kPx];
  const float* __restrict a_py = s.attr[kPy];
  const float* __restrict a_pz = s.attr[kPz];
  const float* __restrict a_nx = s.attr[kNx];
  const float* __restrict a_ny = s.attr[kNy];
  const float* __restrict a_nz = s.attr[kNz];
  const float* __restrict a_tx = s.attr[kTx];
  const float* __restrict a_ty = s.attr[kTy];
  const float* __restrict a_tz = s.attr[kTz];
  const float* __restrict a_bx = s.attr[kBx];
  const float* __restrict a_by = s.attr[kBy];
  const float* __restrict a_bz = s.attr[kBz];
  const float* __restrict a_u = s.attr[kU];
  const float* __restrict a_v = s.attr[kV];
  float* __restrict r_x = res[kResX].data();
  float* __restrict r_y = res[kResY].data();
  float* __restrict r_l0 = res[kResL0].data();
  float* __restrict r_l1 = res[kResL1].data();
  float* __restrict r_l2 = res[kResL2].data();
  float* __restrict r_v0 = res[kResV0].data();
  float* __restrict r_v1 = res[kResV1].data();
  float* __restrict r_v2 = res[kResV2].data();
  float* __restrict r_irr = res[kResIrr].data();
  const SetUpLight lighting = s.light;
  const float ex = s.eye.x, ey = s.eye.y, ez = s.eye.z;
  const float texel = s.texel, tw = s.tw, th = s.th;
#pragma omp simd
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t t = std::size_t(tri[k]);
    const std::uint32_t i0 = cn[3 * t], i1 = cn[3 * t + 1], i2 = cn[3 * t + 2];
    const float l0 = b0[k], l1 = b1[k], l2 = 1.0f - l0 - l1;
    const float px = interpolate(a_px, i0, i1, i2, l0, l1, l2),
                py = interpolate(a_py, i0, i1, i2, l0, l1, l2),
                pz = interpolate(a_pz, i0, i1, i2, l0, l1, l2);
    const float gx = fc[3 * t], gy = fc[3 * t + 1], gz = fc[3 * t + 2];  // the face normal
    // The frame: x, y, z = t, b, n.
    float nx = interpolate(a_nx, i0, i1, i2, l0, l1, l2),
          ny = interpolate(a_ny, i0, i1, i2, l0, l1, l2),
          nz = interpolate(a_nz, i0, i1, i2, l0, l1, l2);
    shading_normal(nx, ny, nz, gx, gy, gz);
    float tx = interpolate(a_tx, i0, i1, i2, l0, l1, l2),
          ty = interpolate(a_ty, i0, i1, i2, l0, l1, l2),
          tz = interpolate(a_tz, i0, i1, i2, l0, l1, l2);
    frame_tangent(tx, ty, tz, nx, ny, nz);
    float bx = interpolate(a_bx, i0, i1, i2, l0, l1, l2),
          by = interpolate(a_by, i0, i1, i2, l0, l1, l2),
          bz = interpolate(a_bz, i0, i1, i2, l0, l1, l2);
    frame_bitangent(bx, by, bz, nx, ny, nz, tx, ty, tz);
    float vx = px, vy = py, vz = pz;
    toward_eye(vx, vy, vz, ex, ey, ez);
    face_viewer(nx, ny, nz, gx, gy, gz, vx, vy, vz);
    float lx, ly, lz;
    const float irradiance = light_at(lighting, px, py, pz, nx, ny, nz, lx, ly, lz);
    // In the dark: the light is below this point's horizon.
    const float fl2 = along(lx, ly, lz, nx, ny, nz);
    st[k] = !(fl2 > 0.0f) || !(irradiance > 0.0f) ? 1 : 2;
    float fv0 = along(vx, vy, vz, tx, ty, tz), fv1 = along(vx, vy, vz, bx, by, bz),
          fv2 = along(vx, vy, vz, nx, ny, nz);
    view_above_horizon(fv0, fv1, fv2);
    // The texture coordinate in tile pixels, wrapped into the tile.
    r_x[k] = wrap_into_tile(interpolate(a_u, i0, i1, i2, l0, l1, l2) * texel, tw);
    r_y[k] = wrap_into_tile(interpolate(a_v, i0, i1, i2, l0, l1, l2) * texel, th);
    r_l0[k] = along(lx, ly, lz, tx, ty, tz);
    r_l1[k] = along(lx, ly, lz, bx, by, bz);
    r_l2[k] = fl2;
    r_v0[k] = fv0;
    r_v1[k] = fv1;
    r_v2[k] = fv2;
    r_irr[k] = irradiance;
  }
}

}  // namespace btfgmm::detail
