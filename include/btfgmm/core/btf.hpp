// The BTF container: one RGB float image for every (light, view) pair.
//
// Values keep the scale of the source: 8-bit and 16-bit images are held as levels on the
// 0-255 scale (8-bit data is held exactly, as whole numbers), HDR (EXR) data as the stored
// linear floats. format() says which.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/directions.hpp"

namespace btfgmm {

enum class SampleFormat {
  kLdr8,   // 8-bit per channel (PNG, JPEG); values are 0..255 levels
  kLdr16,  // 16-bit per channel PNG; values scaled to 0..255 (v / 257)
  kHdr,    // floating point (EXR); linear values as stored
};
std::string to_string(SampleFormat f);

// A rectangle of pixels: x, y of its top-left corner, width, height. An empty tile (width or
// height 0) means the whole image where a function accepts it.
struct Tile {
  int x = 0, y = 0, width = 0, height = 0;
  bool empty() const { return width <= 0 || height <= 0; }
  bool operator==(const Tile&) const = default;
  // This tile, or where it is empty (none asked), the whole image of width x height.
  Tile or_whole(int image_width, int image_height) const {
    return empty() ? Tile{.x = 0, .y = 0, .width = image_width, .height = image_height} : *this;
  }
};

class Btf {
 public:
  Btf() = default;
  // Zero-filled images. Throws Error(kArgument) for empty direction sets or a size < 1.
  Btf(DirectionSet lights, DirectionSet views, int width, int height, SampleFormat format);

  const DirectionSet& lights() const { return lights_; }
  const DirectionSet& views() const { return views_; }
  int width() const { return width_; }
  int height() const { return height_; }
  SampleFormat format() const { return format_; }

  // Where this BTF was cut from its source (x, y in the source image); {0, 0, w, h} when it
  // is the whole image.
  const Tile& origin() const { return origin_; }
  void set_origin(const Tile& t) { origin_ = t; }
  // What made the images when they are not a crop of the source's as on disk (a seamless tile
  // cut from a larger region, btfgmm/measure/seamless_tile.hpp): its description, which a
  // model's provenance records as the setting "tile"; empty for a crop.
  const std::string& made_from() const { return made_from_; }
  void set_made_from(std::string what) { made_from_ = std::move(what); }

  std::size_t image_count() const { return lights_.size() * views_.size(); }
  // Images are ordered light-major: index = light * views().size() + view (the Bonn order).
  std::size_t image_index(std::size_t light, std::size_t view) const {
    return light * views_.size() + view;
  }
  // floats per image: width * height * 3, row-major, RGB interleaved.
  std::size_t image_floats() const { return std::size_t(width_) * height_ * 3; }

  float* image(std::size_t light, std::size_t view) {
    return data_.data() + image_index(light, view) * image_floats();
  }
  const float* image(std::size_t light, std::size_t view) const {
    return data_.data() + image_index(light, view) * image_floats();
  }
  float& at(std::size_t light, std::size_t view, int x, int y, int c) {
    return image(light, view)[(std::size_t(y) * width_ + x) * 3 + c];
  }
  float at(std::size_t light, std::size_t view, int x, int y, int c) const {
    return image(light, view)[(std::size_t(y) * width_ + x) * 3 + c];
  }

  std::span<float> data() { return data_; }
  std::span<const float> data() const { return data_; }

 private:
  DirectionSet lights_, views_;
  int width_ = 0, height_ = 0;
  SampleFormat format_ = SampleFormat::kLdr8;
  Tile origin_;
  std::string made_from_;
  std::vector<float> data_;
};

}  // namespace btfgmm
