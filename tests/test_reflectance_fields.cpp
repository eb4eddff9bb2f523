// The reflectance-field methods: PTM RF (Malzbender et al. 2001) and PLM RF (Filip, Haindl
// 2004) on data generated from their own models, Table 2's ratios, the model file, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "btfgmm/btfgmm.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

using test::error_of;

// Lights on three elevations (they determine PTM's biquadratic), a few views.
DirectionSet test_lights() {
  return DirectionSet::rings({{0, 1}, {25, 6}, {50, 8}, {70, 10}});
}
DirectionSet test_views() {
  return DirectionSet::rings({{0, 1}, {40, 4}});
}

// Directions between the measured ones.
const Direction kUnmeasured[] = {{37.0, 100.0}, {12.0, 200.0}, {62.0, 333.0}};

double max_abs(std::span<const float> v) {
  double m = 0.0;
  for (float x : v) m = std::max(m, double(std::abs(x)));
  return m;
}

// Per texel, view and channel, six random coefficients; the data is the biquadratic at the
// measured lights.
struct Biquadratic {
  int width = 5, height = 4;
  std::vector<double> coef;  // [view][pixel*3 + c][k]

  explicit Biquadratic(std::size_t views) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-30.0, 30.0);
    coef.resize(views * std::size_t(width * height) * 3 * 6);
    for (std::size_t i = 0; i < coef.size(); ++i) coef[i] = i % 6 == 5 ? 120.0 + u(rng) : u(rng);
  }
  double value(std::size_t view, std::size_t j, const Direction& light) const {
    const auto t = PtmRf::basis(light);
    const double* a = coef.data() + (view * std::size_t(width * height) * 3 + j) * 6;
    double v = 0.0;
    for (int k = 0; k < 6; ++k) v += a[k] * t[std::size_t(k)];
    return v;
  }
  Btf btf(const DirectionSet& lights, const DirectionSet& views) const {
    Btf b(lights, views, width, height, SampleFormat::kHdr);
    for (std::size_t l = 0; l < lights.size(); ++l)
      for (std::size_t v = 0; v < views.size(); ++v)
        for (std::size_t j = 0; j < b.image_floats(); ++j)
          b.image(l, v)[j] = float(value(v, j, lights[l]));
    return b;
  }
};

FitOptions at(FactorEncoding e) {
  FitOptions s;
  s.precision = e;
  return s;
}

TEST(PtmRf, ReproducesBiquadraticsAtAnyLight) {
  const Biquadratic truth(test_views().size());
  const Btf data = truth.btf(test_lights(), test_views());
  const auto model = fit_ptm_rf(data, at(FactorEncoding::kF32));
  const auto& ptm = dynamic_cast<const PtmRf&>(*model);
  const double tol = 1e-4 * max_abs(data.data());
  std::vector<float> image(data.image_floats());
  double worst = 0.0;
  for (std::size_t v = 0; v < data.views().size(); ++v) {
    for (std::size_t l = 0; l < data.lights().size(); ++l) {
      ptm.measured_image(l, v, image.data());
      for (std::size_t j = 0; j < image.size(); ++j)
        worst = std::max(worst, std::abs(double(image[j]) - double(data.image(l, v)[j])));
    }
    for (const Direction& light : kUnmeasured) {
      ptm.light_image(light, v, image.data());
      for (std::size_t j = 0; j < image.size(); ++j)
        worst = std::max(worst, std::abs(double(image[j]) - truth.value(v, j, light)));
    }
  }
  EXPECT_LT(worst, tol);
  // predict at an unmeasured light, a measured view and a pixel centre: the polynomial there.
  std::vector<Query> q;
  for (const Direction& light : kUnmeasured) q.push_back({3.0, 2.0, light, test_views()[2]});
  std::vector<float> rgb(q.size() * 3);
  model->predict(q, rgb);
  for (std::size_t i = 0; i < q.size(); ++i)
    for (std::size_t c = 0; c < 3; ++c)
      EXPECT_NEAR(rgb[i * 3 + c], truth.value(2, (2 * 5 + 3) * 3 + c, q[i].light), tol);
}

// Per texel, view and channel a Lafortune lobe: its data is the lobe at the measured lights
// (the per-image polynomial is the identity).
struct Lobes {
  int width = 4, height = 3;
  std::vector<std::array<double, 5>> p;  // [view][pixel*3 + c]: rho, axis (unit), n

