// A synthetic BTF: a procedural rough material rendered for any light and view direction sets
// (include/btfgmm/generate.hpp). It is the built-in example and the test data of the project,
// so it reproduces what a measured BTF (Dana et al. 1999; Bonn UBO2003, UTIA) shows: images
// that change with light and view through shadows, highlights, masking and parallax.
//
// The pipeline, step by step:
//  1. A periodic height field h(x, y) in pixel units (the whole image repeats seamlessly), a
//     spatially varying albedo and a specular weight, evaluated procedurally on a grid finer
//     than the pixels (f grid points per pixel side) and sampled bilinearly with wrap.
//  2. Normals from the height-field gradient (central differences) and an ambient
//     accessibility term from horizon angles (horizon-based ambient occlusion; Max 1988,
//     "Horizon mapping"; Bavoil et al. 2008).
//  3. Self-shadowing: for every light, a visibility map made by marching from the surface
//     toward the light through the height field (Max 1988; the soft-shadow variant takes the
//     smallest clearance angle along the ray, approximating an area light of a few degrees).
//  4. Masking and parallax: every camera ray p(t) = (x, y, 0) + t v through a pixel of the
//     reference plane z = 0 (a rectified BTF image) is marched from the top of the height
//     field down to its bottom; the first point below the surface, refined by bisection, is
//     the point seen (relief mapping, Policarpo et al. 2005).
//  5. Reflectance: Lambert diffuse plus a GGX microfacet lobe (Walter et al. 2007) with the
//     Smith-Schlick masking term and Schlick's Fresnel, times the clamped cosine n.l
//     (foreshortening of the incident light) and the visibility; a small ambient term lets
//     shadowed parts stay slightly visible.
//  6. Supersampling: config.supersample^2 stratified rays per pixel, averaged in linear
//     radiance; then an sRGB encode to 8-bit levels (LDR), or the linear radiance (HDR).
//
// Coordinates: x is the image column, y the image row, z points out of the surface toward the
// viewer; a direction's azimuth phi is measured from +x toward +y (to_vector()), so a light at
// phi = 0 shines from the right-hand side (larger x) of the image.
//
// Determinism: every random number comes from splitmix64 (Steele, Lea & Flood 2014) seeded by
// config.seed, and every output value is computed by one thread from inputs that do not depend
// on the schedule, so the result is the same for any number of OpenMP threads.
#include "btfgmm/synth/generate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"

namespace btfgmm {
namespace {

constexpr double kPi = std::numbers::pi;

// ---- Random numbers -------------------------------------------------------------------------

// The splitmix64 output function: a bijective 64-bit mix (Steele, Lea & Flood 2014).
constexpr std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// splitmix64 generator: sequential random numbers (bump placement, per-wale jitter, phases).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ULL;
    return mix64(state_);
  }
  // Uniform in [0, 1) from the top 53 bits.
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

 private:
  std::uint64_t state_;
};

// A stateless hash of integer lattice coordinates to [0, 1): the random values of the noise
// lattices and of per-cell jitter, independent of evaluation order.
double hash01(std::uint64_t key, std::int64_t i, std::int64_t j, std::uint64_t salt = 0) {
  std::uint64_t z = mix64(key ^ (std::uint64_t(i) * 0x9E3779B97F4A7C15ULL));
  z = mix64(z ^ (std::uint64_t(j) * 0xC2B2AE3D27D4EB4FULL) ^ salt);
  return double(z >> 11) * 0x1.0p-53;
}

// The key of one noise field or jitter table of a material: derived from the user's seed.
std::uint64_t sub_key(std::uint64_t seed, std::uint64_t what) {
  return mix64(mix64(seed + 0x632BE59BD9B4E019ULL) ^ mix64(what));
}

int wrap_index(std::int64_t i, int n) {
  const auto r = int(i % n);
  return r < 0 ? r + n : r;
}

// How many repeats of a pattern with the target period fit across `size` pixels: the period
// actually used is size / repeats, so the pattern tiles the image exactly.
int repeats(int size, double target_period) {
  return std::max(1, int(std::lround(double(size) / target_period)));
}

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

// Periodic value noise (Perlin 1985 style lattice noise, quintic fade): a lattice of
// cells_x x cells_y random values in [-1, 1] spread over size x size pixels with wrap, so the
// noise tiles the image.
class TileNoise {
 public:
  TileNoise(std::uint64_t key, int size, int cells_x, int cells_y)
      : key_(key),
        cx_(std::max(1, cells_x)),
        cy_(std::max(1, cells_y)),
        sx_(double(cx_) / size),
        sy_(double(cy_) / size) {}

