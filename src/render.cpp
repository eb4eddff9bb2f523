// The renderer's geometry pass (rasterisation, tangent frames, light and view directions in
// the local frame), composing images, the comparison metrics and figure of Fig. 3.
#include "btfgmm/render.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "btfgmm/error.hpp"
#include "btfgmm/metrics.hpp"

#include "vec3_ops.hpp"

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

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

float wrap_coordinate(double v, int period) {
  const double r = v - double(period) * std::floor(v / double(period));
  float f = float(r);
  if (f < 0.0f) f = 0.0f;
  return f >= float(period) ? 0.0f : f;
}

// A vertex in camera space and on the screen.
struct Projected {
  double sx = 0, sy = 0;  // screen position, pixels (y down)
  double depth = 0;       // distance along the view axis
};

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

  // The visibility buffer: triangle and perspective-correct barycentric coordinates.
  const std::size_t npix = std::size_t(W) * std::size_t(H);
  std::vector<std::int32_t> tri_of(npix, -1);
  std::vector<std::array<double, 2>> bary(npix);
#pragma omp parallel
  {
    std::vector<double> inv_depth(std::size_t(kBand) * std::size_t(W));
#pragma omp for schedule(dynamic, 1)
    for (int band = 0; band < bands; ++band) {
      const int y0 = band * kBand, y1 = std::min(H, y0 + kBand);
      std::fill(inv_depth.begin(), inv_depth.end(), 0.0);
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
        for (int y = ya; y <= yb; ++y) {
          const double py = y + 0.5;
          for (int x = xa; x <= xb; ++x) {
            const double px = x + 0.5;
            // Screen-space barycentric coordinates; either winding (the mesh is two-sided).
            // (The numerators are exact functions of an edge's two ends, so a pixel on an edge
            // gets the same, zero, weight from both of its triangles.)
            const double wa = ((b.sx - px) * (c.sy - py) - (b.sy - py) * (c.sx - px)) * inv_area;
            const double wb = ((c.sx - px) * (a.sy - py) - (c.sy - py) * (a.sx - px)) * inv_area;
            const double wc = ((a.sx - px) * (b.sy - py) - (a.sy - py) * (b.sx - px)) * inv_area;
            if (wa < 0 || wb < 0 || wc < 0) continue;  // edges shared: no holes between
            const double iz = (wa * ia + wb * ib + wc * ic) / (wa + wb + wc);
            double& zb = inv_depth[std::size_t(y - y0) * std::size_t(W) + std::size_t(x)];
            if (iz <= zb) continue;  // 1/depth: larger is nearer
            zb = iz;
            const std::size_t p = std::size_t(y) * std::size_t(W) + std::size_t(x);
            tri_of[p] = std::int32_t(t);
            const double norm = 1.0 / (wa * ia + wb * ib + wc * ic);
            bary[p] = {wa * ia * norm, wb * ib * norm};
          }
        }
      }
    }
  }

  // Per pixel: the surface point, its frame, and the light and view in that frame; 0 the
  // background, 1 in the dark, 2 lit (`s` set).
  const double texel = settings.repeat * tile_width;  // tile pixels per unit of u and v
  const Vec3 light_dir = normalized(light.direction);
  // The vertex attributes side by side, and each triangle's (unnormalised) face normal.
  struct Attributes {
    Vec3 position, normal, tangent, bitangent;
    double u, v;
  };
  std::vector<Attributes> va(m.position.size());
  for (std::size_t i = 0; i < va.size(); ++i)
    va[i] = {m.position[i], m.normal[i], m.tangent[i], m.bitangent[i], m.uv[i][0], m.uv[i][1]};
  std::vector<Vec3> face(m.triangles.size());
  for (std::size_t t = 0; t < face.size(); ++t) {
    const auto& tri = m.triangles[t];
    face[t] =
        cross(m.position[tri[1]] - m.position[tri[0]], m.position[tri[2]] - m.position[tri[0]]);
  }
  auto setup = [&](std::size_t p, SurfacePoint& s) -> std::uint8_t {
    if (tri_of[p] < 0) return 0;
    const auto& tri = m.triangles[std::size_t(tri_of[p])];
    const double l0 = bary[p][0], l1 = bary[p][1], l2 = 1.0 - l0 - l1;
    const Attributes &a0 = va[tri[0]], &a1 = va[tri[1]], &a2 = va[tri[2]];
    auto lerp = [&](Vec3 Attributes::*f) { return a0.*f * l0 + a1.*f * l1 + a2.*f * l2; };
    const Vec3 pos = lerp(&Attributes::position);
    const Vec3& geo = face[std::size_t(tri_of[p])];
    Vec3 nrm = lerp(&Attributes::normal);
    const double nl = length(nrm);
    nrm = nl > 1e-12 ? nrm * (1.0 / nl) : normalized(geo);
    // The frame: tangent along +u made normal to the normal; bitangent normal to both, on
    // the side of +v (a mirrored UV layout gives a mirrored, still consistent, frame).
    Vec3 tan = lerp(&Attributes::tangent);
    tan = tan - nrm * dot(tan, nrm);
    const double tl = length(tan);
    tan = tl > 1e-12 ? tan * (1.0 / tl) : any_perpendicular(nrm);
    Vec3 bit = cross(nrm, tan);
    if (dot(bit, lerp(&Attributes::bitangent)) < 0) bit = bit * -1.0;
    // Seen from behind (an open surface such as the cloth), the back side shows the material
    // too: the normal turns toward the viewer.
    const Vec3 to_eye = normalized(camera.eye - pos);
    if ((dot(geo, nrm) < 0) != (dot(geo, to_eye) < 0)) nrm = nrm * -1.0;
    Vec3 to_light = light_dir;
    double irradiance = light.intensity;
    if (light.kind == Light::Kind::kPoint) {
      const Vec3 d = light.position - pos;
      const double d2 = dot(d, d);
      to_light = d2 > 0 ? d * (1.0 / std::sqrt(d2)) : nrm;
      irradiance = d2 > 0 ? light.intensity / d2 : 0.0;
    }
    const Vec3 l{dot(to_light, tan), dot(to_light, bit), dot(to_light, nrm)};
    // In the dark: the light is below this point's horizon.
    if (!(l.z > 0.0) || !(irradiance > 0.0)) return 1;
    Vec3 v{dot(to_eye, tan), dot(to_eye, bit), dot(to_eye, nrm)};
    // A shading normal may turn slightly away from the eye at a silhouette: the view is taken
    // on the horizon there.
    if (v.z < 0.0) {
      v = normalized(Vec3{v.x, v.y, 0.0});
      if (!(length(v) > 0.5)) v = {0, 0, 1};
    }
    const double u = a0.u * l0 + a1.u * l1 + a2.u * l2;
    const double w = a0.v * l0 + a1.v * l1 + a2.v * l2;
    s.x = wrap_coordinate(u * texel, tile_width);
    s.y = wrap_coordinate(w * texel, tile_height);
    s.light = {float(l.x), float(l.y), float(l.z)};  // a unit vector in an orthonormal frame
    s.view = {float(v.x), float(v.y), float(v.z)};
    s.irradiance = float(irradiance);
    return 2;
  };

  // Screen blocks of B x B pixels, in parallel: each block's lit points in a slot of its
  // own, then packed in block order (the model evaluator bounds the model over a block).
  constexpr int B = SurfaceBuffer::kBlockSize;
  const int bw = (W + B - 1) / B, bh = (H + B - 1) / B;
  const std::size_t nblocks = std::size_t(bw) * std::size_t(bh), slot = std::size_t(B) * B;
  SurfaceBuffer out;
  out.width = W;
  out.height = H;
  out.coverage.assign(npix, 0);
  std::vector<SurfacePoint> staged(nblocks * slot);
  std::vector<std::uint32_t> staged_pixel(nblocks * slot), count(nblocks, 0);
