// Parts of the HTML report (report.cpp) written in files of their own: the curves
// (curves.cpp), the image decoded by each method (methods_figure.cpp) and the models side by
// side (side_by_side.cpp), and the number
// formats and file helpers every part shares.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <span>
#include <string>

#include "btfgmm/core/text.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/measure/compare.hpp"

namespace btfgmm::report {

// ---- numbers as the report writes them -------------------------------------------------------

inline std::string angles(const Direction& d) {
  return fmt::format("&theta; {:g}&deg; &phi; {:g}&deg;", d.theta_deg, d.phi_deg);
}

inline std::string db(double v) {
  return std::isfinite(v) ? fmt::format("{:.2f}", v) : std::string("&infin;");
}

// RMSE for people: levels with 2 decimals; HDR data (any scale) with 4 significant digits.
inline std::string rmse_text(double v, SampleFormat f) {
  return f == SampleFormat::kHdr ? fmt::format("{:.4g}", v) : fmt::format("{:.2f}", v);
}

inline std::string ratio(double r) {
  return r >= 100 ? fmt::format("1:{:.0f}", r) : fmt::format("1:{:.1f}", r);
}

// A time with its unit: "12.3 s", "m:ss min", "h:mm:ss h".
inline std::string time_text(double s) {
  const std::string t = human_seconds(s);
  if (s < 60) return t;
  return t + (std::lround(s) < 3600 ? " min" : " h");
}

inline std::string tile_text(const Tile& t) {
  return fmt::format("{}&times;{} at ({}, {})", t.width, t.height, t.x, t.y);
}

// ---- files ---------------------------------------------------------------------------------

inline void save_png(const std::filesystem::path& folder, const std::string& name,
                     const Image& image) {
  write_png(folder / name, image.width, image.height, image.rgb);
}

// The factor that enlarges `largest` pixels to at least `target`.
inline int upscale_for(int largest, int target) {
  return std::max(1, (target + largest - 1) / largest);
}

// ---- the parts -----------------------------------------------------------------------------

// The curves: compression ratio against tile size, PSNR against M, rate-distortion.
std::string curves_section(std::span<const ModelComparison> models);

// The frontal (light, view) pair decoded by each method beside the original, for the models
// of the first model's tile; writes its PNG pictures into `folder`. Empty for one model.
std::string methods_figure(const std::filesystem::path& folder,
                           std::span<const ModelComparison> models);

// The models of the first model's tile side by side: a row per (light, view) pair (the first
// model's two worst images by PSNR and a typical one, its median PSNR), original | model 1 |
// model 2 | ..., each labelled with its file, method, size and that image's PSNR; a synthesis
// model's picture says it is new texture, and beside the data tiled 2 x 2 its synthesis at
// twice the tile's size. `data`: the first model's tile of the data (null: the pairs the first
// model pictures). Writes its PNG pictures into `folder`. Empty for fewer than two models of
// that tile.
std::string side_by_side(const std::filesystem::path& folder,
                         std::span<const ModelComparison> models, const Btf* data);

}  // namespace btfgmm::report