  double operator()(double x, double y) const {
    const double gx = x * sx_, gy = y * sy_;
    const double fx0 = std::floor(gx), fy0 = std::floor(gy);
    const double tx = fade(gx - fx0), ty = fade(gy - fy0);
    const auto ix = std::int64_t(fx0), iy = std::int64_t(fy0);
    const int x0 = wrap_index(ix, cx_), x1 = wrap_index(ix + 1, cx_);
    const int y0 = wrap_index(iy, cy_), y1 = wrap_index(iy + 1, cy_);
    const double v00 = value(x0, y0), v10 = value(x1, y0);
    const double v01 = value(x0, y1), v11 = value(x1, y1);
    const double a = v00 + (v10 - v00) * tx, b = v01 + (v11 - v01) * tx;
    return a + (b - a) * ty;
  }

 private:
  static double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
  double value(int i, int j) const { return 2.0 * hash01(key_, i, j) - 1.0; }

  std::uint64_t key_;
  int cx_, cy_;
  double sx_, sy_;
};

// ---- The surface ----------------------------------------------------------------------------

struct Rgb {
  double r = 0.0, g = 0.0, b = 0.0;
};

// What a material's procedural description gives at one point.
struct Point {
  double height = 0.0;  // pixels
  Rgb albedo;           // linear diffuse reflectance
  double gloss = 1.0;   // weight of the specular lobe (1 = the material's full f0)
};

// A material: its procedural point function and its reflectance constants.
struct MaterialModel {
  std::function<Point(double x, double y)> at;  // x, y in pixels; periodic in size
  double roughness = 0.5;                       // GGX alpha
  Rgb f0{0.04, 0.04, 0.04};                     // specular reflectance at normal incidence
  double height_range = 0.0;  // > 0: rescale the height field to this peak-to-peak range
};

// Corduroy: parallel wales (ridges) running along y, period size / round(size / 8), each with
// a rounded profile separated by narrow grooves; pile noise; a red-brown albedo whose tone and
// height vary slightly from wale to wale.
MaterialModel corduroy(int size, std::uint64_t seed) {
  Rng rng(sub_key(seed, 1));
  const int wales = repeats(size, 8.0);
  const double period = double(size) / wales;
  const double phase_x = rng.uniform(0.0, size), phase_y = rng.uniform(0.0, size);
  const auto nw = std::size_t(wales);
  std::vector<double> wale_height(nw), wale_tone(nw), wale_red(nw);
  for (int k = 0; k < wales; ++k) {
    wale_height[std::size_t(k)] = rng.uniform(0.9, 1.1);
    wale_tone[std::size_t(k)] = rng.uniform(0.9, 1.1);
    wale_red[std::size_t(k)] = rng.uniform(0.95, 1.05);
  }
  const Rgb base{0.25 * rng.uniform(0.92, 1.08), 0.07 * rng.uniform(0.9, 1.1),
                 0.035 * rng.uniform(0.9, 1.1)};
  const TileNoise pile(sub_key(seed, 2), size, size, std::max(1, size / 3));
  const TileNoise fibre(sub_key(seed, 3), size, 2 * size, 2 * size);
  const TileNoise blotch(sub_key(seed, 4), size, repeats(size, 12.0), repeats(size, 12.0));
  constexpr double kAmplitude = 2.2;  // pixels: wale height above the groove
  constexpr double kHalfWidth = 0.8;  // the wale covers 80 % of the period
  MaterialModel m;
  m.roughness = 0.45;
  m.f0 = {0.035, 0.03, 0.03};
  m.at = [=](double x, double y) {
    const double xs = x + phase_x, ys = y + phase_y;
    const double w = std::floor(xs / period);
    const double u = xs / period - w;
    const auto k = std::size_t(wrap_index(std::int64_t(w), wales));
    const double d = std::abs(u - 0.5) * 2.0;  // 0 on the wale's crest, 1 in the groove
    const double q = d < kHalfWidth ? 1.0 - (d / kHalfWidth) * (d / kHalfWidth) : 0.0;
    const double profile = std::pow(q, 0.6);  // rounded, slightly flat-topped
    const double p = pile(xs, ys), fb = fibre(xs, ys);
    Point pt;
    pt.height = kAmplitude * wale_height[k] * profile + 0.15 * p + 0.05 * fb;
    const double tone =
        wale_tone[k] * (1.0 + 0.10 * p + 0.06 * fb + 0.08 * blotch(xs, ys)) * (0.75 + 0.25 * q);
    pt.albedo = {base.r * tone * wale_red[k], base.g * tone, base.b * tone};
    pt.gloss = 0.5 + 0.5 * profile;
    return pt;
  };
  return m;
}

