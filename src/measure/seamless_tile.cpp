// Seamless tiles made by cutting (include/btfgmm/measure/seamless_tile.hpp): the mismatch of
// every pixel with the one a tile's width to its right (and a tile's height below) summed
// over all images as they stream past, then for each region position the closed cuts of
// least cost through the column overlap and the row overlap by dynamic programming.
#include "btfgmm/measure/seamless_tile.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/text.hpp"

namespace btfgmm {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// What a level of the wrap's step above the data's mean step costs against a level of a cut's
// mismatch (wrap_excess, ClosedCut).
constexpr double kWrapWeight = 1.0;

double sq(double v) {
  return v * v;
}

// The overlap of a tile `size` long in an image `full` long: as asked, or as many as fit up to
// half the tile.
int overlap_for(int asked, int size, int full) {
  return asked > 0 ? asked : std::min(size / 2, full - size);
}

void check_size(const BtfInfo& info, const SeamlessTileConfig& c, int ox, int oy) {
  const std::string where = info.path.string();
  if (c.width < 4 || c.height < 4)
    throw Error(Error::Kind::kArgument,
                fmt::format("a seamless tile of {}x{} pixels is too small to cut; give at least "
                            "4x4",
                            c.width, c.height));
  if (ox < 2 || oy < 2 || c.width + ox > info.width || c.height + oy > info.height)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("{}: its {}x{} images cannot give a seamless {}x{} tile with an overlap of "
                    "{}x{}: a cut needs the tile plus an overlap of at least 2 (and at most half "
                    "the tile) in each direction, so images of at least {}x{}; give a tile of at "
                    "most {}x{}, or a plain crop ({} X,Y,W,H)",
                    where, info.width, info.height, c.width, c.height, std::max(ox, 2),
                    std::max(oy, 2), c.width + std::max(ox, 2), c.height + std::max(oy, 2),
                    info.width - 2, info.height - 2, option_name("tile")));
  if (ox > c.width / 2 || oy > c.height / 2)
    throw Error(Error::Kind::kArgument,
                fmt::format("an overlap of {} is more than half the {}x{} tile; give at most {}",
                            std::max(ox, oy), c.width, c.height, std::min(c.width, c.height) / 2));
}

// The width of the feather across a cut through an overlap `n` wide: kFeather pixels, or
// fewer (even, down to 0: a hard cut) where the overlap leaves less room beside the cut.
constexpr int kFeather = 4;
int feather_for(int n) {
  return std::clamp((n - 2) / 2 * 2, 0, kFeather);
}

// The weight of strip A (the tile's own continuation) at overlap position j of a cut at p
// feathered over f pixels: 0 (all B) up to p - f / 2, 1 (all A) from p + f / 2 on, linear
// between (Burt and Adelson's blend across a seam, narrowed to the cut).
float weight_of_a(int j, int p, int f) {
  if (f == 0) return j < p ? 0.0f : 1.0f;
  return std::clamp(0.5f + (float(j - p) + 0.5f) / float(f), 0.0f, 1.0f);
}

// The sums over images and channels of (I(x + W, y) - I(x, y))^2 (`right`, x < w - W) and of
// (I(x, y + H) - I(x, y))^2 (`below`, y < h - H), and of the squared steps between
// neighbouring pixels (`step_right`, x < w - 1, and `step_below`, y < h - 1). Each row is
// summed by one thread over the images in their order, so the sums do not depend on the
// number of threads.
struct MismatchSums {
  int w = 0, h = 0, W = 0, H = 0;
  std::vector<double> right, below, step_right, step_below;
  std::size_t images = 0;

  MismatchSums(int w_, int h_, int W_, int H_)
      : w(w_),
        h(h_),
        W(W_),
        H(H_),
        right(std::size_t(w) * std::size_t(h), 0.0),
        below(right),
        step_right(right),
        step_below(right) {}

  std::size_t index(int x, int y) const { return std::size_t(y) * std::size_t(w) + x; }
  double at_right(int x, int y) const { return right[index(x, y)]; }
  double at_below(int x, int y) const { return below[index(x, y)]; }

