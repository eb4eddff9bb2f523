// Each image's colour: the per-channel mean and standard deviation of every (light, view)
// image of a tile (internal), what the texture models match their synthesis to
// (docs/METHODS.md, "The probabilistic texture models"). The means are the mean BRDF the
// mixture stores; both are kept as codes of a byte (for 8-bit data steps of one level for the
// means, half a level for the deviations), predicted from their neighbours on the light x
// view grid as the mixture's mean BRDF is (model/compact.hpp).
#pragma once

#include <cstddef>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

struct ImageMoments {
  std::vector<float> mean, deviation;  // 3 per image, light-major (Btf::image_index)
  double mean_step = 1.0, deviation_step = 1.0;
  // Each subspace's marginal (measure_marginal), 3 x kQuantiles values a subspace.
  std::vector<std::vector<float>> marginals;

  bool empty() const { return mean.empty(); }
  std::size_t images() const { return mean.size() / 3; }
};

// Every image's moments, rounded to their codes (what a file written and read holds): for 8-
// and 16-bit data (held on 0-255) in steps of kMeanStep and kDeviationStep levels, the mean
// BRDF's step in the mixture and half of it (a level and half a level: codes of a byte);
// for HDR data in steps of the largest value / 255. Format version 6 took the largest / 255
// for all data, finer steps than the means' and deviations' own noise, in more bytes.
constexpr double kMeanStep = 1.0, kDeviationStep = 0.5;
ImageMoments measure_image_moments(const Btf& tile);

// How the moments' codes are laid out: each less the one before it in its plane, modulo 256
// (format version 6, flags kImageMoments), or predicted from their neighbours on the light x
// view grid as the mixture's mean BRDF is (version 7 on, flags kImageMoments |
// kPredictedImageMoments).
enum class MomentsCoding { kDeltas, kPredicted };

// f32 mean step, f32 deviation step, u64 C, u32 P, then P bytes: a zstd frame of C bytes, six
// columns of ni*nv codes (model/compact.hpp): the planes G, R - G, B - G of the means' codes
// and of the deviations', each code less the plane through its neighbours on the light x view
// grid of `views` views a light (predicted_colour_planes).
void put_image_moments(ByteWriter& w, const ImageMoments& m, std::size_t views);
// Reads what put_image_moments wrote (kPredicted) or version 6's block (kDeltas: f32 mean
// step, f32 deviation step, u32 P, then P bytes: a zstd frame of 6 n bytes, the planes mean
// R, G, B, deviation R, G, B, each n codes light-major, each code stored less the one before
// it in its plane, modulo 256) for `images` images; r.fail() on anything out of range (a code
// outside 0..255 among them).
ImageMoments get_image_moments(ByteReader& r, std::size_t images, std::size_t views,
                               MomentsCoding coding);

// An image's (pixels RGB values) mean and deviation per channel.
void measure_moments(const float* rgb, std::size_t pixels, float* mean, float* deviation);

// The image made to have `mean` and `deviation` per channel: each channel scaled about its
// own mean to the deviation and moved to the mean (moment matching); a constant channel
// takes the mean alone.
void match_moments(float* rgb, std::size_t pixels, const float* mean, const float* deviation);

// 8-bit and 16-bit data are held on 0-255 and cannot leave it: a value of a synthesis of such
// data rolled off smoothly into (1, 254) past knees kKnee levels inside (v' = knee + kKnee
// tanh((v - knee) / kKnee)), so that it is never clipped at 0 or 255 (values between the
// knees unchanged, the map monotonic): the data's own saturated values are the only ones.
constexpr float kKnee = 8.0f;
float within_levels(float v);

// A subspace's marginal distribution per channel: the standardised values (v - mean) / deviation
// of its representative image at kQuantiles evenly spaced ranks (0, 1/32, .., 1), 3 x
// kQuantiles values, channel-major. A Gaussian field's tails leave the data's range (values
// clipped at 0 or 255 where the data has none) and miss its skew (dark grooves, bright
// highlights): the synthesis is mapped onto this distribution by rank (histogram matching)
// before its moments are matched.
constexpr std::size_t kQuantiles = 33;
std::vector<float> measure_marginal(const float* rgb, std::size_t pixels);
// Per channel f32 lowest, f32 highest, then kQuantiles u8 codes between them (0 the lowest,
// 255 the highest); what measure_marginal returns is already rounded to them.
void put_marginal(ByteWriter& w, const std::vector<float>& z);
std::vector<float> get_marginal(ByteReader& r);
// Each channel of the field (pixels RGB values) replaced, rank for rank, by the quantile
// function of `z` (linear between the quantiles), in the channel's own mean and deviation.
void match_marginal(float* rgb, std::size_t pixels, const std::vector<float>& z);

}  // namespace btfgmm::detail