// Knit (stockinette): columns of V-shaped stitches, each V two slanted yarn legs with a round
// cross-section and a ply twist; a leg rises toward the V's point so that the point of the row
// above lies over the tops of the legs below (the interlaced loops). Wool-coloured, with a
// per-stitch tone jitter and fuzz.
MaterialModel knit(int size, std::uint64_t seed) {
  Rng rng(sub_key(seed, 11));
  const int cols = repeats(size, 10.0), rows = repeats(size, 10.0);
  const double pw = double(size) / cols, ph = double(size) / rows;
  const double phase_x = rng.uniform(0.0, size), phase_y = rng.uniform(0.0, size);
  const Rgb base{0.40 * rng.uniform(0.95, 1.05), 0.33 * rng.uniform(0.95, 1.05),
                 0.22 * rng.uniform(0.9, 1.1)};
  const std::uint64_t stitch_key = sub_key(seed, 12);
  const TileNoise fuzz(sub_key(seed, 13), size, 2 * size, 2 * size);
  const TileNoise tone_noise(sub_key(seed, 14), size, repeats(size, 10.0), repeats(size, 10.0));
  constexpr double kAmplitude = 2.0;  // pixels
  const double slant = 0.45;          // radians from vertical
  const double half_len = 0.64 * ph / std::cos(slant), half_wid = 0.27 * pw;
  const double twist_len = 0.35 * pw;
  MaterialModel m;
  m.roughness = 0.6;
  m.f0 = {0.03, 0.03, 0.03};
  m.at = [=](double x, double y) {
    const double xs = x + phase_x, ys = y + phase_y;
    const auto cx = std::int64_t(std::floor(xs / pw)), cy = std::int64_t(std::floor(ys / ph));
    double best = -0.45 * kAmplitude;  // the gaps between loops
    double cover = 0.0;
    std::int64_t bi = cx, bj = cy;
    for (std::int64_t j = cy - 1; j <= cy + 1; ++j)
      for (std::int64_t i = cx - 1; i <= cx + 1; ++i)
        for (int leg = 0; leg < 2; ++leg) {
          const double sgn = leg == 0 ? 1.0 : -1.0;  // left leg slants toward +x going down
          const double ox = (double(i) + (leg == 0 ? 0.27 : 0.73)) * pw;
          const double oy = (double(j) + 0.5) * ph;
          const double ax = sgn * std::sin(slant), ay = std::cos(slant);
          const double rx = xs - ox, ry = ys - oy;
          const double along = rx * ax + ry * ay, across = -rx * ay + ry * ax;
          const double a = along / half_len, c = across / half_wid;
          if (std::abs(a) >= 1.0 || std::abs(c) >= 1.0) continue;
          const double q = 1.0 - a * a - c * c;  // an elongated ellipsoid
          if (q <= 0.0) continue;
          const double prof = std::sqrt(q);
          const double tilt = 0.8 + 0.2 * a;  // rises toward the V's point (over the loop below)
          const double twist = 1.0 + 0.1 * std::sin(2.0 * kPi * (along / twist_len + 0.5 * c));
          const double h = kAmplitude * tilt * prof * twist;
          if (h > best) {
            best = h;
            bi = i;
            bj = j;
          }
          cover = std::max(cover, prof);
        }
    const double fz = fuzz(xs, ys);
    const double jitter =
        0.9 + 0.2 * hash01(stitch_key, wrap_index(bi, cols), wrap_index(bj, rows));
    const double tone =
        jitter * (1.0 + 0.08 * fz + 0.08 * tone_noise(xs, ys)) * (0.55 + 0.45 * std::sqrt(cover));
    Point pt;
    pt.height = best + 0.08 * fz;
    pt.albedo = {base.r * tone, base.g * tone, base.b * tone};
    pt.gloss = cover;
    return pt;
  };
  return m;
}

