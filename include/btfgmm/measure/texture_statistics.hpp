// Statistics that measure a model which synthesises new texture (methods/texture_models.hpp)
// against its data, where pixel-wise figures mean nothing (docs/METRICS.md): per image and
// channel the mean and standard deviation, the luminance histogram, and the normalised
// autocorrelation up to a lag; each averaged over the images.
#pragma once

#include <array>

#include "btfgmm/core/btf.hpp"

namespace btfgmm {

struct TextureStatistics {
  int max_lag = 4;  // autocorrelation lags (dx, dy) with |dx|, |dy| <= max_lag
  // Means over the images of each channel's mean and standard deviation, data and model.
  std::array<double, 3> data_mean{}, model_mean{}, data_deviation{}, model_deviation{};
  // Means over the images and channels of |mean_model - mean_data| and of
  // |deviation_model - deviation_data|, in the data's scale.
  double mean_difference = 0, deviation_difference = 0;
  // Mean over the images of the total-variation distance (half the L1 distance, 0 to 1) of
  // the luminance histograms, 32 bins over the data image's range.
  double histogram_distance = 0;
  // Mean over the images of the mean |rho_model(s) - rho_data(s)| over the lags s != 0, rho
  // the luminance's autocorrelation normalised by its variance, on the torus.
  double autocorrelation_difference = 0;
};

// `model` decoded at the data's directions and size. Asserts equal shapes.
TextureStatistics texture_statistics(const Btf& data, const Btf& model, int max_lag = 4);

}  // namespace btfgmm
