// One BTF subspace's texture model (internal): the RGB image of a subspace learnt by one of
// Haindl & Filip's probabilistic models (PAMI 2007) and synthesised at any size from a seed.
//   3D CAR: one causal autoregressive field of the RGB vector (methods/car.hpp).
//   2D CAR: the colour decorrelated by the Karhunen-Loeve transform, a CAR per band.
//   GMRF:   the same bands, a Gaussian Markov random field per band (methods/gmrf.hpp).
// Each on every level of the image's Gaussian-Laplacian pyramid (methods/pyramid.hpp; Haindl &
// Filip 2007, Sec. 4): a model per level, the levels synthesised alone and collapsed.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "methods/texture_field.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

enum class TextureKind : std::uint8_t { kCar3d = 0, kCar2d = 1, kGmrf = 2 };

// How a CAR model is synthesised: in raster order with warm-up passes (synthesise_car, the
// files before format version 6, which keep synthesising as they did) or solved exactly on
// the torus (synthesise_car_spectral, every fit since). GMRF takes its FFT synthesis either way.
enum class CarSynthesis : std::uint8_t { kRaster, kSpectral };

// The Karhunen-Loeve transform of RGB: band b = basis row b . (rgb - mean), the rows the
// eigenvectors of the 3 x 3 colour covariance, largest eigenvalue first.
struct KarhunenLoeve {
  std::array<double, 3> mean{};
  std::array<double, 9> basis{1, 0, 0, 0, 1, 0, 0, 0, 1};
};
KarhunenLoeve karhunen_loeve(const Field& rgb);
Field to_bands(const Field& rgb, const KarhunenLoeve& kl);
Field from_bands(const Field& bands, const KarhunenLoeve& kl);

class ColourTexture {
 public:
  virtual ~ColourTexture() = default;
  // An RGB field of width x height on the torus (it tiles), deterministic from `seed`.
  virtual Field synthesise(int width, int height, std::uint64_t seed) const = 0;
  // Stored values (neighbourhood offsets not counted: they are the model's structure).
  virtual std::size_t parameter_count() const = 0;
  // The Gaussian-Laplacian pyramid's levels (methods/pyramid.hpp), a model each.
  virtual int levels() const = 0;
  // The neighbourhood(s), for `info`.
  virtual std::string neighbourhood() const = 0;
  virtual void put(ByteWriter& w) const = 0;
};

// Fits `kind` to an RGB field: its Gaussian-Laplacian pyramid of `levels` levels (1: the
// field itself), a model per level (2D CAR, GMRF: per band and level; the Karhunen-Loeve
// transform is the field's), neighbourhoods chosen up to `max_order`. The field's sides must
// hold the levels (max_levels).
// CAR models are stabilised for `synthesis` (stabilise_car_spectrum or stabilise_car).
std::unique_ptr<ColourTexture> fit_colour_texture(TextureKind kind, const Field& rgb, int max_order,
                                                  int levels = 1,
                                                  CarSynthesis synthesis = CarSynthesis::kSpectral);
// Reads what put wrote for a model of `levels` levels; r.fail() on anything out of range.
std::unique_ptr<ColourTexture> get_colour_texture(TextureKind kind, int levels, ByteReader& r,
                                                  CarSynthesis synthesis);

}  // namespace btfgmm::detail