// Bumps (stone): a sum of periodic Gaussian bumps placed, sized and tinted by the seeded
// generator, plus a grainy noise; a mottled grey-beige albedo with darker valleys, mildly
// glossy.
MaterialModel bumps(int size, std::uint64_t seed) {
  Rng rng(sub_key(seed, 21));
  struct Bump {
    double x, y, inv2s2, amp, radius;
    Rgb tint;
  };
  // Two populations: large bumps (pebbles) and small ones (grit) between them.
  const int large = std::max(4, int(std::lround(double(size) * size / 70.0)));
  const int small = std::max(4, int(std::lround(double(size) * size / 30.0)));
  std::vector<Bump> list;
  list.reserve(std::size_t(large + small));
  for (int i = 0; i < large + small; ++i) {
    const bool is_large = i < large;
    Bump b;
    b.x = rng.uniform(0.0, size);
    b.y = rng.uniform(0.0, size);
    const double sigma = is_large ? rng.uniform(1.2, 2.4) : rng.uniform(0.7, 1.2);
    b.inv2s2 = 1.0 / (2.0 * sigma * sigma);
    b.radius = 3.5 * sigma;
    b.amp = is_large ? rng.uniform(0.8, 1.6) : rng.uniform(0.15, 0.4);
    const double t = rng.uniform(-1.0, 1.0), bright = rng.uniform(0.85, 1.15);
    b.tint = {bright * (1.0 + 0.06 * t), bright * (1.0 + 0.01 * t), bright * (1.0 - 0.06 * t)};
    list.push_back(b);
  }
  const double base_tone = rng.uniform(0.85, 1.15), warm = rng.uniform(-1.0, 1.0);
  const Rgb base{0.31 * base_tone * (1.0 + 0.04 * warm), 0.28 * base_tone,
                 0.24 * base_tone * (1.0 - 0.04 * warm)};
  const TileNoise grain(sub_key(seed, 22), size, repeats(size, 2.0), repeats(size, 2.0));
  const TileNoise mottle(sub_key(seed, 23), size, repeats(size, 9.0), repeats(size, 9.0));
  const TileNoise speck(sub_key(seed, 24), size, size, size);
  const double s = double(size);
  // Bins of bumps, at least as wide as the widest bump's reach, so that a point only looks at
  // the bumps of its own and the 8 neighbouring bins. With fewer than 3 bins per side (small
  // images) every bump is looked at, over all its periodic images within its reach.
  double max_radius = 0.0;
  for (const Bump& b : list) max_radius = std::max(max_radius, b.radius);
  const int bins = int(std::floor(s / max_radius));
  const bool binned = bins >= 3;
  std::vector<std::vector<std::size_t>> bin_list(binned ? std::size_t(bins) * bins : 1);
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::size_t k =
        binned ? std::size_t(std::min(int(list[i].y / s * bins), bins - 1)) * std::size_t(bins) +
                     std::size_t(std::min(int(list[i].x / s * bins), bins - 1))
               : 0;
    bin_list[k].push_back(i);
  }
  MaterialModel m;
  m.roughness = 0.3;
  m.f0 = {0.045, 0.045, 0.045};
  m.height_range = 2.2;
  m.at = [=](double x, double y) {
    double h = 0.0, w = 0.0;
    Rgb tint{0.0, 0.0, 0.0};
    const auto add = [&](const Bump& b, double ex, double ey) {
      if (std::abs(ex) > b.radius || std::abs(ey) > b.radius) return;
      const double g = std::exp(-(ex * ex + ey * ey) * b.inv2s2);
      h += b.amp * g;
      w += g;
      tint.r += g * b.tint.r;
      tint.g += g * b.tint.g;
      tint.b += g * b.tint.b;
    };
    if (binned) {
      // Radius <= size / 3: only the nearest periodic image of a bump can reach the point.
      const int bx = std::min(int(x / s * bins), bins - 1),
                by = std::min(int(y / s * bins), bins - 1);
      for (int j = by - 1; j <= by + 1; ++j)
        for (int i = bx - 1; i <= bx + 1; ++i)
          for (std::size_t idx : bin_list[std::size_t(wrap_index(j, bins)) * std::size_t(bins) +
                                          std::size_t(wrap_index(i, bins))]) {
            const Bump& b = list[idx];
            add(b, std::remainder(x - b.x, s), std::remainder(y - b.y, s));
          }
    } else {
      for (const Bump& b : list) {
        const double dx = std::remainder(x - b.x, s), dy = std::remainder(y - b.y, s);
        const int reach = int(std::ceil(b.radius / s)) + 1;
        for (int ky = -reach; ky <= reach; ++ky)
          for (int kx = -reach; kx <= reach; ++kx) add(b, dx + kx * s, dy + ky * s);
      }
    }
    const double gr = grain(x, y), mo = mottle(x, y), sp = speck(x, y);
    h += 0.2 * gr + 0.08 * sp;
    const double blend = w / (w + 0.2);
    const double tone = (1.0 + 0.3 * mo + 0.15 * sp) * (0.65 + 0.35 * smoothstep(0.0, 1.2, h));
    Point pt;
    pt.height = h;
    const auto mixc = [&](double base_c, double tint_c) {
      return base_c * tone * ((1.0 - blend) + blend * tint_c / std::max(w, 1e-12));
    };
    pt.albedo = {mixc(base.r, tint.r), mixc(base.g, tint.g), mixc(base.b, tint.b)};
    pt.gloss = 0.7 + 0.3 * smoothstep(-0.5, 0.5, sp);
    return pt;
  };
  return m;
}