  explicit Lobes(std::size_t views) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    p.resize(views * std::size_t(width * height) * 3);
    for (auto& a : p) {
      const double tilt = 0.7 * u(rng), phi = 6.283 * u(rng);
      a = {60.0 + 150.0 * u(rng), std::sin(tilt) * std::cos(phi), std::sin(tilt) * std::sin(phi),
           std::cos(tilt), 1.0 + 20.0 * u(rng)};
    }
  }
  double value(std::size_t view, std::size_t j, const Direction& light) const {
    const auto& a = p[view * std::size_t(width * height) * 3 + j];
    const Vec3 w = to_vector(light);
    const double b = a[1] * w.x + a[2] * w.y + a[3] * w.z;
    return b > 0.0 ? a[0] * std::pow(b, a[4]) : 0.0;
  }
  Btf btf(const DirectionSet& lights, const DirectionSet& views) const {
    Btf out(lights, views, width, height, SampleFormat::kHdr);
    for (std::size_t l = 0; l < lights.size(); ++l)
      for (std::size_t v = 0; v < views.size(); ++v)
        for (std::size_t j = 0; j < out.image_floats(); ++j)
          out.image(l, v)[j] = float(value(v, j, lights[l]));
    return out;
  }
};

TEST(PlmRf, RecoversLafortuneLobes) {
  const Lobes truth(test_views().size());
  const Btf data = truth.btf(test_lights(), test_views());
  const auto model = fit_plm_rf(data, at(FactorEncoding::kF32));
  const auto& plm = dynamic_cast<const PlmRf&>(*model);
  const double tol = 1e-4 * max_abs(data.data());
  std::vector<float> image(data.image_floats());
  double worst = 0.0;
  for (std::size_t v = 0; v < data.views().size(); ++v) {
    for (std::size_t l = 0; l < data.lights().size(); ++l) {
      plm.measured_image(l, v, image.data());
      for (std::size_t j = 0; j < image.size(); ++j)
        worst = std::max(worst, std::abs(double(image[j]) - double(data.image(l, v)[j])));
    }
    for (const Direction& light : kUnmeasured) {
      plm.light_image(light, v, image.data());
      for (std::size_t j = 0; j < image.size(); ++j)
        worst = std::max(worst, std::abs(double(image[j]) - truth.value(v, j, light)));
    }
  }
  EXPECT_LT(worst, tol);
  // The lobes themselves: exponent and axis of every texel, view and channel.
  const std::size_t n = data.image_floats();
  double worst_n = 0.0, worst_axis = 0.0;
  for (std::size_t v = 0; v < data.views().size(); ++v)
    for (std::size_t j = 0; j < n; ++j) {
      const auto& a = truth.p[v * n + j];
      const float* got = plm.lobes().data() + v * 5 * n + j;
      worst_n = std::max(worst_n, std::abs(double(got[4 * n]) - a[4]) / a[4]);
      for (std::size_t k = 1; k <= 3; ++k)
        worst_axis = std::max(worst_axis, std::abs(double(got[k * n]) - a[k]));
    }
  EXPECT_LT(worst_n, 1e-4);
  EXPECT_LT(worst_axis, 1e-5);
}

TEST(ReflectanceFields, TableTwoRatios) {
  ModelFrame f;
  f.lights = f.views = DirectionSet::ubo81();
  f.width = f.height = 25;
  EXPECT_DOUBLE_EQ(f.data_values() / double(ptm_rf_parameter_count(f)), 13.5);
  const double plm = f.data_values() / double(plm_rf_parameter_count(f, 4));
  EXPECT_NEAR(plm, 14.3414, 1e-4);  // Table 2: 14.3
  EXPECT_EQ(ptm_rf_parameter_count(f), 81ull * 625 * 18);
  EXPECT_EQ(plm_rf_parameter_count(f, 4), 81ull * 625 * 15 + 81ull * 81 * 3 * 5);
}

// A tiny generated tile for the model-file tests.
Btf small_tile() {
  GenerateConfig g;
  g.material = "knit";
  g.size = 4;
  g.lights = DirectionSet::rings({{0, 1}, {30, 5}, {60, 5}});
  g.views = DirectionSet::rings({{0, 1}, {45, 3}});
  g.supersample = 1;
  return generate(g);
}

