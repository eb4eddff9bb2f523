// The seamless-tile search (include/btfgmm/measure/tile.hpp): seam mismatches of every candidate
// position accumulated over a sample of images, summed over a tile's rows or columns with
// prefix sums, so every (position, size) costs O(1).
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <tuple>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/measure/tile.hpp"
#include "io/zip.hpp"

namespace btfgmm {
namespace {

// The sampled (light, view) pairs, by light-major index: `count` spread evenly over `total`.
std::vector<std::size_t> sample_pairs(std::size_t total, std::size_t count) {
  if (count == 0 || count >= total) count = total;
  std::vector<std::size_t> out(count);
  for (std::size_t k = 0; k < count; ++k) out[k] = (k * total) / count;
  return out;
}

void check_config(const TileSearchConfig& c, int W, int H) {
  if (c.min_width < 1 || c.min_height < 1 || c.min_width > c.max_width ||
      c.min_height > c.max_height)
    throw Error(Error::Kind::kArgument,
                fmt::format("tile size {}-{} x {}-{} is empty; give sizes >= 1 with the smaller "
                            "first, e.g. 20-28x24",
                            c.min_width, c.max_width, c.min_height, c.max_height));
  if (c.max_width > W || c.max_height > H)
    throw Error(Error::Kind::kArgument,
                fmt::format("tile size up to {}x{} does not fit in the {}x{} image: give a tile "
                            "no larger than the image (the whole image is judged by the step "
                            "across its own wrap)",
                            c.max_width, c.max_height, W, H));
  const double cells = double(c.max_width - c.min_width + 1 + c.max_height - c.min_height + 1) *
                       double(W) * double(H);
  if (cells > 4e8)
    throw Error(Error::Kind::kArgument,
                fmt::format("tile size ranges {}-{} x {}-{} on a {}x{} image need too much memory; "
                            "give narrower ranges",
                            c.min_width, c.max_width, c.min_height, c.max_height, W, H));
}

// Sums of squared seam mismatches per candidate position, over images and channels.
class SeamSums {
 public:
  SeamSums(int W, int H, const TileSearchConfig& c)
      : W_(W), H_(H), c_(c), row_sums_(std::size_t(H), 0.0), col_sums_(std::size_t(W), 0.0) {
    for (int w = c.min_width; w <= c.max_width; ++w)
      ex_.emplace_back(std::size_t(W - w + 1) * std::size_t(H), 0.0);
    for (int h = c.min_height; h <= c.max_height; ++h)
      ey_.emplace_back(std::size_t(H - h + 1) * std::size_t(W), 0.0);
  }

  // RGB images of W x H pixels. Each row (column) is summed by one thread over all the
  // images, in their order: the sums do not depend on the number of threads. Small jobs run
  // on one thread.
  void add(const std::vector<const float*>& images) {
    const std::size_t W = std::size_t(W_), H = std::size_t(H_);
    const double work =
        double(W) * double(H) * double(images.size()) * double(ex_.size() + ey_.size() + 1);
    const bool parallel = work > 4e6;
#pragma omp parallel for schedule(static) if (parallel)
    for (int yi = 0; yi < H_; ++yi) {
      const std::size_t y = std::size_t(yi);
      for (const float* img : images) {
        auto at = [&](std::size_t x, int c) {
          return double(img[(y * W + x) * 3 + std::size_t(c)]);
        };
        for (std::size_t wi = 0; wi < ex_.size(); ++wi) {
          const std::size_t w = std::size_t(c_.min_width) + wi;
          for (std::size_t x0 = 0; x0 + w <= W; ++x0) {
            double s = 0;
            for (int c = 0; c < 3; ++c) {
              if (x0 + w < W) s += sq(at(x0 + w, c) - at(x0, c));
              if (x0 >= 1) s += sq(at(x0 - 1, c) - at(x0 + w - 1, c));
              if (w == W) s += sq(at(0, c) - at(W - 1, c));  // the whole width: its wrap
            }
            ex_[wi][x0 * H + y] += s;
          }
        }
        double d = 0;
        for (std::size_t x = 0; x + 1 < W; ++x)
          for (int c = 0; c < 3; ++c) d += sq(at(x + 1, c) - at(x, c));
        row_sums_[y] += d;
      }
    }
#pragma omp parallel for schedule(static) if (parallel)
    for (int xi = 0; xi < W_; ++xi) {
      const std::size_t x = std::size_t(xi);
      for (const float* img : images) {
        auto at = [&](std::size_t y, int c) {
          return double(img[(y * W + x) * 3 + std::size_t(c)]);
        };
        for (std::size_t hi = 0; hi < ey_.size(); ++hi) {
          const std::size_t h = std::size_t(c_.min_height) + hi;
          for (std::size_t y0 = 0; y0 + h <= H; ++y0) {
            double s = 0;
            for (int c = 0; c < 3; ++c) {
              if (y0 + h < H) s += sq(at(y0 + h, c) - at(y0, c));
              if (y0 >= 1) s += sq(at(y0 - 1, c) - at(y0 + h - 1, c));
              if (h == H) s += sq(at(0, c) - at(H - 1, c));  // the whole height: its wrap
            }
            ey_[hi][y0 * W + x] += s;
          }
        }
        double d = 0;
        for (std::size_t y = 0; y + 1 < H; ++y)
          for (int c = 0; c < 3; ++c) d += sq(at(y + 1, c) - at(y, c));
        col_sums_[x] += d;
      }
    }
    images_ += images.size();
  }

