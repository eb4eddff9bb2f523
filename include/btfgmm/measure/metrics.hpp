// Image quality as the paper measures it (its Fig. 3; docs/METRICS.md): RMSE, PSNR and SSIM of
// a reconstructed image against the original, per channel and overall, per (light, view)
// image and over the whole BTF. The paper's compression ratio for any tile size (Fig. 4),
// paper_compression_ratio(), is declared with the model in model.hpp.
//
// Scale. Values are in the scale of btf.hpp: 0-255 levels for 8- and 16-bit data. The range R
// used by PSNR = 20 log10(R / RMSE) and by SSIM (C1 = (K1 R)^2, C2 = (K2 R)^2) is 255 for
// such data. For HDR data R is the peak of the original (its largest value; linear HDR values
// are not negative), see data_range(); RMSE is then in the data's own units.
//
// SSIM is Wang et al. 2004: an 11 x 11 Gaussian window, sigma = 1.5, normalised to sum 1,
// K1 = 0.01, K2 = 0.03, population (co)variances, no padding (only windows wholly inside the
// image are averaged), per channel, then the mean of the three channels. It equals
// scikit-image's structural_similarity(a, b, channel_axis=-1, gaussian_weights=True,
// sigma=1.5, use_sample_covariance=False, data_range=R) (tests/ssim_check.py).
//
// Small images. An image narrower or lower than 11 pixels has no 11 x 11 window inside it. The
// window then shrinks to the largest odd size that fits, 2r + 1 <= min(W, H), keeping the same
// Gaussian (sigma = 1.5) cut at radius r and renormalised: the same statistic on the most
// local neighbourhood the image holds, still without padding (scikit-image raises instead).
// A 1-pixel image leaves a 1 x 1 window: SSIM is then the luminance term alone.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "btfgmm/core/btf.hpp"
// paper_compression_ratio(), the paper's compression ratio for any tile size (Fig. 4).
#include "btfgmm/model/model.hpp"

namespace btfgmm {

// The SSIM constants of Wang et al. 2004.
struct SsimSettings {
  int radius = 5;  // window 2 * radius + 1 = 11 pixels wide
  double sigma = 1.5;
  double k1 = 0.01, k2 = 0.03;
};

// The window radius actually used on a width x height image: settings.radius, or less where
// the image is smaller than the window (see above).
int ssim_radius(int width, int height, const SsimSettings& settings = {});

// The mean SSIM of one channel of two RGB-interleaved images (width * height * 3 floats),
// with range R. If `map` is given it receives the SSIM of every window centre, (W - 2r) x
// (H - 2r) values, row-major.
double ssim_channel(std::span<const float> a, std::span<const float> b, int width, int height,
                    int channel, double range, const SsimSettings& settings = {},
                    std::vector<double>* map = nullptr);

// PSNR in dB for an RMSE and a range R: 20 log10(R / rmse); +infinity for rmse = 0.
double psnr_db(double rmse, double range);

// The quality of one reconstructed image against its original.
struct ImageQuality {
  std::array<double, 3> rmse_rgb{}, psnr_db_rgb{}, ssim_rgb{};
  double rmse = 0.0;     // over the pixels and the three channels
  double psnr_db = 0.0;  // of rmse
  double ssim = 0.0;     // mean of the three channels
};

// RMSE, PSNR and SSIM of `reconstruction` against `original` (both width * height * 3
// floats, RGB interleaved) with range R. If `error_image` is given it receives
// |original - reconstruction| per pixel and channel. Throws Error(kArgument) for sizes that do
// not match or a range <= 0.
ImageQuality image_quality(std::span<const float> original, std::span<const float> reconstruction,
                           int width, int height, double range, const SsimSettings& settings = {},
                           std::vector<float>* error_image = nullptr);

// The range R for a BTF's data: 255 for 8- and 16-bit data (the 0-255 scale), the largest
// value for HDR data (1 if it holds nothing above 0).
double data_range(const Btf& original);

// The quality of a whole reconstructed BTF: every (light, view) image and all together.
struct BtfQuality {
  double range = 255.0;  // R used
  int ssim_window = 11;  // 2 r + 1 used (smaller than 11 only for small tiles)
  std::size_t lights = 0, views = 0;
  std::vector<ImageQuality> images;  // light-major, as Btf::image_index

  // Over all images, pixels and channels: RMSE of every value, PSNR of that RMSE (the
  // paper's pairing: RMSE 7.3 <-> 30.9 dB), SSIM the mean over images of the per-image SSIM.
  std::array<double, 3> rmse_rgb{}, psnr_db_rgb{}, ssim_rgb{};
  double rmse = 0.0, psnr_db = 0.0, ssim = 0.0;

  // Image indices (light * views + view) of the worst and best image by PSNR and by SSIM.
  std::size_t worst_psnr = 0, best_psnr = 0, worst_ssim = 0, best_ssim = 0;
  // Image indices sorted from the worst PSNR to the best.
  std::vector<std::size_t> by_psnr() const;
};

// Measures `reconstruction` against `original`: the same direction sets and size are
// required (Error(kArgument) otherwise). `range` <= 0 means data_range(original).
BtfQuality measure_quality(const Btf& original, const Btf& reconstruction, double range = 0.0,
                           const SsimSettings& settings = {});

}  // namespace btfgmm