// The file read back gives the same bytes and the same decoded values; every truncated
// prefix of the file and of the payload, and single-byte corruptions, fail cleanly.
void check_model_file(const Representation& model) {
  const std::vector<std::uint8_t> bytes = representation_file_bytes(model);
  const auto back = read_representation(bytes, "m");
  EXPECT_EQ(representation_file_bytes(*back), bytes);
  EXPECT_EQ(back->paper_ratio(), model.paper_ratio());
  const ModelFrame& f = model.frame();
  const Btf a = model.decode(f.lights, f.views, f.width, f.height, 0.0);
  const Btf b = back->decode(f.lights, f.views, f.width, f.height, 0.0);
  ASSERT_EQ(a.data().size(), b.data().size());
  EXPECT_EQ(std::memcmp(a.data().data(), b.data().data(), a.data().size() * 4), 0);
  for (std::size_t len = 0; len < bytes.size(); len += 1 + len / 64)
    EXPECT_FALSE(error_of([&] { read_representation({bytes.data(), len}, "m"); }).empty());
  // The method's own reader, past the file's CRC: truncations are errors, corruptions are
  // errors or models that decode without crashing.
  const std::vector<std::uint8_t> payload = model.payload();
  const MethodInfo& m = find_method(model.method());
  for (std::size_t len = 0; len < payload.size(); ++len)
    EXPECT_THROW(m.read({payload.data(), len}, 0, "m"), Error) << len;
  std::vector<float> image(f.pixels() * 3);
  for (std::size_t i = 0; i < payload.size(); i += 1 + i / 32) {
    std::vector<std::uint8_t> bad = payload;
    bad[i] ^= 0xA5;
    try {
      const auto r = m.read(bad, 0, "m");
      dynamic_cast<const MeasuredImages&>(*r).measured_image(0, 0, image.data());
    } catch (const Error&) {
    }
  }
  std::vector<std::uint8_t> corrupt = bytes;
  corrupt[bytes.size() / 2] ^= 1;
  EXPECT_NE(error_of([&] { read_representation(corrupt, "m"); }).find("corrupted"),
            std::string::npos);
}

TEST(ReflectanceFields, ModelFilesRoundTripAtEveryEncoding) {
  const Btf tile = small_tile();
  for (FactorEncoding e : {FactorEncoding::kF32, FactorEncoding::kF16, FactorEncoding::kQ8,
                           FactorEncoding::kCompact}) {
    SCOPED_TRACE(std::string(to_string(e)));
    FitOptions s = at(e);
    check_model_file(*find_method("ptm-rf").fit(tile, s));
    s.degree = 2;
    s.iterations = 10;
    const auto plm = find_method("plm-rf").fit(tile, s);
    EXPECT_EQ(plm->size_text(), "l = 2");
    check_model_file(*plm);
  }
}

TEST(ReflectanceFields, BadSettingsNameTheOptionAndRange) {
  const Btf tile = small_tile();  // 11 lights
  const Btf few(DirectionSet::rings({{0, 1}, {40, 2}}), test_views(), 2, 2, SampleFormat::kLdr8);
  std::string e = error_of([&] { fit_ptm_rf(few, {}); });
  EXPECT_NE(e.find("at least 6 light directions"), std::string::npos) << e;
  EXPECT_NE(e.find("this BTF has 3"), std::string::npos) << e;
  const Btf ring(DirectionSet::rings({{45, 8}}), test_views(), 2, 2, SampleFormat::kLdr8);
  e = error_of([&] { fit_ptm_rf(ring, {}); });
  EXPECT_NE(e.find("fix only 5 of its 6"), std::string::npos) << e;
  FitOptions s;
  s.components = 4;
  e = error_of([&] { fit_ptm_rf(tile, s); });
  EXPECT_NE(e.find("--components 4: ptm-rf has a fixed size"), std::string::npos) << e;
  e = error_of([&] { fit_plm_rf(tile, s); });
  EXPECT_NE(e.find("--components 4"), std::string::npos) << e;
  EXPECT_NE(e.find("--degree"), std::string::npos) << e;
  s = {};
  s.degree = 9;
  e = error_of([&] { fit_plm_rf(tile, s); });
  EXPECT_NE(e.find("--degree 9: plm-rf takes 1..8"), std::string::npos) << e;
  s = {};
  s.iterations = -1;
  e = error_of([&] { fit_plm_rf(tile, s); });
  EXPECT_NE(e.find("--iterations -1: plm-rf takes 1..1000"), std::string::npos) << e;
  e = error_of([&] { fit_plm_rf(few, {}); });
  EXPECT_NE(e.find("at least 5 light directions"), std::string::npos) << e;
  EXPECT_NE(e.find("this BTF has 3"), std::string::npos) << e;
}

TEST(ReflectanceFields, Registered) {
  EXPECT_EQ(find_method("ptm-rf").citation, "Malzbender, Gelb, Wolters 2001");
  EXPECT_EQ(find_method("plm-rf").citation, "Filip, Haindl 2004");
  ModelFrame f;
  f.lights = f.views = DirectionSet::ubo81();
  f.width = f.height = 25;
  EXPECT_EQ(find_method("ptm-rf").ladder(f).size(), 1u);
  const auto ladder = find_method("plm-rf").ladder(f);
  ASSERT_EQ(ladder.size(), 3u);
  EXPECT_LT(plm_rf_parameter_count(f, ladder[0].degree),
            plm_rf_parameter_count(f, ladder[2].degree));
}

}  // namespace
}  // namespace btfgmm