// Leather: a pebbled grain of polygonal cells (the cells of a periodic jittered-grid Worley
// pattern, Worley 1996) raised between creases, with a fine wrinkle noise; dark brown and
// glossy (a finished leather).
MaterialModel leather(int size, std::uint64_t seed) {
  Rng rng(sub_key(seed, 31));
  const int cells = repeats(size, 6.0);
  const double cw = double(size) / cells;
  const double phase_x = rng.uniform(0.0, size), phase_y = rng.uniform(0.0, size);
  const std::uint64_t cell_key = sub_key(seed, 32);
  const Rgb base{0.13 * rng.uniform(0.9, 1.1), 0.065 * rng.uniform(0.9, 1.1),
                 0.035 * rng.uniform(0.9, 1.1)};
  const TileNoise wrinkle(sub_key(seed, 33), size, repeats(size, 1.5), repeats(size, 1.5));
  const TileNoise stain(sub_key(seed, 34), size, repeats(size, 10.0), repeats(size, 10.0));
  constexpr double kAmplitude = 1.1;
  MaterialModel m;
  m.roughness = 0.25;
  m.f0 = {0.04, 0.037, 0.034};
  m.at = [=](double x, double y) {
    const double xs = x + phase_x, ys = y + phase_y;
    const auto cx = std::int64_t(std::floor(xs / cw)), cy = std::int64_t(std::floor(ys / cw));
    double f1 = 1e30, f2 = 1e30;
    double own = 0.0;
    for (std::int64_t j = cy - 1; j <= cy + 1; ++j)
      for (std::int64_t i = cx - 1; i <= cx + 1; ++i) {
        const int wi = wrap_index(i, cells), wj = wrap_index(j, cells);
        const double px = (double(i) + 0.15 + 0.7 * hash01(cell_key, wi, wj, 1)) * cw;
        const double py = (double(j) + 0.15 + 0.7 * hash01(cell_key, wi, wj, 2)) * cw;
        const double d = std::hypot(xs - px, ys - py);
        if (d < f1) {
          f2 = f1;
          f1 = d;
          own = hash01(cell_key, wi, wj, 3);
        } else if (d < f2) {
          f2 = d;
        }
      }
    const double edge = f2 - f1;  // 0 on the crease between two cells
    const double plateau = smoothstep(0.0, 0.25 * cw, edge);
    const double dome = 1.0 - 0.25 * smoothstep(0.0, 0.6 * cw, f1);
    const double wr = wrinkle(xs, ys);
    Point pt;
    pt.height = kAmplitude * plateau * dome * (0.85 + 0.3 * own) + 0.06 * wr;
    const double tone =
        (0.6 + 0.4 * plateau) * (1.0 + 0.15 * stain(xs, ys) + 0.05 * wr) * (0.9 + 0.2 * own);
    pt.albedo = {base.r * tone, base.g * tone, base.b * tone};
    pt.gloss = 0.35 + 0.65 * plateau;
    return pt;
  };
  return m;
}

const std::vector<std::string>& names() {
  static const std::vector<std::string> n{"corduroy", "knit", "bumps", "leather"};
  return n;
}

// A bilinear sampling position on a periodic grid of n x n points, grid point (i, j) at
// pixel coordinates (i / f, j / f).
struct Lerp {
  std::uint32_t i00, i10, i01, i11;
  float wx, wy;
  template <class T>
  float operator()(const T* g) const {
    const float a = float(g[i00]) + (float(g[i10]) - float(g[i00])) * wx;
    const float b = float(g[i01]) + (float(g[i11]) - float(g[i01])) * wx;
    return a + (b - a) * wy;
  }
  // The same for a grid of interleaved triples (normals, albedo).
  std::array<float, 3> rgb(const float* g) const {
    std::array<float, 3> out{};
    for (std::size_t c = 0; c < 3; ++c) {
      const float a = g[3 * i00 + c] + (g[3 * i10 + c] - g[3 * i00 + c]) * wx;
      const float b = g[3 * i01 + c] + (g[3 * i11 + c] - g[3 * i01 + c]) * wx;
      out[c] = a + (b - a) * wy;
    }
    return out;
  }
};