  // The best tile over all sizes and positions, or the seam error of one given tile.
  TileSearchResult search(std::optional<Tile> only = std::nullopt) {
    // Prefix sums along y (left-right seams) and x (top-bottom seams).
    const std::size_t W = std::size_t(W_), H = std::size_t(H_);
    std::vector<std::vector<double>> px(ex_.size()), py(ey_.size());
    for (std::size_t wi = 0; wi < ex_.size(); ++wi) {
      const std::size_t n = W - (std::size_t(c_.min_width) + wi) + 1;
      px[wi].assign(n * (H + 1), 0.0);
      for (std::size_t x0 = 0; x0 < n; ++x0)
        for (std::size_t y = 0; y < H; ++y)
          px[wi][x0 * (H + 1) + y + 1] = px[wi][x0 * (H + 1) + y] + ex_[wi][x0 * H + y];
    }
    for (std::size_t hi = 0; hi < ey_.size(); ++hi) {
      const std::size_t n = H - (std::size_t(c_.min_height) + hi) + 1;
      py[hi].assign(n * (W + 1), 0.0);
      for (std::size_t y0 = 0; y0 < n; ++y0)
        for (std::size_t x = 0; x < W; ++x)
          py[hi][y0 * (W + 1) + x + 1] = py[hi][y0 * (W + 1) + x] + ey_[hi][y0 * W + x];
    }
    double dx = 0, dy = 0;
    for (double v : row_sums_) dx += v;
    for (double v : col_sums_) dy += v;
    const double per = 3.0 * double(images_);
    dx /= per * double(W - 1) * double(H);
    dy /= per * double(H - 1) * double(W);
    const double tiny = 1e-12;

    TileSearchResult best;
    best.seam.total = std::numeric_limits<double>::infinity();
    best.images = images_;
    auto judge = [&](int w, int h, int x0, int y0) {
      const std::size_t wi = std::size_t(w - c_.min_width), hi = std::size_t(h - c_.min_height);
      const std::size_t ux = std::size_t(x0), uy = std::size_t(y0);
      const double sx = px[wi][ux * (H + 1) + uy + std::size_t(h)] - px[wi][ux * (H + 1) + uy];
      const double sy = py[hi][uy * (W + 1) + ux + std::size_t(w)] - py[hi][uy * (W + 1) + ux];
      const double mx = mean_mismatch(sx / (per * h), x0, w, W_, dx);
      const double my = mean_mismatch(sy / (per * w), y0, h, H_, dy);
      SeamError e;
      e.left_right = mx / std::max(dx, tiny);
      e.top_bottom = my / std::max(dy, tiny);
      e.total = 0.5 * (e.left_right + e.top_bottom);
      e.rms_levels = std::sqrt(0.5 * (mx + my));
      return e;
    };
    if (only) {
      best.tile = *only;
      best.seam = judge(only->width, only->height, only->x, only->y);
      best.score = tile_score(best.seam, only->width, only->height);
      best.candidates = 1;
      return best;
    }
    // The best position of every size, larger sizes first (so that ties keep them).
    std::vector<TileCandidate> per_size;
    for (int w = c_.max_width; w >= c_.min_width; --w)
      for (int h = c_.max_height; h >= c_.min_height; --h) {
        TileCandidate size_best;
        size_best.score = std::numeric_limits<double>::infinity();
        for (int y0 = 0; y0 + h <= H_; ++y0)
          for (int x0 = 0; x0 + w <= W_; ++x0) {
            const SeamError e = judge(w, h, x0, y0);
            ++best.candidates;
            const double score = tile_score(e, w, h);
            if (score < size_best.score)
              size_best = {{.x = x0, .y = y0, .width = w, .height = h}, e, score};
          }
        per_size.push_back(size_best);
      }
    std::stable_sort(
        per_size.begin(), per_size.end(),
        [](const TileCandidate& a, const TileCandidate& b) { return a.score < b.score; });
    per_size.resize(std::min(per_size.size(), std::max<std::size_t>(c_.top, 1)));
    best.tile = per_size[0].tile;
    best.seam = per_size[0].seam;
    best.score = per_size[0].score;
    best.ranked = std::move(per_size);
    return best;
  }

