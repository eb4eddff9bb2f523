// The common ground of the methods that represent the tile's images at the measured
// directions (PCA BTF, PCA RF, LPCA, PTM RF, PLM RF): a method says how to make the image of
// a measured (light, view) pair, or one pixel of it; this base evaluates any pixel, light
// and view from that, as the renderer evaluates the data (render/data_evaluator.hpp):
// bilinear between the four nearest pixels (the tile wraps), and over the measured
// directions with DirectionInterpolator's barycentric weights (3 lights x 3 views), the
// same interpolation as the mean BRDF's. A method that is analytic in the light (PTM RF,
// PLM RF) overrides the light-taking overloads instead and is evaluated there exactly.
#pragma once

#include <memory>
#include <span>

#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/methods/representation.hpp"

namespace btfgmm {

class MeasuredImages : public Representation {
 public:
  explicit MeasuredImages(ModelFrame frame);
  ~MeasuredImages() override;

  const ModelFrame& frame() const final { return frame_; }

  // RGB of pixel (x, y) (0 <= x < W, 0 <= y < H) of the image of measured light `light` and
  // view `view`, 3 floats.
  virtual void measured_pixel(std::size_t light, std::size_t view, int x, int y,
                              float* rgb) const = 0;
  // The whole W x H image of measured pair (light, view), W*H*3 floats, row-major. The
  // default calls measured_pixel for every pixel; methods override it with their fast form.
  virtual void measured_image(std::size_t light, std::size_t view, float* rgb) const;

  // One pixel of the image of a measured view: the view's index and the tile pixel.
  struct ViewPixel {
    std::size_t view = 0;
    int x = 0, y = 0;
  };
  // Any light, measured views: the RGB of each sample (3 floats each), the measured lights'
  // values blended with their interpolation weights. What depends on the light alone (its
  // weights, a method's basis) is computed once for all the samples, which predict gives
  // grouped by view. Methods analytic in the light override both.
  virtual void light_pixels(const Direction& light, std::span<const ViewPixel> samples,
                            float* rgb) const;
  virtual void light_image(const Direction& light, std::size_t view, float* rgb) const;

  void predict(std::span<const Query> queries, std::span<float> rgb) const override;
  // Measured pairs come straight from measured_image; others are blended over the views
  // (and, unless a method is analytic in the light, the lights). `tolerance` is unused: every
  // value is exact.
  Btf decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
             double tolerance) const override;

 protected:
  const DirectionInterpolator& light_interpolator() const { return *lights_; }
  const DirectionInterpolator& view_interpolator() const { return *views_; }

 private:
  void predict_one(const Query& q, float* rgb) const;

  ModelFrame frame_;
  std::unique_ptr<DirectionInterpolator> lights_, views_;
};

}  // namespace btfgmm
