// The comparison of the paper's Fig. 3: the metrics of a model rendering against a data
// rendering, and the figure data | model | difference with the metrics written under it
// (docs/RENDERING.md, "The comparison figure").
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "btfgmm/io/image.hpp"

namespace btfgmm {

struct Rendering;  // render.hpp

// RMSE (levels, over the pixels on the object and the three channels, values clamped to
// 0-255 as displayed), PSNR = 20 log10(255 / RMSE), and the mean SSIM (Wang et al. 2004: an
// 11 x 11 Gaussian window, sigma 1.5, K1 = 0.01, K2 = 0.03, L = 255, no padding; per channel;
// averaged over the windows whose centre pixel is on the object).
struct RenderComparison {
  double rmse = 0.0, psnr = 0.0, ssim = 0.0;
  std::size_t pixels = 0;  // object pixels compared
};
RenderComparison compare_renderings(const Rendering& reference, const Rendering& test);

// What the comparison figure writes besides the metrics: the model's name and size ("gm,
// M = 600"), and lines that state the scene (light, camera, mesh, tile repeat, tolerance).
struct FigureCaption {
  std::string model;
  std::vector<std::string> scene;
};

// data | model | difference x `difference_scale` side by side, each panel titled, with a
// grey scale of the difference (0 to 255 / difference_scale levels), the metrics (and what
// they are measured over) and the caption's scene written under them in a TrueType font
// (render/font.hpp). Values clamped to 0-255.
Image comparison_figure(const Rendering& data, const Rendering& model,
                        const RenderComparison& metrics, double difference_scale = 10.0,
                        const FigureCaption& caption = {});

}  // namespace btfgmm