Lerp locate(double x, double y, int n, double f) {
  const double gx = x * f, gy = y * f;
  const double fx = std::floor(gx), fy = std::floor(gy);
  const int x0 = wrap_index(std::int64_t(fx), n), y0 = wrap_index(std::int64_t(fy), n);
  const int x1 = x0 + 1 == n ? 0 : x0 + 1, y1 = y0 + 1 == n ? 0 : y0 + 1;
  const auto un = std::uint32_t(n);
  return {std::uint32_t(y0) * un + std::uint32_t(x0),
          std::uint32_t(y0) * un + std::uint32_t(x1),
          std::uint32_t(y1) * un + std::uint32_t(x0),
          std::uint32_t(y1) * un + std::uint32_t(x1),
          float(gx - fx),
          float(gy - fy)};
}

// The material evaluated on the fine periodic grid, with its derived maps.
struct Surface {
  int size = 0;  // image side, pixels
  int f = 1;     // grid points per pixel side
  int n = 0;     // grid points per side (f * size)
  std::vector<float> height, albedo, gloss, normal, access;
  float h_min = 0.0f, h_max = 0.0f;
  double roughness = 0.5;
  Rgb f0;

  float h(double x, double y) const { return locate(x, y, n, f)(height.data()); }
};

Surface build_surface(const MaterialModel& m, int size) {
  Surface s;
  s.size = size;
  s.f = size <= 256 ? 4 : size <= 512 ? 2 : 1;
  s.n = s.f * size;
  s.roughness = m.roughness;
  s.f0 = m.f0;
  const int n = s.n;
  const std::size_t count = std::size_t(n) * std::size_t(n);
  s.height.resize(count);
  s.albedo.resize(3 * count);
  s.gloss.resize(count);
  s.normal.resize(3 * count);
  s.access.resize(count);
  const double inv_f = 1.0 / s.f;

  // 1. The procedural height, albedo and gloss at every grid point.
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

  // The reference plane z = 0 is the mean surface height; optionally fix the relief depth.
  double sum = 0.0, lo = 1e30, hi = -1e30;
  for (float v : s.height) {
    sum += v;
    lo = std::min(lo, double(v));
    hi = std::max(hi, double(v));
  }
  const double mean = sum / double(count);
  const double scale = m.height_range > 0.0 && hi > lo ? m.height_range / (hi - lo) : 1.0;
  for (float& v : s.height) v = float((v - mean) * scale);
  s.h_min = float((lo - mean) * scale);
  s.h_max = float((hi - mean) * scale);

  // 2. Normals from the gradient of the height field (central differences, pixel units).
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

  // 2b. Ambient accessibility: the fraction of a uniform sky a point sees, cos^2 of the
  // horizon elevation averaged over 8 azimuths (horizon-based ambient occlusion).
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
  return s;
}

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

// What the camera rays of one view see, kept for all lights (structure of arrays, so that the
// per-light shading loop vectorises).
struct ViewRays {
  explicit ViewRays(std::size_t n)
      : nx(n),
        ny(n),
        nz(n),
        r(n),
        g(n),
        b(n),
        ambient(n),
        spec_view(n),
        wx(n),
        wy(n),
        i00(n),
        i10(n),
        i01(n),
        i11(n),
        red(n),
        green(n),
        blue(n) {}
  std::vector<float> nx, ny, nz;  // shading normal
  std::vector<float> r, g, b;     // albedo
  std::vector<float> ambient;     // ambient weight (accessibility * ambient light)
  std::vector<float> spec_view;   // gloss * G1(v) / (4 n.v): the view-only part of the lobe
  std::vector<float> wx, wy;      // where to read a light's visibility map (bilinear)
  std::vector<std::uint32_t> i00, i10, i01, i11;
  std::vector<float> red, green, blue;  // radiance of each ray for the current light
};