 private:
  // The mean squared mismatch of a seam from its sum per pixel of the tile's side (`sum`) at
  // `start`, `size` long, in an image `full` long. A tile as wide (high) as the image has no
  // neighbour column (row) to be judged against: its seam is the step across its wrap beyond
  // a typical step `typical` (0 when the image tiles).
  static double mean_mismatch(double sum, int start, int size, int full, double typical) {
    if (size == full) return std::max(0.0, sum - typical);
    return sum / double((start >= 1) + (start + size < full));
  }
  static double sq(double v) {
    return v * v;
  }
  int W_, H_;
  TileSearchConfig c_;
  std::vector<double> row_sums_, col_sums_;  // squared neighbour differences per row, column
  std::vector<std::vector<double>> ex_, ey_;
  std::size_t images_ = 0;
};

// One image of a source, whole, as RGB floats (a Bonn zip opened once, its entries read by the
// io layer's zip reader with their sizes checked).
class SourceReader {
 public:
  explicit SourceReader(const BtfSource& s) : src_(s) {}

  Image read(std::size_t light, std::size_t view) {
    const BtfInfo& info = src_.info();
    const std::string& name = src_.image_name(light, view);
    if (info.layout != Layout::kBonnZip) return read_image(info.path / name);
    if (!zip_) zip_ = detail::open_zip(info.path);
    return decode_image(detail::read_zip_entry(zip_.get(), info.path, name),
                        detail::entry_display(info.path, name));
  }

 private:
  const BtfSource& src_;
  detail::Zip zip_;
};

int parse_int(const std::string& s, const std::string& option, const std::string& text) {
  int v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || r.ec != std::errc() || r.ptr != s.data() + s.size() || v < 1 || v > 65536)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}': '{}' is not a size in pixels; give WxH with W and H each a "
                            "number or a range, e.g. 32x32 or 20-28x24",
                            option, text, s));
  return v;
}

std::pair<int, int> parse_range(const std::string& s, const std::string& option,
                                const std::string& text) {
  const std::size_t dash = s.find('-');
  if (dash == std::string::npos) {
    const int v = parse_int(s, option, text);
    return {v, v};
  }
  return {parse_int(s.substr(0, dash), option, text), parse_int(s.substr(dash + 1), option, text)};
}

}  // namespace

double tile_score(const SeamError& seam, int width, int height) {
  return seam.total * double(std::max(width, height)) / double(std::min(width, height));
}

