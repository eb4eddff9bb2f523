// The procedural materials of the synthetic BTF (step 1 of the pipeline described in
// generate.cpp): for every material, a periodic height field in pixel units, a spatially
// varying albedo and a specular weight, evaluated at any point (x, y) of the image, and the
// material's GGX roughness and normal-incidence Fresnel reflectance f0.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/synth/generate.hpp"
#include "synth/materials.hpp"
#include "synth/noise.hpp"

namespace btfgmm {
namespace detail::synth {
namespace {

// ---- Corduroy -------------------------------------------------------------------------------

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

// ---- Knit -----------------------------------------------------------------------------------

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

// ---- Bumps (stone) --------------------------------------------------------------------------

// One periodic Gaussian bump of the stone.
struct Bump {
  double x, y, inv2s2, amp, radius;
  Rgb tint;
};

// Two populations: large bumps (pebbles) and small ones (grit) between them, placed, sized
// and tinted by the seeded generator.
std::vector<Bump> scatter_bumps(Rng& rng, int size) {
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
  return list;
}

// Bins of bumps, at least as wide as the widest bump's reach, so that a point only looks at
// the bumps of its own and the 8 neighbouring bins. With fewer than 3 bins per side (small
// images) every bump is looked at, over all its periodic images within its reach.
struct BumpBins {
  int bins = 0;         // bins per side
  bool binned = false;  // bins >= 3; otherwise one list of all bumps
  std::vector<std::vector<std::size_t>> lists;
};

BumpBins bin_bumps(const std::vector<Bump>& list, double s) {
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
  return {bins, binned, std::move(bin_list)};
}

// The bumps summed at one point: height, total Gaussian weight and weighted tint.
struct BumpSum {
  double h = 0.0, w = 0.0;
  Rgb tint{0.0, 0.0, 0.0};
};

// Sums the bumps that reach (x, y) on an s x s periodic image.
BumpSum sum_bumps(const std::vector<Bump>& list, const BumpBins& grid, double s, double x,
                  double y) {
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
  const int bins = grid.bins;
  if (grid.binned) {
    // Radius <= size / 3: only the nearest periodic image of a bump can reach the point.
    const int bx = std::min(int(x / s * bins), bins - 1),
              by = std::min(int(y / s * bins), bins - 1);
    for (int j = by - 1; j <= by + 1; ++j)
      for (int i = bx - 1; i <= bx + 1; ++i)
        for (std::size_t idx : grid.lists[std::size_t(wrap_index(j, bins)) * std::size_t(bins) +
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
  return {h, w, tint};
}

// Bumps (stone): a sum of periodic Gaussian bumps placed, sized and tinted by the seeded
// generator, plus a grainy noise; a mottled grey-beige albedo with darker valleys, mildly
// glossy.
MaterialModel bumps(int size, std::uint64_t seed) {
  Rng rng(sub_key(seed, 21));
  const std::vector<Bump> list = scatter_bumps(rng, size);
  const double base_tone = rng.uniform(0.85, 1.15), warm = rng.uniform(-1.0, 1.0);
  const Rgb base{0.31 * base_tone * (1.0 + 0.04 * warm), 0.28 * base_tone,
                 0.24 * base_tone * (1.0 - 0.04 * warm)};
  const TileNoise grain(sub_key(seed, 22), size, repeats(size, 2.0), repeats(size, 2.0));
  const TileNoise mottle(sub_key(seed, 23), size, repeats(size, 9.0), repeats(size, 9.0));
  const TileNoise speck(sub_key(seed, 24), size, size, size);
  const double s = double(size);
  const BumpBins grid = bin_bumps(list, s);
  MaterialModel m;
  m.roughness = 0.3;
  m.f0 = {0.045, 0.045, 0.045};
  m.height_range = 2.2;
  m.at = [=](double x, double y) {
    const BumpSum sum = sum_bumps(list, grid, s, x, y);
    double h = sum.h;
    const double w = sum.w;
    const Rgb tint = sum.tint;
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

// ---- Leather --------------------------------------------------------------------------------

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

// The one table of the materials: name, description, procedural model.
struct MaterialEntry {
  MaterialInfo info;
  MaterialModel (*make)(int size, std::uint64_t seed);
};

const std::array<MaterialEntry, 4>& table() {
  static const std::array<MaterialEntry, 4> t{{
      {{"corduroy", "parallel ridges (wales) between narrow grooves, red-brown pile"}, corduroy},
      {{"knit", "V-shaped stitches of round yarn (stockinette), wool-coloured"}, knit},
      {{"bumps", "scattered rounded bumps with grain, grey-beige stone"}, bumps},
      {{"leather", "pebbled grain of raised cells between creases, dark brown, glossy"}, leather},
  }};
  return t;
}

// The material called `name`; Error(kArgument) naming the nearest one otherwise.
const MaterialEntry& entry(const std::string& name) {
  for (const MaterialEntry& e : table())
    if (e.info.name == name) return e;
  std::vector<std::string_view> names;
  for (const MaterialEntry& e : table()) names.push_back(e.info.name);
  throw Error(Error::Kind::kArgument,
              fmt::format("unknown material '{}'{}; the materials are: {}", name,
                          did_you_mean(name, names), fmt::join(names, ", ")));
}

}  // namespace

void check_material(const std::string& name) {
  entry(name);
}

MaterialModel material_model(const std::string& name, int size, std::uint64_t seed) {
  return entry(name).make(size, seed);
}

}  // namespace detail::synth

std::span<const MaterialInfo> materials() {
  static const std::vector<MaterialInfo> infos = [] {
    std::vector<MaterialInfo> v;
    for (const auto& e : detail::synth::table()) v.push_back(e.info);
    return v;
  }();
  return infos;
}

std::vector<std::string> material_names() {
  std::vector<std::string> names;
  for (const MaterialInfo& m : materials()) names.emplace_back(m.name);
  return names;
}

}  // namespace btfgmm
