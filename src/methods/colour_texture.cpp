// The subspace texture models: 3D CAR, 2D CAR on Karhunen-Loeve bands, GMRF on the same bands
// (Haindl & Filip, PAMI 2007), their fit, synthesis and storage.
#include "methods/colour_texture.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/eigen_dense.hpp"
#include "core/random.hpp"
#include "methods/car.hpp"
#include "methods/gmrf.hpp"
#include "methods/pyramid.hpp"

namespace btfgmm::detail {
namespace {

constexpr int kMaxReach = 3;  // the largest |dx|, |dy| a stored neighbourhood may hold

void put_offsets(ByteWriter& w, const std::vector<Offset>& n) {
  w.put<std::uint8_t>(std::uint8_t(n.size()));
  for (const Offset& s : n)
    w.put<std::int8_t>(std::int8_t(s.dx)), w.put<std::int8_t>(std::int8_t(s.dy));
}

template <class Valid>
std::vector<Offset> get_offsets(ByteReader& r, Valid valid, const char* field) {
  const std::size_t n = r.get<std::uint8_t>(field);
  if (n == 0 || n > 48) r.fail(fmt::format("{}: {} offsets, expected 1 to 48", field, n));
  std::vector<Offset> out(n);
  for (Offset& s : out) {
    s.dx = r.get<std::int8_t>(field);
    s.dy = r.get<std::int8_t>(field);
    if (!valid(s) || std::abs(s.dx) > kMaxReach || std::abs(s.dy) > kMaxReach)
      r.fail(fmt::format("{}: offset ({},{}) is not allowed", field, s.dx, s.dy));
  }
  return out;
}

void put_values(ByteWriter& w, const std::vector<double>& v) {
  for (double x : v) w.put<float>(float(x));
}

std::vector<double> get_values(ByteReader& r, std::size_t n, const char* field) {
  std::vector<double> out(n);
  for (double& x : out) {
    x = r.get<float>(field);
    if (!std::isfinite(x)) r.fail(fmt::format("{} holds a value that is not finite", field));
  }
  return out;
}

void put_car(ByteWriter& w, const CarModel& m) {
  put_offsets(w, m.neighbourhood);
  put_values(w, m.mean);
  put_values(w, m.gamma);
  put_values(w, m.sigma);
}

CarModel get_car(ByteReader& r, int d) {
  CarModel m;
  m.d = d;
  m.neighbourhood = get_offsets(r, causal, "CAR neighbourhood");
  const std::size_t dd = std::size_t(d);
  m.mean = get_values(r, dd, "CAR mean");
  m.gamma = get_values(r, dd * dd * m.eta(), "CAR gamma");
  m.sigma = get_values(r, dd * dd, "CAR noise covariance");
  for (std::size_t i = 0; i < dd; ++i)
    if (!(m.sigma[i * dd + i] >= 0.0)) r.fail("CAR noise covariance has a negative variance");
  return m;
}

void put_gmrf(ByteWriter& w, const GmrfModel& m) {
  put_offsets(w, m.half);
  put_values(w, m.a);
  put_values(w, {m.sigma2, m.mean, m.shrink});
}

GmrfModel get_gmrf(ByteReader& r) {
  GmrfModel m;
  m.half = get_offsets(
      r, [](const Offset& s) { return s.dy > 0 || (s.dy == 0 && s.dx > 0); }, "GMRF neighbourhood");
  m.a = get_values(r, m.half.size(), "GMRF parameters");
  const auto rest = get_values(r, 3, "GMRF variance");
  m.sigma2 = rest[0], m.mean = rest[1], m.shrink = rest[2];
  if (!(m.sigma2 >= 0.0)) r.fail("GMRF variance is negative");
  return m;
}

void put_kl(ByteWriter& w, const KarhunenLoeve& kl) {
  put_values(w, {kl.mean.begin(), kl.mean.end()});
  put_values(w, {kl.basis.begin(), kl.basis.end()});
}

KarhunenLoeve get_kl(ByteReader& r) {
  KarhunenLoeve kl;
  const auto mean = get_values(r, 3, "Karhunen-Loeve mean");
  const auto basis = get_values(r, 9, "Karhunen-Loeve basis");
  std::copy(mean.begin(), mean.end(), kl.mean.begin());
  std::copy(basis.begin(), basis.end(), kl.basis.begin());
  return kl;
}

// The seed of pyramid level k's synthesis: level 0 takes the model's own (a one-level model
// synthesises as before the pyramid), the others one mixed from it.
std::uint64_t level_seed(std::uint64_t seed, int level) {
  return level == 0 ? seed : mix64(seed ^ (0x6C6576656C000000ULL + std::uint64_t(level)));
}

// The level sizes of a synthesis of width x height, each level synthesised by `make` (level,
// its width, its height, its seed) and collapsed into the image.
template <class Make>
Field synthesise_pyramid(int levels, int width, int height, std::uint64_t seed, Make make) {
  std::vector<Field> fields;
  for (int k = 0; k < levels; ++k)
    fields.push_back(make(k, level_side(width, k), level_side(height, k), level_seed(seed, k)));
  return collapse(fields);
}

Field synthesise_car_as(const CarModel& m, int w, int h, std::uint64_t seed,
                        CarSynthesis synthesis) {
  return synthesis == CarSynthesis::kSpectral ? synthesise_car_spectral(m, w, h, seed)
                                              : synthesise_car(m, w, h, seed);
}

// 3D CAR: one model of the RGB vector per pyramid level (level 0 the finest).
class Car3dTexture final : public ColourTexture {
 public:
  Car3dTexture(std::vector<CarModel> levels, CarSynthesis synthesis)
      : levels_(std::move(levels)), synthesis_(synthesis) {}
  Field synthesise(int width, int height, std::uint64_t seed) const override {
    return synthesise_pyramid(
        int(levels_.size()), width, height, seed, [this](int k, int w, int h, std::uint64_t s) {
          return synthesise_car_as(levels_[std::size_t(k)], w, h, s, synthesis_);
        });
  }
  std::size_t parameter_count() const override {
    std::size_t n = 0;
    for (const CarModel& m : levels_) n += m.parameter_count();
    return n;
  }
  int levels() const override { return int(levels_.size()); }
  std::string neighbourhood() const override {
    return neighbourhood_text(levels_[0].neighbourhood) + (levels_.size() > 1 ? " (level 0)" : "");
  }
  void put(ByteWriter& w) const override {
    for (const CarModel& m : levels_) put_car(w, m);
  }