TileSearchConfig parse_tile_search_size(const std::string& text, const std::string& option) {
  const std::size_t x = text.find('x');
  if (x == std::string::npos)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}' is not a tile size; give WxH, each a number or a range, e.g. "
                            "32x32 or 20-28x24",
                            option, text));
  TileSearchConfig c;
  std::tie(c.min_width, c.max_width) = parse_range(text.substr(0, x), option, text);
  std::tie(c.min_height, c.max_height) = parse_range(text.substr(x + 1), option, text);
  if (c.min_width > c.max_width || c.min_height > c.max_height)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}': a range must give the smaller size first, e.g. 20-28x24",
                            option, text));
  return c;
}

TileSearchResult find_seamless_tile(const Btf& btf, const TileSearchConfig& config) {
  check_config(config, btf.width(), btf.height());
  SeamSums sums(btf.width(), btf.height(), config);
  std::vector<const float*> images;
  for (std::size_t k : sample_pairs(btf.image_count(), config.images))
    images.push_back(btf.data().data() + k * btf.image_floats());
  sums.add(images);
  return sums.search();
}

TileSearchResult find_seamless_tile(const BtfSource& source, const TileSearchConfig& config) {
  const BtfInfo& info = source.info();
  check_config(config, info.width, info.height);
  SeamSums sums(info.width, info.height, config);
  const std::size_t nv = info.views.size();
  const std::vector<std::size_t> pairs = sample_pairs(info.lights.size() * nv, config.images);
  if (info.layout == Layout::kUboBtf) {  // decoded from its factors, an image at a time
    std::vector<float> image;
    for (std::size_t k : pairs) {
      source.read_tiles({}, k, k + 1, [&](std::size_t, std::span<const float> rgb) {
        image.assign(rgb.begin(), rgb.end());
      });
      sums.add({image.data()});
    }
    return sums.search();
  }
  const std::size_t batch = std::size_t(std::max(8, 2 * omp_get_max_threads()));
  for (std::size_t b0 = 0; b0 < pairs.size(); b0 += batch) {
    const std::size_t n = std::min(batch, pairs.size() - b0);
    std::vector<Image> images(n);
    std::exception_ptr failure;
#pragma omp parallel
    {
      SourceReader reader(source);
#pragma omp for schedule(dynamic, 1)
      for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(n); ++i) {
        try {
          const std::size_t k = pairs[b0 + std::size_t(i)];
          images[std::size_t(i)] = reader.read(k / nv, k % nv);
        } catch (...) {
#pragma omp critical
          if (!failure) failure = std::current_exception();
        }
      }
    }
    if (failure) std::rethrow_exception(failure);
    std::vector<const float*> batch_images;
    for (std::size_t i = 0; i < n; ++i) {
      const Image& img = images[i];
      if (img.width != info.width || img.height != info.height)
        throw Error(Error::Kind::kFormat,
                    fmt::format("{}: {}x{} pixels where the data set has {}x{}",
                                source.image_name(pairs[b0 + i] / nv, pairs[b0 + i] % nv),
                                img.width, img.height, info.width, info.height));
      batch_images.push_back(img.rgb.data());
    }
    sums.add(batch_images);
  }
  return sums.search();
}

TileSearchResult find_seamless_tile(const BtfSource& source, int width, int height) {
  TileSearchConfig c;
  c.min_width = c.max_width = width;
  c.min_height = c.max_height = height;
  return find_seamless_tile(source, c);
}

SeamError seam_error(const Btf& btf, const Tile& tile, std::size_t images) {
  if (tile.empty() || tile.x < 0 || tile.y < 0 || tile.x + tile.width > btf.width() ||
      tile.y + tile.height > btf.height())
    throw Error(Error::Kind::kArgument,
                fmt::format("tile {},{},{},{} is not inside the {}x{} image", tile.x, tile.y,
                            tile.width, tile.height, btf.width(), btf.height()));
  TileSearchConfig c;
  c.min_width = c.max_width = tile.width;
  c.min_height = c.max_height = tile.height;
  c.images = images;
  check_config(c, btf.width(), btf.height());
  SeamSums sums(btf.width(), btf.height(), c);
  std::vector<const float*> chosen;
  for (std::size_t k : sample_pairs(btf.image_count(), images))
    chosen.push_back(btf.data().data() + k * btf.image_floats());
  sums.add(chosen);
  return sums.search(tile).seam;
}

}  // namespace btfgmm
