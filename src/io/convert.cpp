// Converting a data set to the nested UTIA layout (io/convert.hpp): the tile of each image is
// read (decoded, for a .btf file), scaled for PNG by the stated exposure, and written
// atomically; conversion.txt states what was written.
#include "btfgmm/io/convert.hpp"

#include <fmt/format.h>

#include <cmath>
#include <mutex>
#include <system_error>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/io/image_names.hpp"
#include "io/angle_names.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

ImageFormat output_format(const BtfInfo& info, const ConvertOptions& o, const fs::path& folder) {
  const ImageFormat f =
      o.format.value_or(info.format == SampleFormat::kHdr ? ImageFormat::kExr : ImageFormat::kPng);
  if (f == ImageFormat::kJpeg)
    throw Error(Error::Kind::kArgument,
                fmt::format("cannot write {} as JPEG (lossy); write PNG or EXR", folder.string()));
  if (!std::isfinite(o.exposure) || o.exposure <= 0.0)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("exposure {} is not a positive number; give e.g. 1 or 0.5", o.exposure));
  return f;
}

// The levels a PNG holds per unit of value: 255 * exposure for HDR data, exposure for levels.
double png_scale(const BtfInfo& info, double exposure) {
  return info.format == SampleFormat::kHdr ? 255.0 * exposure : exposure;
}

std::vector<fs::path> make_view_folders(const DirectionSet& views, const fs::path& folder) {
  std::vector<fs::path> dirs;
  for (const Direction& v : views) {
    dirs.push_back(folder / detail::angles(v, "tv", "pv", '_'));
    std::error_code ec;
    fs::create_directories(dirs.back(), ec);
    if (ec)
      throw Error(Error::Kind::kIo, fmt::format("cannot create the folder {}: {}",
                                                dirs.back().string(), ec.message()));
  }
  return dirs;
}

std::string conversion_note(const BtfInfo& info, const Tile& t, ImageFormat f, double exposure) {
  std::string note = fmt::format(
      "source: {} ({})\ntile: x={} y={} {}x{} of {}x{}\nimages: {} lights x {} views\nformat: {}\n",
      info.path.string(), to_string(info.layout), t.x, t.y, t.width, t.height, info.width,
      info.height, info.lights.size(), info.views.size(), to_string(f));
  for (const auto& [name, value] : info.details)
    if (name == "made image") note += fmt::format("made: {}\n", value);
  if (f == ImageFormat::kExr) return note + "values: linear, as decoded (32-bit float)\n";
  if (info.format == SampleFormat::kHdr)
    return note + fmt::format(
                      "values: 8-bit linear levels = round(255 x {} x value), clamped to "
                      "0..255 (exposure {}; no sRGB curve)\n",
                      exposure, exposure);
  return note + fmt::format(
                    "values: 8-bit levels = round({} x level), clamped to 0..255 "
                    "(exposure {})\n",
                    exposure, exposure);
}

}  // namespace

ConvertPlan plan_conversion(const BtfSource& source, const Tile& tile, const fs::path& folder,
                            const ConvertOptions& o) {
  const BtfInfo& info = source.info();
  ConvertPlan p;
  p.format = output_format(info, o, folder);
  p.tile = tile.or_whole(info.width, info.height);
  p.images = info.lights.size() * info.views.size();
  const std::uint64_t per_pixel = p.format == ImageFormat::kExr ? 12 : 3;
  p.pixel_bytes = std::uint64_t(p.images) * std::uint64_t(p.tile.width) *
                  std::uint64_t(p.tile.height) * per_pixel;
  return p;
}

ConvertResult convert_to_utia(const BtfSource& source, const Tile& tile, const fs::path& folder,
                              const ConvertOptions& o) {
  const BtfInfo& info = source.info();
  const ConvertPlan plan = plan_conversion(source, tile, folder, o);
  ConvertResult r;
  r.format = plan.format;
  r.tile = plan.tile;
  const std::size_t nv = info.views.size(), n = plan.images;
  const std::vector<fs::path> view_dirs = make_view_folders(info.views, folder);
  const char* ext = r.format == ImageFormat::kExr ? ".exr" : ".png";
  const double scale = png_scale(info, o.exposure);
  std::mutex progress_mutex;
  std::size_t written = 0;
  source.read_tiles(r.tile, 0, n, [&](std::size_t i, std::span<const float> rgb) {
    if (o.stopped && o.stopped())
      throw Error(Error::Kind::kArgument, fmt::format("stopped: {} images of {} written to {}",
                                                      written, n, folder.string()));
    const fs::path p =
        view_dirs[i % nv] / (utia_image_stem(info.lights[i / nv], info.views[i % nv]) + ext);
    if (r.format == ImageFormat::kExr) {
      write_exr(p, r.tile.width, r.tile.height, rgb);
    } else {
      std::vector<float> levels(rgb.begin(), rgb.end());
      for (float& v : levels) v = float(v * scale);
      write_png(p, r.tile.width, r.tile.height, levels);
    }
    const std::lock_guard<std::mutex> lock(progress_mutex);
    ++written;
    if (o.progress) o.progress(double(written) / double(n));
  });
  r.images = n;
  r.note = conversion_note(info, r.tile, r.format, o.exposure);
  write_file_atomically(
      folder / "conversion.txt",
      std::span(reinterpret_cast<const std::uint8_t*>(r.note.data()), r.note.size()),
      "conversion note");
  return r;
}

}  // namespace btfgmm