 private:
  std::vector<CarModel> levels_;
  CarSynthesis synthesis_;
};

// 2D CAR and GMRF: a Karhunen-Loeve transform and a model per band and pyramid level (level-
// major: level 0's three bands first).
template <class Model>
class BandTexture final : public ColourTexture {
 public:
  BandTexture(KarhunenLoeve kl, std::vector<Model> bands,
              CarSynthesis synthesis = CarSynthesis::kSpectral)
      : kl_(kl), bands_(std::move(bands)), synthesis_(synthesis) {}
  Field synthesise(int width, int height, std::uint64_t seed) const override {
    return from_bands(synthesise_pyramid(levels(), width, height, seed,
                                         [this](int k, int w, int h, std::uint64_t s) {
                                           return synthesise_level(k, w, h, s);
                                         }),
                      kl_);
  }
  std::size_t parameter_count() const override {
    std::size_t n = kl_.mean.size() + kl_.basis.size();
    for (const Model& m : bands_) n += m.parameter_count();
    return n;
  }
  int levels() const override { return int(bands_.size() / 3); }
  std::string neighbourhood() const override;
  void put(ByteWriter& w) const override {
    put_kl(w, kl_);
    for (const Model& m : bands_) put_band(w, m);
  }

 private:
  // Level k's three bands, each from its model, band b from seed + b.
  Field synthesise_level(int k, int width, int height, std::uint64_t seed) const {
    Field bands(width, height, 3);
    for (int b = 0; b < 3; ++b) {
      const Field f = synthesise_band(bands_[std::size_t(3 * k + b)], width, height,
                                      seed + std::uint64_t(b), synthesis_);
      for (std::size_t i = 0; i < f.pixels(); ++i)
        bands.values[i * 3 + std::size_t(b)] = f.values[i];
    }
    return bands;
  }
  static Field synthesise_band(const CarModel& m, int w, int h, std::uint64_t s,
                               CarSynthesis synthesis) {
    return synthesise_car_as(m, w, h, s, synthesis);
  }
  static Field synthesise_band(const GmrfModel& m, int w, int h, std::uint64_t s, CarSynthesis) {
    return synthesise_gmrf(m, w, h, s);
  }
  static void put_band(ByteWriter& w, const CarModel& m) { put_car(w, m); }
  static void put_band(ByteWriter& w, const GmrfModel& m) { put_gmrf(w, m); }

  KarhunenLoeve kl_;
  std::vector<Model> bands_;
  CarSynthesis synthesis_;
};

template <>
std::string BandTexture<CarModel>::neighbourhood() const {
  return neighbourhood_text(bands_[0].neighbourhood) +
         (levels() > 1 ? " (band 1, level 0; causal)" : " (band 1; causal)");
}
template <>
std::string BandTexture<GmrfModel>::neighbourhood() const {
  return fmt::format("{} symmetric pairs (band 1{})", bands_[0].half.size(),
                     levels() > 1 ? ", level 0" : "");
}

double covariance_trace(const Field& f) {
  double trace = 0.0;
  for (int c = 0; c < f.channels; ++c) {
    const Field ch = channel_of(f, c);
    double m = 0, s = 0;
    for (double v : ch.values) m += v;
    m /= double(ch.pixels());
    for (double v : ch.values) s += (v - m) * (v - m);
    trace += s / double(ch.pixels());
  }
  return trace;
}

}  // namespace

KarhunenLoeve karhunen_loeve(const Field& rgb) {
  KarhunenLoeve kl;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < rgb.pixels(); ++i)
    for (int c = 0; c < 3; ++c) kl.mean[std::size_t(c)] += rgb.values[i * 3 + std::size_t(c)];
  for (double& m : kl.mean) m /= double(rgb.pixels());
  for (std::size_t i = 0; i < rgb.pixels(); ++i) {
    const Eigen::Vector3d v(rgb.values[i * 3] - kl.mean[0], rgb.values[i * 3 + 1] - kl.mean[1],
                            rgb.values[i * 3 + 2] - kl.mean[2]);
    cov += v * v.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov / double(rgb.pixels()));
  for (int b = 0; b < 3; ++b)  // eigenvalues ascend: band 0 takes the last
    for (int c = 0; c < 3; ++c) kl.basis[std::size_t(b * 3 + c)] = eig.eigenvectors()(c, 2 - b);
  return kl;
}

