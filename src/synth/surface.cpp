// The surface of the synthetic BTF: steps 1 and 2 of the pipeline in generate.cpp. The
// material is evaluated on a periodic grid finer than the pixels; its heights are moved to a
// reference plane z = 0 at their mean; normals come from the height gradient and an ambient
// accessibility from horizon angles (horizon-based ambient occlusion; Max 1988, "Horizon
// mapping"; Bavoil et al. 2008).
#include "synth/surface.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "synth/materials.hpp"
#include "synth/noise.hpp"

namespace btfgmm::detail::synth {
namespace {

// 1. The procedural height, albedo and gloss at every grid point.
void sample_material(const MaterialModel& m, Surface& s) {
  const int n = s.n;
  const double inv_f = 1.0 / s.f;
#pragma omp parallel for schedule(dynamic, 4)
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Point p = m.at(i * inv_f, j * inv_f);
      const std::size_t k = std::size_t(j) * std::size_t(n) + std::size_t(i);
      s.height[k] = float(p.height);
      s.albedo[3 * k + 0] = float(std::clamp(p.albedo.r, 0.0, 1.0));
      s.albedo[3 * k + 1] = float(std::clamp(p.albedo.g, 0.0, 1.0));
      s.albedo[3 * k + 2] = float(std::clamp(p.albedo.b, 0.0, 1.0));
      s.gloss[k] = float(std::clamp(p.gloss, 0.0, 1.0));
    }
}

// The reference plane z = 0 is the mean surface height; a height_range > 0 fixes the relief
// depth (peak to peak).
void set_reference_plane(double height_range, Surface& s) {
  const std::size_t count = s.height.size();
  double sum = 0.0, lo = 1e30, hi = -1e30;
  for (float v : s.height) {
    sum += v;
    lo = std::min(lo, double(v));
    hi = std::max(hi, double(v));
  }
  const double mean = sum / double(count);
  const double scale = height_range > 0.0 && hi > lo ? height_range / (hi - lo) : 1.0;
  for (float& v : s.height) v = float((v - mean) * scale);
  s.h_min = float((lo - mean) * scale);
  s.h_max = float((hi - mean) * scale);
}

// 2. Normals from the gradient of the height field (central differences, pixel units).
void compute_normals(Surface& s) {
  const int n = s.n;
  const auto at = [&](int i, int j) {
    return s.height[std::size_t(wrap_index(j, n)) * std::size_t(n) + std::size_t(wrap_index(i, n))];
  };
#pragma omp parallel for schedule(static)
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double dx = (at(i + 1, j) - at(i - 1, j)) * 0.5 * s.f;
      const double dy = (at(i, j + 1) - at(i, j - 1)) * 0.5 * s.f;
      const double len = std::sqrt(dx * dx + dy * dy + 1.0);
      const std::size_t k = std::size_t(j) * std::size_t(n) + std::size_t(i);
      s.normal[3 * k + 0] = float(-dx / len);
      s.normal[3 * k + 1] = float(-dy / len);
      s.normal[3 * k + 2] = float(1.0 / len);
    }
}

// 2b. Ambient accessibility: the fraction of a uniform sky a point sees, cos^2 of the
// horizon elevation averaged over 8 azimuths (horizon-based ambient occlusion).
void compute_accessibility(Surface& s) {
  const int n = s.n;
  const double inv_f = 1.0 / s.f;
  constexpr int kAzimuths = 8;
  constexpr double kReach = 4.0, kStep = 0.5;  // pixels
#pragma omp parallel for schedule(static)
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = i * inv_f, y = j * inv_f;
      const double h0 = s.height[std::size_t(j) * std::size_t(n) + std::size_t(i)];
      double open = 0.0;
      for (int a = 0; a < kAzimuths; ++a) {
        const double phi = 2.0 * kPi * a / kAzimuths;
        const double cx = std::cos(phi), cy = std::sin(phi);
        double slope = 0.0;
        for (double d = kStep; d <= kReach; d += kStep)
          slope = std::max(slope, (s.h(x + d * cx, y + d * cy) - h0) / d);
        open += 1.0 / (1.0 + slope * slope);  // cos^2 of the horizon elevation
      }
      s.access[std::size_t(j) * std::size_t(n) + std::size_t(i)] = float(open / kAzimuths);
    }
}

}  // namespace

Surface build_surface(const MaterialModel& m, int size) {
  Surface s;
  s.size = size;
  s.f = size <= 256 ? 4 : size <= 512 ? 2 : 1;
  s.n = s.f * size;
  s.roughness = m.roughness;
  s.f0 = m.f0;
  const std::size_t count = std::size_t(s.n) * std::size_t(s.n);
  s.height.resize(count);
  s.albedo.resize(3 * count);
  s.gloss.resize(count);
  s.normal.resize(3 * count);
  s.access.resize(count);
  sample_material(m, s);
  set_reference_plane(m.height_range, s);
  compute_normals(s);
  compute_accessibility(s);
  return s;
}

}  // namespace btfgmm::detail::synth
