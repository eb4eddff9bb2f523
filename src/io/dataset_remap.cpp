// A data set whose images are made of another's pixels (io/dataset.hpp, PixelMap): the map's
// region of each image is read as the source reads it, one image per thread at a time, and
// its pixels gathered into the made image.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/dataset.hpp"

namespace btfgmm {
namespace {

void check_map(const BtfInfo& info, const PixelMap& m) {
  const Tile& r = m.region;
  if (m.width < 1 || m.height < 1 || r.empty() || r.x < 0 || r.y < 0 ||
      std::int64_t(r.x) + r.width > info.width || std::int64_t(r.y) + r.height > info.height)
    throw Error(Error::Kind::kArgument,
                fmt::format("a {}x{} image made of the region x={} y={} {}x{} of {} ({}x{}): the "
                            "region must lie inside the images and the made image be at least "
                            "1x1",
                            m.width, m.height, r.x, r.y, r.width, r.height, info.path.string(),
                            info.width, info.height));
  if (m.source.size() != std::size_t(m.width) * std::size_t(m.height))
    throw Error(Error::Kind::kArgument,
                fmt::format("a {}x{} image made of {}: the map has {} pixels, not {}", m.width,
                            m.height, info.path.string(), m.source.size(),
                            std::size_t(m.width) * std::size_t(m.height)));
  for (const auto& taps : m.source) {
    double sum = 0.0;
    for (const PixelTap& t : taps) {
      if (t.weight != 0.0f && (t.dx >= r.width || t.dy >= r.height))
        throw Error(
            Error::Kind::kArgument,
            fmt::format("a {}x{} image made of {}: the map takes pixel {},{} of a {}x{} "
                        "region",
                        m.width, m.height, info.path.string(), t.dx, t.dy, r.width, r.height));
      sum += t.weight;
    }
    if (!(std::abs(sum - 1.0) < 1e-4))
      throw Error(Error::Kind::kArgument,
                  fmt::format("a {}x{} image made of {}: a pixel's weights sum to {}, not 1",
                              m.width, m.height, info.path.string(), sum));
  }
}

}  // namespace

BtfSource BtfSource::remapped(PixelMap map) const {
  check_map(info_, map);
  BtfSource s;
  s.info_ = info_;
  s.info_.width = map.width;
  s.info_.height = map.height;
  s.info_.details.emplace_back("made image", map.description);
  s.names_ = names_;
  s.original_ = std::make_shared<const BtfSource>(*this);
  s.map_ = std::make_shared<const PixelMap>(std::move(map));
  return s;
}

void BtfSource::read_mapped_tiles(const Tile& tile, std::size_t first, std::size_t last,
                                  const TileSink& take) const {
  const PixelMap& m = *map_;
  const Tile t = tile.or_whole(m.width, m.height);
  if (t.x < 0 || t.y < 0 || std::int64_t(t.x) + t.width > m.width ||
      std::int64_t(t.y) + t.height > m.height)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("tile x={} y={} {}x{} is not inside the {}x{} images of {} ({})", t.x, t.y,
                    t.width, t.height, m.width, m.height, info_.path.string(), m.description));
  const std::size_t rw = std::size_t(m.region.width);
  const bool levels = info_.format == SampleFormat::kLdr8;
  original_->read_tiles(m.region, first, last, [&](std::size_t i, std::span<const float> rgb) {
    std::vector<float> out(std::size_t(t.width) * std::size_t(t.height) * 3);
    float* o = out.data();
    for (int y = t.y; y < t.y + t.height; ++y)
      for (int x = t.x; x < t.x + t.width; ++x) {
        float v[3] = {0.0f, 0.0f, 0.0f};
        for (const PixelTap& tap : m.source[std::size_t(y) * std::size_t(m.width) + x]) {
          if (tap.weight == 0.0f) continue;
          const float* p = rgb.data() + (std::size_t(tap.dy) * rw + tap.dx) * 3;
          for (int c = 0; c < 3; ++c) v[c] += tap.weight * p[c];
        }
        for (float c : v) *o++ = levels ? std::round(c) : c;
      }
    take(i, out);
  });
}

}  // namespace btfgmm