Field to_bands(const Field& rgb, const KarhunenLoeve& kl) {
  Field out(rgb.width, rgb.height, 3);
  for (std::size_t i = 0; i < rgb.pixels(); ++i)
    for (int b = 0; b < 3; ++b) {
      double v = 0.0;
      for (int c = 0; c < 3; ++c)
        v += kl.basis[std::size_t(b * 3 + c)] *
             (rgb.values[i * 3 + std::size_t(c)] - kl.mean[std::size_t(c)]);
      out.values[i * 3 + std::size_t(b)] = v;
    }
  return out;
}

Field from_bands(const Field& bands, const KarhunenLoeve& kl) {
  Field out(bands.width, bands.height, 3);
  for (std::size_t i = 0; i < bands.pixels(); ++i)
    for (int c = 0; c < 3; ++c) {
      double v = kl.mean[std::size_t(c)];
      for (int b = 0; b < 3; ++b)
        v += kl.basis[std::size_t(b * 3 + c)] * bands.values[i * 3 + std::size_t(b)];
      out.values[i * 3 + std::size_t(c)] = v;
    }
  return out;
}

namespace {

// The stability test and variance match of the synthesis the model will have.
void stabilise(CarModel& m, const Field& data, CarSynthesis synthesis) {
  if (synthesis == CarSynthesis::kSpectral)
    stabilise_car_spectrum(m, covariance_trace(data), data.width, data.height);
  else
    stabilise_car(m, covariance_trace(data), data.width, data.height);
}

std::unique_ptr<ColourTexture> fit_car3d_texture(const Field& rgb, int max_order, int levels,
                                                 CarSynthesis synthesis) {
  std::vector<CarModel> models;
  for (const Field& level : laplacian_pyramid(rgb, levels)) {
    models.push_back(select_car(level, max_order));
    stabilise(models.back(), level, synthesis);
  }
  return std::make_unique<Car3dTexture>(std::move(models), synthesis);
}

}  // namespace

std::unique_ptr<ColourTexture> fit_colour_texture(TextureKind kind, const Field& rgb, int max_order,
                                                  int levels, CarSynthesis synthesis) {
  if (kind == TextureKind::kCar3d) return fit_car3d_texture(rgb, max_order, levels, synthesis);
  const KarhunenLoeve kl = karhunen_loeve(rgb);
  const Field bands = to_bands(rgb, kl);
  const std::vector<Field> pyramid = laplacian_pyramid(bands, levels);
  if (kind == TextureKind::kCar2d) {
    std::vector<CarModel> models;
    for (const Field& level : pyramid)
      for (int b = 0; b < 3; ++b) {
        const Field band = channel_of(level, b);
        models.push_back(select_car(band, max_order));
        stabilise(models.back(), band, synthesis);
      }
    return std::make_unique<BandTexture<CarModel>>(kl, std::move(models), synthesis);
  }
  std::vector<GmrfModel> models;
  for (const Field& level : pyramid)
    for (int b = 0; b < 3; ++b) models.push_back(select_gmrf(channel_of(level, b), max_order));
  return std::make_unique<BandTexture<GmrfModel>>(kl, std::move(models));
}

std::unique_ptr<ColourTexture> get_colour_texture(TextureKind kind, int levels, ByteReader& r,
                                                  CarSynthesis synthesis) {
  const std::size_t n = std::size_t(levels);
  if (kind == TextureKind::kCar3d) {
    std::vector<CarModel> models;
    for (std::size_t k = 0; k < n; ++k) models.push_back(get_car(r, 3));
    return std::make_unique<Car3dTexture>(std::move(models), synthesis);
  }
  const KarhunenLoeve kl = get_kl(r);
  if (kind == TextureKind::kCar2d) {
    std::vector<CarModel> models;
    for (std::size_t b = 0; b < 3 * n; ++b) models.push_back(get_car(r, 1));
    return std::make_unique<BandTexture<CarModel>>(kl, std::move(models), synthesis);
  }
  std::vector<GmrfModel> models;
  for (std::size_t b = 0; b < 3 * n; ++b) models.push_back(get_gmrf(r));
  return std::make_unique<BandTexture<GmrfModel>>(kl, std::move(models));
}

}  // namespace btfgmm::detail