// Linear -> 8-bit sRGB levels (IEC 61966-2-1), rounded: level k is the number of decision
// thresholds (the linear values of the level midpoints) at or below x. A table over 4096 bins
// of [0, 1] gives the lowest level of a bin; at most a few thresholds lie inside one bin.
class SrgbEncoder {
 public:
  SrgbEncoder() {
    for (int k = 0; k < 255; ++k) {
      const double e = (k + 0.5) / 255.0;
      const double lin = e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
      thresholds_[std::size_t(k)] = float(lin);
    }
    thresholds_[255] = std::numeric_limits<float>::infinity();
    for (std::size_t b = 0; b < kBins; ++b) {
      const float lo = float(b) / float(kBins);
      start_[b] = std::uint8_t(std::upper_bound(thresholds_.begin(), thresholds_.end() - 1, lo) -
                               thresholds_.begin());
    }
  }
  float operator()(float x) const {
    if (!(x > 0.0f)) return 0.0f;
    if (x >= 1.0f) return 255.0f;
    std::size_t bin = std::min(std::size_t(x * float(kBins)), kBins - 1);
    // The bin's lower edge is <= x; guard the float rounding of x * kBins.
    while (bin > 0 && float(bin) / float(kBins) > x) --bin;
    unsigned level = start_[bin];
    while (thresholds_[level] <= x) ++level;
    return float(level);
  }

 private:
  static constexpr std::size_t kBins = 4096;
  std::array<float, 256> thresholds_{};
  std::array<std::uint8_t, kBins> start_{};
};

}  // namespace

std::vector<std::string> material_names() {
  return names();
}

