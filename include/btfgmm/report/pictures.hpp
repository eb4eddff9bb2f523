// The report's pictures, as 8-bit levels for write_png: images of the tile for display, the
// paper's Fig. 3 differences, its Fig. 2 mean BRDF, and the PSNR of every (light, view) image
// as colours. See docs/METRICS.md.
#pragma once

#include <array>
#include <cstddef>
#include <span>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/measure/metrics.hpp"

namespace btfgmm {

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

}  // namespace btfgmm
