// The range map of a BTF tile (Haindl & Filip, PAMI 2007, Sec. 3; docs/METHODS.md): the
// surface's relief, estimated from the images seen from the top view. Photometric stereo
// (Woodham 1980) gives a normal per pixel, the Lambertian intensity I = rho (n . l) solved by
// least squares over the lights; Frankot-Chellappa integration (1988) turns the normals'
// gradients into heights by FFT, which makes the range map periodic: it tiles without seams.
// The probabilistic texture models store it and shade their synthesis with its relief.
#pragma once

#include <cstddef>
#include <filesystem>
#include <vector>

#include "btfgmm/core/btf.hpp"

namespace btfgmm {

struct RangeMap {
  int width = 0, height = 0;
  std::vector<float> heights;  // W*H, in pixel units, mean 0, row-major
  std::vector<float> normals;  // W*H*3 unit normals (x, y, z), from photometric stereo
};

struct RangeMapSettings {
  // Lights above this elevation from the normal are left out of the photometric stereo:
  // grazing light is mostly shadow there.
  double max_light_theta_deg = 60.0;
  // At each pixel the darkest and the brightest of these fractions of the lights are left
  // out: shadows and highlights, which the Lambertian model does not hold.
  double shadow_fraction = 0.25, highlight_fraction = 0.1;
};

// The view of `btf` nearest the top (smallest elevation).
std::size_t top_view(const Btf& btf);

// Photometric stereo on one view's images: W*H*3 unit normals. Values of 8- and 16-bit data
// are taken as sRGB levels and made linear first; the intensity is the mean of R, G and B.
// Throws Error(kArgument) when fewer than 3 lights lie within the settings' elevation or
// they do not span three dimensions.
std::vector<float> photometric_normals(const Btf& btf, std::size_t view,
                                       const RangeMapSettings& settings = {});

// Frankot-Chellappa: the periodic height field (mean 0) whose gradient is nearest, in least
// squares, to p = -nx/nz, q = -ny/nz of the W*H*3 normals.
std::vector<float> frankot_chellappa(const std::vector<float>& normals, int width, int height);

// Both steps on the top view. Throws as photometric_normals.
RangeMap estimate_range_map(const Btf& btf, const RangeMapSettings& settings = {});

// Writes the heights to `path` (.exr: the heights as they are, in R, G and B; .png: scaled
// to 0-255 from the lowest to the highest) and the normal map beside it as
// STEM-normals.png ((n + 1) / 2 as 0-255 levels). Returns the normal map's path. Throws
// Error(kArgument) for another extension, Error(kIo) when a file cannot be written.
std::filesystem::path write_range_map(const std::filesystem::path& path, const RangeMap& map);

}  // namespace btfgmm