  void add(const std::vector<std::vector<float>>& batch, std::size_t count) {
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; ++y)
      for (std::size_t k = 0; k < count; ++k) add_row(batch[k].data(), y);
    images += count;
  }

  // The RMS step between neighbouring pixels, per image and channel: across columns (x), down
  // rows (y), and of both.
  double neighbour_rms_x() const {
    return rms(step_right, std::size_t(w - 1) * h);
  }
  double neighbour_rms_y() const {
    return rms(step_below, std::size_t(h - 1) * w);
  }
  double neighbour_rms() const {
    const double nx = double(w - 1) * h, ny = double(h - 1) * w;
    return std::sqrt((sq(neighbour_rms_x()) * nx + sq(neighbour_rms_y()) * ny) / (nx + ny));
  }

 private:
  double rms(const std::vector<double>& sums, std::size_t pairs) const {
    double total = 0.0;
    for (double v : sums) total += v;
    return std::sqrt(total / double(std::max<std::size_t>(pairs * 3 * images, 1)));
  }

  void add_row(const float* img, int y) {
    auto v = [&](int x, int yy, int c) {
      return double(img[(std::size_t(yy) * std::size_t(w) + x) * 3 + c]);
    };
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        const double here = v(x, y, c);
        if (x + W < w) right[index(x, y)] += sq(v(x + W, y, c) - here);
        if (y + H < h) below[index(x, y)] += sq(v(x, y + H, c) - here);
        if (x + 1 < w) step_right[index(x, y)] += sq(v(x + 1, y, c) - here);
        if (y + 1 < h) step_below[index(x, y)] += sq(v(x, y + 1, c) - here);
      }
  }
};

// Every image once, a batch of whole images at a time, in their order.
MismatchSums sum_mismatches(const BtfSource& source, const SeamlessTileConfig& c) {
  const BtfInfo& info = source.info();
  MismatchSums sums(info.width, info.height, c.width, c.height);
  const std::size_t n = info.lights.size() * info.views.size();
  const std::size_t image_floats = std::size_t(info.width) * std::size_t(info.height) * 3;
  const std::size_t batch =
      std::clamp<std::size_t>((std::size_t(64) << 20) / (image_floats * 4), 1, 256);
  std::vector<std::vector<float>> images(std::min(batch, n));
  for (std::size_t first = 0; first < n; first += batch) {
    if (c.stopped && c.stopped())
      throw Error(
          Error::Kind::kArgument,
          fmt::format("stopped: the seamless tile's cut had read {} of {} images", first, n));
    const std::size_t last = std::min(n, first + batch);
    source.read_tiles({}, first, last, [&](std::size_t i, std::span<const float> rgb) {
      images[i - first].assign(rgb.begin(), rgb.end());
    });
    sums.add(images, last - first);
    if (c.progress) c.progress(double(last) / double(n));
  }
  return sums;
}

// A closed cut through an overlap `n` wide along a cycle `length` long: p[r] in [1, n - 1]
// for every r, |p[r + 1] - p[r]| <= 1 and |p[0] - p[length - 1]| <= 1. `a[r * n + j]` is
// ||A - B|| at position j of step r; the cut costs a[r][p - 1] + a[r][p] at each step (the
// pair it puts side by side) and a[r][m] + a[r + 1][m] where it moves, m = min(p[r], p[r + 1])
// (the pair it puts one above the other).
struct ClosedCut {
  std::vector<int> path;
  double cost = kInf;
  std::size_t edges = 0;
};

ClosedCut cheapest_closed_cut(const std::vector<double>& a, int length, int n, int margin) {
  const int lo = 1 + margin, hi = n - 1 - margin;  // room for the feather on both sides
  const auto A = [&](int r, int j) { return a[std::size_t(r) * std::size_t(n) + std::size_t(j)]; };
  const auto side = [&](int r, int p) { return A(r, p - 1) + A(r, p); };
  const auto move = [&](int r, int p, int q) {
    return p == q ? 0.0 : A(r, std::min(p, q)) + A((r + 1) % length, std::min(p, q));
  };
  ClosedCut best;
  std::vector<double> cost(static_cast<std::size_t>(n)), next(cost);
  std::vector<int> from(std::size_t(length) * std::size_t(n), 0);
  for (int s = lo; s <= hi; ++s) {
    std::fill(cost.begin(), cost.end(), kInf);
    cost[std::size_t(s)] = side(0, s);
    for (int r = 1; r < length; ++r) {
      for (int p = lo; p <= hi; ++p) {
        double low = kInf;
        int arg = p;
        for (int q = std::max(lo, p - 1); q <= std::min(hi, p + 1); ++q) {
          const double v = cost[std::size_t(q)] + move(r - 1, q, p);
          if (v < low) low = v, arg = q;
        }
        next[std::size_t(p)] = low + side(r, p);
        from[std::size_t(r) * std::size_t(n) + std::size_t(p)] = arg;
      }
      std::swap(cost, next);
    }
    for (int p = std::max(lo, s - 1); p <= std::min(hi, s + 1); ++p) {
      const double total = cost[std::size_t(p)] + move(length - 1, p, s);
      if (total >= best.cost) continue;
      best.cost = total;
      best.path.assign(std::size_t(length), 0);
      best.path[std::size_t(length - 1)] = p;
      for (int r = length - 1; r > 0; --r)
        best.path[std::size_t(r - 1)] =
            from[std::size_t(r) * std::size_t(n) + std::size_t(best.path[std::size_t(r)])];
    }
  }
  best.edges = std::size_t(length);
  for (int r = 0; r < length; ++r)
    best.edges += best.path[std::size_t(r)] != best.path[std::size_t((r + 1) % length)];
  return best;
}

