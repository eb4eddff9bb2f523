// A model compared with the BTF it was fitted to, and the report a person looks at: the
// paper's Fig. 2 (the mean BRDF as an ni x nv image), Fig. 3 (original | model | 10 x
// difference with RMSE / PSNR / SSIM and compression ratios), Fig. 4 (compression ratio
// against tile size) and rate-distortion curves, written as PNG pictures, inline SVG and one
// self-contained index.html (no network, no server). See docs/METRICS.md.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/measure/metrics.hpp"
#include "btfgmm/model/model.hpp"

namespace btfgmm {

// One (light, view) pair pictured: its original and model images (the tile, in the data's
// scale) and why it was chosen.
struct PicturedPair {
  std::size_t light = 0, view = 0;
  std::string label;  // e.g. "frontal light and view", "worst PSNR 1"
  std::vector<float> original, model;
};

struct ModelComparison {
  std::string name;  // how the report names the model (its file)
  BtfModel model;
  std::uint64_t file_bytes = 0;  // the size of the model file (0: not written)
  Tile tile;                     // the tile of the source the model was fitted to
  BtfQuality quality;            // the model against the original tile
  BtfQuality mean_brdf_only;     // the mean BRDF alone (every pixel its image's mean)
  std::vector<float> mean_brdf;  // of the original tile, ni * nv * 3 (Fig. 2)
  std::vector<PicturedPair> pairs;
};

struct CompareOptions {
  std::size_t worst_pairs = 3;  // pictures of the worst images by PSNR
  SsimSettings ssim;
};

// Decodes `model` at its own direction sets and tile size, measures it against `original` (the
// tile it was fitted to) and keeps the images of the pairs to picture: frontal light and view,
// a grazing light, a grazing view, then the worst by PSNR. Throws Error(kArgument) naming
// `name` if the original's direction sets or size differ from the model's.
ModelComparison compare_model(const Btf& original, const BtfModel& model, const std::string& name,
                              std::uint64_t file_bytes, const CompareOptions& options = {});

// ---- pictures (8-bit levels, for write_png) -----------------------------------------------

// An image for display: 8-bit data as its levels; HDR data divided by `range` and
// sRGB-encoded to 0..255.
Image display_image(std::span<const float> rgb, int width, int height, SampleFormat format,
                    double range);
// scale x |original - model| (the paper's Fig. 3 uses 10), in levels (HDR: levels of range/255).
Image difference_image(std::span<const float> original, std::span<const float> model, int width,
                       int height, SampleFormat format, double range, double scale = 10.0);
// Every pixel repeated factor x factor times.
Image upscale_nearest(const Image& image, int factor);
// The mean BRDF as the paper's Fig. 2: ni rows (lights) x nv columns (views), scaled so the
// brightest value is 255 (HDR: then sRGB-encoded).
Image mean_brdf_image(std::span<const float> mean_brdf, std::size_t lights, std::size_t views,
                      SampleFormat format);
// The viridis colour map at t in [0, 1] (clamped), 0..255 per channel.
std::array<float, 3> colour_map(double t);
// PSNR per (light, view) image as colours: ni rows x nv columns, lo_db (and below) at
// colour_map(0), hi_db (and above, and an exact image) at colour_map(1).
Image psnr_map_image(const BtfQuality& quality, double lo_db, double hi_db);
// The colour scale of psnr_map_image for a quality: whole dB around the finite per-image
// PSNRs.
std::array<double, 2> psnr_map_range(const BtfQuality& quality);

// ---- curves (inline SVG) ------------------------------------------------------------------

struct ChartSeries {
  std::string label;
  std::vector<std::array<double, 2>> points;  // (x, y)
  std::string colour = "#2563eb";
  bool line = true;      // join the points in order
  bool dashed = false;   // ... with a dashed line
  bool markers = false;  // a dot at every point
  bool hollow = false;   // ... hollow
};

struct Chart {
  std::string title, x_label, y_label;
  std::vector<ChartSeries> series;
  int width = 420, height = 300;
  bool x_from_zero = false, y_from_zero = false;
  bool x_integer = false;  // x takes whole numbers (e.g. M): ticks only at whole numbers
};

// A line/scatter chart as an <svg> element (no xmlns, for inline HTML): nice ticks, axis
// labels, a legend.
std::string svg_chart(const Chart& chart);

// The compression ratio against tile size (the paper's Fig. 4) for the direction sets of the
// models compared: a line per distinct M (and M = 600, the paper's setting), the models as
// points by the paper's count and by their file bytes.
Chart compression_ratio_chart(std::span<const ModelComparison> models);

// ---- the report ---------------------------------------------------------------------------

// Writes `folder`/index.html and its PNG pictures next to it (the folder is created if
// needed; files of the same names are replaced). `btf_name` names the BTF in the title.
// Throws Error(kArgument) for no models, Error(kIo) if a file cannot be written.
void write_report(const std::filesystem::path& folder, const std::string& btf_name,
                  std::span<const ModelComparison> models);

}  // namespace btfgmm