#pragma omp parallel for schedule(dynamic, 4)
  for (std::ptrdiff_t bi = 0; bi < std::ptrdiff_t(nblocks); ++bi) {
    const int bx = int(bi % bw) * B, by = int(bi / bw) * B;
    std::uint32_t k = 0;
    const std::size_t base = std::size_t(bi) * slot;
    for (int y = by; y < std::min(H, by + B); ++y)
      for (int x = bx; x < std::min(W, bx + B); ++x) {
        const std::size_t p = std::size_t(y) * std::size_t(W) + std::size_t(x);
        out.coverage[p] = setup(p, staged[base + k]);
        if (out.coverage[p] == 2) staged_pixel[base + k++] = std::uint32_t(p);
      }
    count[std::size_t(bi)] = k;
  }
  std::vector<std::size_t> offset(nblocks + 1, 0);
  for (std::size_t b = 0; b < nblocks; ++b) {
    offset[b + 1] = offset[b] + count[b];
    if (count[b]) out.block_start.push_back(std::uint32_t(offset[b]));
  }
  out.block_start.push_back(std::uint32_t(offset[nblocks]));
  out.points.resize(offset[nblocks]);
  out.pixel.resize(offset[nblocks]);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t bi = 0; bi < std::ptrdiff_t(nblocks); ++bi) {
    const std::size_t b = std::size_t(bi);
    std::copy_n(&staged[b * slot], count[b], &out.points[offset[b]]);
    std::copy_n(&staged_pixel[b * slot], count[b], &out.pixel[offset[b]]);
  }
  out.seconds = since(t0);
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
  for (std::size_t p = 0; p < npix; ++p) {
    r.object[p] = s.coverage[p] != 0;
    for (int c = 0; c < 3; ++c)
      r.rgb[p * 3 + std::size_t(c)] =
          s.coverage[p] == 0 ? settings.background[std::size_t(c)] : 0.0f;
  }
  const double scale = std::exp2(settings.exposure);
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    const std::size_t p = s.pixel[i];
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