// The two cuts of the region at (x0, y0): the columns' first, then the rows' through the
// pixels the columns' cut chose.
struct RegionCuts {
  ClosedCut columns, rows;
  double wrap = 0.0;  // wrap_excess
  double cost() const { return columns.cost + rows.cost + wrap; }
};

// How much the wrap's steps (the tile's last column to its first, the data's step from the
// region's column W - 1 to W, and the same for the rows) exceed the data's mean step across
// columns `mean_x` and down rows `mean_y`, summed over the wrap's edges, each RMS over the
// images: a wrap placed where the texture changes fast (at a wale's edge) shows as a line of
// large steps although no cut is near it.
double wrap_excess(const MismatchSums& m, int x0, int y0, int ox, int oy, double scale,
                   double mean_x, double mean_y) {
  double excess = 0.0;
  for (int r = oy; r < m.H + oy; ++r)
    excess += std::sqrt(m.step_right[m.index(x0 + m.W - 1, y0 + r)]) * scale - mean_x;
  for (int c = ox; c < m.W + ox; ++c)
    excess += std::sqrt(m.step_below[m.index(x0 + c, y0 + m.H - 1)]) * scale - mean_y;
  return excess;
}

RegionCuts cut_region(const MismatchSums& m, int x0, int y0, int ox, int oy, double scale,
                      double mean_x, double mean_y) {
  const int W = m.W, H = m.H;
  std::vector<double> a(std::size_t(H) * std::size_t(ox));
  for (int r = 0; r < H; ++r)
    for (int j = 0; j < ox; ++j) {
      double e = m.at_right(x0 + j, y0 + r);
      if (r < oy)
        e = std::sqrt(e) + std::sqrt(m.at_right(x0 + j, y0 + r + H));
      else
        e = std::sqrt(e);
      a[std::size_t(r) * std::size_t(ox) + std::size_t(j)] = e * scale;
    }
  RegionCuts cuts;
  cuts.columns = cheapest_closed_cut(a, H, ox, feather_for(ox) / 2);
  a.assign(std::size_t(W) * std::size_t(oy), 0.0);
  for (int c = 0; c < W; ++c)
    for (int i = 0; i < oy; ++i) {
      const bool from_b = c < ox && c < cuts.columns.path[std::size_t(i)];
      a[std::size_t(c) * std::size_t(oy) + std::size_t(i)] =
          std::sqrt(m.at_below(x0 + c + (from_b ? W : 0), y0 + i)) * scale;
    }
  cuts.rows = cheapest_closed_cut(a, W, oy, feather_for(oy) / 2);
  cuts.wrap = kWrapWeight * wrap_excess(m, x0, y0, ox, oy, scale, mean_x, mean_y);
  return cuts;
}

// The region positions tried: every one that fits, or as many as `most` allows spread evenly.
std::vector<std::pair<int, int>> region_positions(int nx, int ny, std::size_t most) {
  int sx = 1, sy = 1;
  while (std::size_t((nx + sx - 1) / sx) * std::size_t((ny + sy - 1) / sy) > most)
    (sx <= sy ? sx : sy) += 1;
  std::vector<std::pair<int, int>> out;
  for (int y = 0; y < ny; y += sy)
    for (int x = 0; x < nx; x += sx) out.emplace_back(x, y);
  return out;
}

}  // namespace

