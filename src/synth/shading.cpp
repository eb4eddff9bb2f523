// Light transport of the synthetic BTF: steps 3 to 5 of the pipeline in generate.cpp.
// Self-shadowing by marching from the surface toward the light (Max 1988), masking and
// parallax by marching the camera rays through the height field (relief mapping, Policarpo et
// al. 2005), and the reflectance of the points seen: Lambert diffuse plus a GGX microfacet
// lobe (Walter et al. 2007) with the Smith-Schlick masking term and Schlick's Fresnel.
#include "synth/shading.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "btfgmm/core/directions.hpp"
#include "core/vec3_ops.hpp"
#include "synth/surface.hpp"

namespace btfgmm::detail::synth {
namespace {

// 3. Visibility of the light from the surface: marched from every point of a grid
// (fs points per pixel side) toward the light. The soft variant keeps the smallest clearance
// angle above the height field along the ray, relative to the angular radius of the light,
// so shadows get a penumbra (a light of ~4 degrees) instead of a hard aliased edge.
// Fills row j of the visibility map of light l (fs * size values).
void shadow_row(const Surface& s, const Vec3& l, int fs, int j, float* row) {
  const int ns = fs * s.size;
  const double sin_t = std::hypot(l.x, l.y);
  if (sin_t < 1e-6 || l.z <= 0.0) {  // overhead: nothing casts a shadow; below: all dark
    std::fill(row, row + ns, l.z <= 0.0 ? 0.0f : 1.0f);
    return;
  }
  const double dx = l.x / sin_t, dy = l.y / sin_t;  // horizontal unit direction
  // Height gained per pixel travelled; a light at the horizon is marched as if at 89 degrees.
  const double rise = std::max(l.z / sin_t, 0.02);
  constexpr double kLightRadius = 0.07;                      // radians
  constexpr double kStep = 0.25, kBias = 0.03;               // pixels
  const double gain = sin_t * sin_t / (2.0 * kLightRadius);  // d(elevation)/d(slope)
  const double inv_fs = 1.0 / fs;
  const double y = j * inv_fs;
  for (int i = 0; i < ns; ++i) {
    const double x = i * inv_fs;
    const double h0 = s.h(x, y) + kBias;
    const double reach = (double(s.h_max) - h0) / rise;  // above the highest peak beyond
    double v = 1.0;
    for (double d = kStep; d <= reach + kStep; d += kStep) {
      const double clearance = h0 + d * rise - s.h(x + d * dx, y + d * dy);
      v = std::min(v, 0.5 + gain * clearance / d);
      if (v <= 0.0) break;
    }
    row[i] = float(std::clamp(v, 0.0, 1.0));
  }
}

// 4. The camera ray through (x, y, 0) along v, marched from z = h_max down to z = h_min; the
// first sample below the surface is refined by bisection. Returns the (x, y) of the hit.
std::array<double, 2> trace(const Surface& s, double x, double y, const Vec3& v) {
  const double vz = std::max(v.z, 0.01);  // views at the horizon: a very long, finite march
  const double t_top = (double(s.h_max) + 1e-3) / vz;
  const double t_bottom = (double(s.h_min) - 1e-3) / vz;
  constexpr double kStep = 0.25;  // pixels along the ray
  double t_above = t_top, t_below = t_bottom;
  for (double t = t_top - kStep;; t -= kStep) {
    if (t < t_bottom) t = t_bottom;
    if (t * vz <= s.h(x + t * v.x, y + t * v.y)) {
      t_below = t;
      break;
    }
    t_above = t;
    if (t == t_bottom) break;  // numerically never reached: h >= h_min everywhere
  }
  for (int it = 0; it < 10; ++it) {
    const double t = 0.5 * (t_above + t_below);
    if (t * vz <= s.h(x + t * v.x, y + t * v.y))
      t_below = t;
    else
      t_above = t;
  }
  const double t = 0.5 * (t_above + t_below);
  return {x + t * v.x, y + t * v.y};
}

// The half vector of a light and a view direction and Schlick's Fresnel term for it: they
// depend only on the direction pair.
struct PairTerms {
  float hx, hy, hz;  // unit half vector
  float fr, fg, fb;  // Fresnel reflectance per channel
};

PairTerms pair_terms(const Vec3& l, const Vec3& v, const std::array<float, 3>& f0) {
  Vec3 h = l + v;
  const double hl = length(h);
  if (hl > 1e-12)
    h = {h.x / hl, h.y / hl, h.z / hl};
  else
    h = {0.0, 0.0, 1.0};
  const double vdh = std::clamp(dot(v, h), 0.0, 1.0);
  const auto schlick = float(std::pow(1.0 - vdh, 5.0));
  return {.hx = float(h.x),
          .hy = float(h.y),
          .hz = float(h.z),
          .fr = f0[0] + (1.0f - f0[0]) * schlick,
          .fg = f0[1] + (1.0f - f0[1]) * schlick,
          .fb = f0[2] + (1.0f - f0[2]) * schlick};
}

}  // namespace

Reflectance reflectance(const Surface& s) {
  const auto alpha = float(s.roughness);
  return {alpha * alpha, alpha * 0.5f, {float(s.f0.r), float(s.f0.g), float(s.f0.b)}};
}

std::vector<std::vector<float>> visibility_maps(const Surface& s, const std::vector<Vec3>& lights,
                                                int fs) {
  const int ns = fs * s.size;
  const std::size_t nl = lights.size();
  std::vector<std::vector<float>> shadows(nl);
  for (auto& m : shadows) m.resize(std::size_t(ns) * std::size_t(ns));
#pragma omp parallel for schedule(dynamic, 4)
  for (std::ptrdiff_t task = 0; task < std::ptrdiff_t(nl) * ns; ++task) {
    const auto li = std::size_t(task / ns);
    const int j = int(task % ns);
    shadow_row(s, lights[li], fs, j, shadows[li].data() + std::size_t(j) * std::size_t(ns));
  }
  return shadows;
}

void trace_band(const Surface& s, const Reflectance& refl, const Vec3& v, int y0, int y1, int ss,
                int fs, ViewRays& rays) {
  const int size = s.size;
  const int ns = fs * size;
  const std::size_t rays_per_pixel = std::size_t(ss) * std::size_t(ss);
  const float k_smith = refl.k_smith;
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < size; ++x)
      for (int sy = 0; sy < ss; ++sy)
        for (int sx = 0; sx < ss; ++sx) {
          const double px = x + (sx + 0.5) / ss, py = y + (sy + 0.5) / ss;
          const auto [hx, hy] = trace(s, px, py, v);
          const Lerp at = locate(hx, hy, s.n, s.f);
          const auto n3 = at.rgb(s.normal.data());
          const float len = std::sqrt(n3[0] * n3[0] + n3[1] * n3[1] + n3[2] * n3[2]);
          const float nx = n3[0] / len, ny = n3[1] / len, nz = n3[2] / len;
          const auto a3 = at.rgb(s.albedo.data());
          const std::size_t k =
              (std::size_t(y - y0) * std::size_t(size) + std::size_t(x)) * rays_per_pixel +
              std::size_t(sy) * std::size_t(ss) + std::size_t(sx);
          rays.nx[k] = nx;
          rays.ny[k] = ny;
          rays.nz[k] = nz;
          rays.r[k] = a3[0];
          rays.g[k] = a3[1];
          rays.b[k] = a3[2];
          rays.ambient[k] = kAmbient * at(s.access.data());
          const float ndv = std::max(float(nx * v.x + ny * v.y + nz * v.z), 1e-3f);
          const float g1v = ndv / (ndv * (1.0f - k_smith) + k_smith);
          rays.spec_view[k] = at(s.gloss.data()) * g1v / (4.0f * ndv);
          const Lerp sh = locate(hx, hy, ns, fs);
          rays.wx[k] = sh.wx;
          rays.wy[k] = sh.wy;
          rays.i00[k] = sh.i00;
          rays.i10[k] = sh.i10;
          rays.i01[k] = sh.i01;
          rays.i11[k] = sh.i11;
        }
}