Btf generate(const GenerateConfig& config) {
  const auto& known = names();
  if (std::find(known.begin(), known.end(), config.material) == known.end())
    throw Error(Error::Kind::kArgument, fmt::format("unknown material '{}'; known: {}",
                                                    config.material, fmt::join(known, ", ")));
  if (config.size < 4 || config.size > 8192)
    throw Error(Error::Kind::kArgument,
                fmt::format("generated image size {} is out of range; give a size from 4 to "
                            "8192 pixels",
                            config.size));
  if (config.supersample < 1 || config.supersample > 8)
    throw Error(Error::Kind::kArgument,
                fmt::format("supersample {} is out of range; give 1 to 8 rays per pixel side",
                            config.supersample));

  const int size = config.size;
  Btf btf(config.lights, config.views, size, size,
          config.hdr ? SampleFormat::kHdr : SampleFormat::kLdr8);
  btf.set_origin({0, 0, size, size});

  const MaterialModel model = config.material == "corduroy" ? corduroy(size, config.seed)
                              : config.material == "knit"   ? knit(size, config.seed)
                              : config.material == "bumps"  ? bumps(size, config.seed)
                                                            : leather(size, config.seed);
  const Surface surf = build_surface(model, size);

  // Per-light visibility maps (step 3), at up to 2 points per pixel side.
  const int fs = std::min(surf.f, 2);
  const int ns = fs * size;
  const std::size_t nl = btf.lights().size(), nv = btf.views().size();
  std::vector<Vec3> lvec(nl), vvec(nv);
  for (std::size_t i = 0; i < nl; ++i) lvec[i] = to_vector(btf.lights()[i]);
  for (std::size_t i = 0; i < nv; ++i) vvec[i] = to_vector(btf.views()[i]);
  std::vector<std::vector<float>> shadows(nl);
  for (auto& m : shadows) m.resize(std::size_t(ns) * std::size_t(ns));
#pragma omp parallel for schedule(dynamic, 4)
  for (std::ptrdiff_t task = 0; task < std::ptrdiff_t(nl) * ns; ++task) {
    const auto li = std::size_t(task / ns);
    const int j = int(task % ns);
    shadow_row(surf, lvec[li], fs, j, shadows[li].data() + std::size_t(j) * std::size_t(ns));
  }

  // Reflectance constants (step 5). The incident light has irradiance pi at normal incidence,
  // so a white Lambertian surface lit and seen frontally has radiance 1.
  constexpr float kAmbient = 0.08f;   // ambient light relative to the direct light
  constexpr float kExposure = 1.25f;  // frontal images mid-bright, highlights may clip
  const auto alpha = float(surf.roughness);
  const float alpha2 = alpha * alpha;
  const float k_smith = alpha * 0.5f;  // Smith-Schlick G1 with k = alpha / 2 (Karis 2013)
  const std::array<float, 3> f0{float(surf.f0.r), float(surf.f0.g), float(surf.f0.b)};

  const int ss = config.supersample;
  const std::size_t rays_per_pixel = std::size_t(ss) * std::size_t(ss);
  const SrgbEncoder encode;
  const bool hdr = config.hdr;

  // Work in tasks of (view, band of rows): a band's rays are traced once and serve every
  // light; bands keep the memory bounded for large images.
  const int band_rows = std::clamp(int(65536 / (std::size_t(size) * rays_per_pixel)), 1, size);
  const int bands = (size + band_rows - 1) / band_rows;

#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t task = 0; task < std::ptrdiff_t(nv) * bands; ++task) {
    const auto vi = std::size_t(task / bands);
    const int y0 = int(task % bands) * band_rows, y1 = std::min(size, y0 + band_rows);
    const Vec3 v = vvec[vi];
    const std::size_t pixels = std::size_t(y1 - y0) * std::size_t(size);
    // Steps 4 and 6: trace the band's rays once; the hits serve every light.
    ViewRays rays(pixels * rays_per_pixel);
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < size; ++x)
        for (int sy = 0; sy < ss; ++sy)
          for (int sx = 0; sx < ss; ++sx) {
            const double px = x + (sx + 0.5) / ss, py = y + (sy + 0.5) / ss;
            const auto [hx, hy] = trace(surf, px, py, v);
            const Lerp at = locate(hx, hy, surf.n, surf.f);
            const auto n3 = at.rgb(surf.normal.data());
            const float len = std::sqrt(n3[0] * n3[0] + n3[1] * n3[1] + n3[2] * n3[2]);
            const float nx = n3[0] / len, ny = n3[1] / len, nz = n3[2] / len;
            const auto a3 = at.rgb(surf.albedo.data());
            const std::size_t k =
                (std::size_t(y - y0) * std::size_t(size) + std::size_t(x)) * rays_per_pixel +
                std::size_t(sy) * std::size_t(ss) + std::size_t(sx);
            rays.nx[k] = nx;
            rays.ny[k] = ny;
            rays.nz[k] = nz;
            rays.r[k] = a3[0];
            rays.g[k] = a3[1];
            rays.b[k] = a3[2];
            rays.ambient[k] = kAmbient * at(surf.access.data());
            const float ndv = std::max(float(nx * v.x + ny * v.y + nz * v.z), 1e-3f);
            const float g1v = ndv / (ndv * (1.0f - k_smith) + k_smith);
            rays.spec_view[k] = at(surf.gloss.data()) * g1v / (4.0f * ndv);
            const Lerp sh = locate(hx, hy, ns, fs);
            rays.wx[k] = sh.wx;
            rays.wy[k] = sh.wy;
            rays.i00[k] = sh.i00;
            rays.i10[k] = sh.i10;
            rays.i01[k] = sh.i01;
            rays.i11[k] = sh.i11;
          }

    const std::size_t count = pixels * rays_per_pixel;
    for (std::size_t li = 0; li < nl; ++li) {
      const Vec3 l = lvec[li];
      const float* vis_map = shadows[li].data();
      // Half vector and Fresnel depend only on the direction pair.
      double hx = l.x + v.x, hy = l.y + v.y, hz = l.z + v.z;
      const double hl = std::sqrt(hx * hx + hy * hy + hz * hz);
      if (hl > 1e-12) {
        hx /= hl;
        hy /= hl;
        hz /= hl;
      } else {
        hx = 0.0;
        hy = 0.0;
        hz = 1.0;
      }
      const double vdh = std::clamp(v.x * hx + v.y * hy + v.z * hz, 0.0, 1.0);
      const auto schlick = float(std::pow(1.0 - vdh, 5.0));
      const float fr = f0[0] + (1.0f - f0[0]) * schlick, fg = f0[1] + (1.0f - f0[1]) * schlick,
                  fb = f0[2] + (1.0f - f0[2]) * schlick;
      const auto lx = float(l.x), ly = float(l.y), lz = float(l.z);
      const auto hxf = float(hx), hyf = float(hy), hzf = float(hz);

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

      float* out = btf.image(li, vi) + std::size_t(y0) * std::size_t(size) * 3;
      const float norm = kExposure / float(rays_per_pixel);
      for (std::size_t p = 0; p < pixels; ++p) {
        float acc_r = 0.0f, acc_g = 0.0f, acc_b = 0.0f;
        for (std::size_t q = p * rays_per_pixel; q < (p + 1) * rays_per_pixel; ++q) {
          acc_r += rays.red[q];
          acc_g += rays.green[q];
          acc_b += rays.blue[q];
        }
        const float rgb[3] = {acc_r * norm, acc_g * norm, acc_b * norm};
        for (std::size_t c = 0; c < 3; ++c) out[3 * p + c] = hdr ? rgb[c] : encode(rgb[c]);
      }
    }
  }
  return btf;
}

}  // namespace btfgmm