SeamlessTile cut_seamless_tile(const BtfSource& source, const SeamlessTileConfig& c) {
  const BtfInfo& info = source.info();
  const int ox = overlap_for(c.overlap_x, c.width, info.width);
  const int oy = overlap_for(c.overlap_y, c.height, info.height);
  check_size(info, c, ox, oy);
  limits::check_memory(double(info.width) * info.height * 32.0 + (64 << 20),
                       fmt::format("the seamless tile's cost maps of {}", info.path.string()),
                       "give a smaller data set");
  const MismatchSums sums = sum_mismatches(source, c);
  const double scale = 1.0 / std::sqrt(3.0 * double(std::max<std::size_t>(sums.images, 1)));
  const double mean_x = sums.neighbour_rms_x(), mean_y = sums.neighbour_rms_y();
  // The DP's work per position, bounded so that the search takes seconds at most.
  const double per_position = 3.0 * (double(c.height) * ox * ox + double(c.width) * oy * oy);
  const std::size_t most = std::clamp<std::size_t>(std::size_t(2e9 / per_position), 1,
                                                   std::max<std::size_t>(c.max_positions, 1));
  const int nx = info.width - c.width - ox + 1, ny = info.height - c.height - oy + 1;
  if (c.at && (c.at->first < 0 || c.at->second < 0 || c.at->first >= nx || c.at->second >= ny))
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: a {}x{} region at {},{} is not inside its {}x{} images",
                            info.path.string(), c.width + ox, c.height + oy, c.at->first,
                            c.at->second, info.width, info.height));
  const auto positions =
      c.at ? std::vector<std::pair<int, int>>{*c.at} : region_positions(nx, ny, most);
  std::vector<RegionCuts> cuts(positions.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t k = 0; k < std::ptrdiff_t(positions.size()); ++k)
    cuts[std::size_t(k)] =
        cut_region(sums, positions[std::size_t(k)].first, positions[std::size_t(k)].second, ox, oy,
                   scale, mean_x, mean_y);
  std::size_t best = 0;
  for (std::size_t k = 1; k < cuts.size(); ++k)
    if (cuts[k].cost() < cuts[best].cost()) best = k;
  SeamlessTile t;
  t.width = c.width;
  t.height = c.height;
  t.region = {.x = positions[best].first,
              .y = positions[best].second,
              .width = c.width + ox,
              .height = c.height + oy};
  t.overlap_x = ox;
  t.overlap_y = oy;
  t.column_cut = cuts[best].columns.path;
  t.row_cut = cuts[best].rows.path;
  t.cost.edges = cuts[best].columns.edges + cuts[best].rows.edges;
  t.cost.cut_levels =
      (cuts[best].columns.cost + cuts[best].rows.cost) / (2.0 * double(t.cost.edges));
  t.cost.neighbour_levels = sums.neighbour_rms();
  t.positions = positions.size();
  t.images = sums.images;
  return t;
}

PixelMap SeamlessTile::pixel_map(const std::string& description) const {
  PixelMap m;
  m.width = width;
  m.height = height;
  m.region = region;
  m.description = description;
  m.source.reserve(std::size_t(width) * std::size_t(height));
  const int fx = feather_for(overlap_x), fy = feather_for(overlap_y);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float a = x < overlap_x ? weight_of_a(x, column_cut[std::size_t(y)], fx) : 1.0f;
      const float b = y < overlap_y ? weight_of_a(y, row_cut[std::size_t(x)], fy) : 1.0f;
      const auto u = std::uint16_t(x), v = std::uint16_t(y);
      const auto uw = std::uint16_t(x + width), vh = std::uint16_t(y + height);
      std::array<PixelTap, 4> taps{PixelTap{u, v, a * b}, PixelTap{uw, v, (1 - a) * b},
                                   PixelTap{u, vh, a * (1 - b)},
                                   PixelTap{uw, vh, (1 - a) * (1 - b)}};
      for (PixelTap& tap : taps)
        if (tap.weight == 0.0f) tap = {};  // unused: kept inside the region
      m.source.push_back(taps);
    }
  return m;
}

std::string SeamlessTile::describe() const {
  return fmt::format("seamless {}x{} tile cut from {},{},{},{} (overlap {}x{})", width, height,
                     region.x, region.y, region.width, region.height, overlap_x, overlap_y);
}

BtfSource seamless_tile_source(const BtfSource& source, const SeamlessTile& tile) {
  return source.remapped(tile.pixel_map(tile.describe()));
}

BtfSource made_tile_source(const BtfSource& source, const std::string& description) {
  if (description.empty()) return source;
  return seamless_tile_source(source, made_tile_again(source, description));
}

SeamlessTile made_tile_again(const BtfSource& source, const std::string& description) {
  SeamlessTileConfig c;
  int x = 0, y = 0, rw = 0, rh = 0, ox = 0, oy = 0;
  if (std::sscanf(description.c_str(), "seamless %dx%d tile cut from %d,%d,%d,%d (overlap %dx%d)",
                  &c.width, &c.height, &x, &y, &rw, &rh, &ox, &oy) != 8 ||
      rw != c.width + ox || rh != c.height + oy)
    throw Error(Error::Kind::kArgument,
                fmt::format("'{}' names no seamless tile btfgmm made (\"seamless WxH tile cut "
                            "from X,Y,W,H (overlap OXxOY)\")",
                            description));
  c.at = std::pair(x, y);
  c.overlap_x = ox;
  c.overlap_y = oy;
  return cut_seamless_tile(source, c);
}

}  // namespace btfgmm
