// Statistics that measure a model which synthesises new texture (methods/texture_models.hpp)
// against its data, where pixel-wise figures mean nothing (docs/METRICS.md). Per image: each
// channel's mean and standard deviation, the luminance's normalised autocorrelation at lags
// 1 to 4 along x and along y, its histogram, the share of saturated values and the largest
// jump between neighbouring row or column means (a streak); then the image compared with
// its data image, the synthesis at any size.
#pragma once

#include <array>
#include <span>
#include <vector>

#include "btfgmm/core/btf.hpp"

namespace btfgmm {

constexpr int kTextureLags = 4;  // autocorrelation lags 1..kTextureLags along x and along y

// One RGB image's statistics (`texture_image_statistics`).
struct TextureImageStatistics {
  int width = 0, height = 0;
  std::array<double, 3> mean{}, deviation{};
  // rho(s) = sum (Y_r - m)(Y_{r+s} - m) / sum (Y_r - m)^2 of the luminance (R + G + B) / 3 on
  // the torus, s = (k, 0) in x and (0, k) in y, k = 1..kTextureLags.
  std::array<double, kTextureLags> rho_x{}, rho_y{};
  // The share of the values (pixels x channels) at or beyond the 8-bit range's ends,
  // <= 0.5 or >= 254.5: what an 8-bit image would clip.
  double saturated = 0;
  // The largest |difference| between neighbouring column means or neighbouring row means
  // (each over the channels' mean, the image wrapping), in the data's scale.
  double streak = 0;
  std::vector<double> luminance;
};

TextureImageStatistics texture_image_statistics(std::span<const float> rgb, int width, int height);

// A synthesised image against its data image (the sizes may differ).
struct TextureImageComparison {
  std::array<double, 3> mean_difference{};  // model - data, per channel
  std::array<double, 3> deviation_ratio{};  // model / data, per channel (1 where both are 0)
  // The largest |rho_model - rho_data| over the lags 1..4 in x and y.
  double autocorrelation_difference = 0;
  // The total-variation distance (half the L1 distance, 0 to 1) of the luminance histograms,
  // 32 bins over the data image's range.
  double histogram_distance = 0;
  double streak_ratio = 0;  // model streak / data streak (data streak at least 1e-6)
  double saturated_data = 0, saturated_model = 0;
};

TextureImageComparison compare_texture_images(const TextureImageStatistics& data,
                                              const TextureImageStatistics& model);

struct TextureStatistics {
  int max_lag = kTextureLags;
  // Means over the images of each channel's mean and standard deviation, data and model.
  std::array<double, 3> data_mean{}, model_mean{}, data_deviation{}, model_deviation{};
  // Means over the images and channels of |mean_model - mean_data| and of
  // |deviation_model - deviation_data|, in the data's scale.
  double mean_difference = 0, deviation_difference = 0;
  // Mean over the images of the histogram distance (TextureImageComparison).
  double histogram_distance = 0;
  // Mean over the images of the mean |rho_model - rho_data| over the lags 1..4 in x and y.
  double autocorrelation_difference = 0;
  // The worst image of each: the largest |mean difference| of a channel, the smallest and
  // largest deviation ratio, the largest autocorrelation difference and streak ratio.
  double worst_mean_difference = 0, worst_autocorrelation_difference = 0, worst_streak_ratio = 0;
  double lowest_deviation_ratio = 1, highest_deviation_ratio = 1;
  // Shares of saturated values over all images, data and model.
  double saturated_data = 0, saturated_model = 0;
};

// `model` decoded at the data's directions (any size: a synthesis larger than the tile is
// compared with the tile). Asserts equal image counts.
TextureStatistics texture_statistics(const Btf& data, const Btf& model);

// The same from the per-image comparisons.
TextureStatistics summarise_texture(std::span<const TextureImageComparison> images,
                                    std::span<const TextureImageStatistics> data,
                                    std::span<const TextureImageStatistics> model);

}  // namespace btfgmm