void shade_rays(const Reflectance& refl, const Vec3& l, const Vec3& v, const float* vis_map,
                std::size_t count, ViewRays& rays) {
  const float alpha2 = refl.alpha2, k_smith = refl.k_smith;
  const PairTerms pair = pair_terms(l, v, refl.f0);
  const float fr = pair.fr, fg = pair.fg, fb = pair.fb;
  const auto lx = float(l.x), ly = float(l.y), lz = float(l.z);
  const float hxf = pair.hx, hyf = pair.hy, hzf = pair.hz;

  // Step 5 for every ray, without branches: a point facing away from the light gets
  // n.l = 0, hence no diffuse and (G1(l) = 0) no specular light.
  for (std::size_t k = 0; k < count; ++k) {
    const float ndl = std::max(rays.nx[k] * lx + rays.ny[k] * ly + rays.nz[k] * lz, 0.0f);
    const float va =
        vis_map[rays.i00[k]] + (vis_map[rays.i10[k]] - vis_map[rays.i00[k]]) * rays.wx[k];
    const float vb =
        vis_map[rays.i01[k]] + (vis_map[rays.i11[k]] - vis_map[rays.i01[k]]) * rays.wx[k];
    const float vis = va + (vb - va) * rays.wy[k];
    const float ndh = std::max(rays.nx[k] * hxf + rays.ny[k] * hyf + rays.nz[k] * hzf, 0.0f);
    const float dd = ndh * ndh * (alpha2 - 1.0f) + 1.0f;
    const float d_pi = alpha2 / (dd * dd);  // pi * GGX D
    const float g1l = ndl / (ndl * (1.0f - k_smith) + k_smith);
    // pi * D G F / (4 n.l n.v) * n.l, without F (per channel below).
    const float spec = vis * d_pi * g1l * rays.spec_view[k];
    const float diffuse = vis * ndl + rays.ambient[k];
    rays.red[k] = rays.r[k] * diffuse + spec * fr;
    rays.green[k] = rays.g[k] * diffuse + spec * fg;
    rays.blue[k] = rays.b[k] * diffuse + spec * fb;
  }
}

}  // namespace btfgmm::detail::synth
