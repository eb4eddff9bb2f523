// A writer of Bonn .btf files for the tests and the benchmark, following the published layout
// of btflib's writers (write_common_header, write_ubo_dfmf, write_ubo_fmf) field by field, and
// the forward form of its colour models (the inverse of undecorrelate.m): written here on its
// own, sharing no code with the reader (src/io/ubo_btf*.cpp): its own byte order, its own
// half floats (Eigen::half), its own factorisation (Eigen's SVD).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/eigen_dense.hpp"  // Eigen, its false AVX-512 warnings silenced

namespace btfgmm::test {

// A direction as the file stores it: inclination theta and azimuth phi, in radians.
struct UboAngles {
  float theta = 0, phi = 0;
};

struct UboSpec {
  bool dfmf = true;  // !DFMF08FCR, else !FMF12FCER
  std::uint32_t metadata_version = 4;
  std::vector<UboAngles> lights, views;
  std::uint32_t width = 0, height = 0;
  std::int32_t colour_model = 0;    // DFMF: 0 (RGB) or 11 (Ylog U/Y V/Y)
  bool cosine = false;              // the light's cos(theta) multiplied into the data
  std::uint32_t dynamic_range = 0;  // FMF: nonzero stores log(value + 1e-5)
  std::uint32_t components = 0;     // 0: full rank
  std::uint32_t rotations = 0;
  std::string setup = "test dome", sensor = "test sensor", light_source = "test lights";
  std::string xml = "<measurement/>";
};

// One factor matrix as the file holds it: S, U (rows x P) and S x V (columns x P).
struct UboFactors {
  Eigen::VectorXf s;
  Eigen::MatrixXf u, sxv;
};

class UboBytes {
 public:
  void u8(std::uint8_t v) { bytes.push_back(v); }
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes.push_back(std::uint8_t(v >> (8 * i)));
  }
  void f32(float f) {
    std::uint32_t v;
    std::memcpy(&v, &f, 4);
    u32(v);
  }
  void half(float f) {
    const std::uint16_t v = Eigen::numext::bit_cast<std::uint16_t>(Eigen::half(f));
    bytes.push_back(std::uint8_t(v & 0xff));
    bytes.push_back(std::uint8_t(v >> 8));
  }
  void chars(const std::string& s, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) bytes.push_back(i < s.size() ? std::uint8_t(s[i]) : 0);
  }
  std::vector<std::uint8_t> bytes;
};

// write_common_header: the signature, the metadata (its size counts itself), the views with
// their light lists, the size, the rotations.
inline void write_ubo_common(UboBytes& b, const UboSpec& s) {
  b.chars(s.dfmf ? "!DFMF08FCR" : "!FMF12FCER", 10);
  UboBytes m;
  m.u32(s.metadata_version);
  m.chars(s.setup, 80);
  m.chars(s.sensor, 80);
  m.chars(s.light_source, 80);
  m.f32(10.0f);
  for (int i = 0; i < 3; ++i) m.f32(1.0f);
  if (s.metadata_version > 1) m.u32(s.cosine ? 1 : 0);
  if (s.metadata_version > 2) {
    m.u32(std::uint32_t(s.xml.size()));
    m.chars(s.xml, s.xml.size());
  }
  if (s.metadata_version > 3) {
    m.u32(3);
    for (const char* name : {"R", "G", "B"}) {
      m.u32(1);
      m.chars(name, 1);
    }
  }
  b.u32(std::uint32_t(m.bytes.size() + 4));
  b.bytes.insert(b.bytes.end(), m.bytes.begin(), m.bytes.end());
  b.u32(std::uint32_t(s.views.size()));
  for (const UboAngles& v : s.views) {
    b.f32(v.theta);
    b.f32(v.phi);
    b.u32(std::uint32_t(s.lights.size()));
    for (const UboAngles& l : s.lights) {
      b.f32(l.theta);
      b.f32(l.phi);
    }
  }
  b.u32(s.width);
  b.u32(s.height);
  b.u32(s.rotations);
  for (std::uint32_t r = 0; r < s.rotations * 9; ++r) b.f32(r % 4 == 0 ? 1.0f : 0.0f);
}

inline void write_ubo_factors(UboBytes& b, const UboFactors& f) {
  for (Eigen::Index k = 0; k < f.s.size(); ++k) b.half(f.s(k));
  for (Eigen::Index r = 0; r < f.u.rows(); ++r)
    for (Eigen::Index k = 0; k < f.u.cols(); ++k) b.half(f.u(r, k));
  for (Eigen::Index r = 0; r < f.sxv.rows(); ++r)
    for (Eigen::Index k = 0; k < f.sxv.cols(); ++k) b.half(f.sxv(r, k));
}

// A whole file from its factors: DFMF one per channel, FMF one.
inline std::vector<std::uint8_t> write_ubo_btf(const UboSpec& s,
                                               const std::vector<UboFactors>& factors) {
  UboBytes b;
  write_ubo_common(b, s);
  if (s.dfmf) {
    std::uint32_t most = 0;
    for (const UboFactors& f : factors) most = std::max(most, std::uint32_t(f.u.cols()));
    b.u32(most);
    b.u32(std::uint32_t(s.colour_model));
    for (int i = 0; i < 3; ++i) b.f32(0.0f);                      // colour mean
    for (int i = 0; i < 9; ++i) b.f32(i % 4 == 0 ? 1.0f : 0.0f);  // transformation matrix
    for (const UboFactors& f : factors) {
      b.u8(2);  // half floats
      b.u32(std::uint32_t(f.u.cols()));
      b.u32(std::uint32_t(f.u.rows()));
      b.u32(std::uint32_t(f.sxv.rows()));
      write_ubo_factors(b, f);
    }
  } else {
    const UboFactors& f = factors.at(0);
    b.u8(2);  // extended header version: dynamic range and height map
    b.u32(s.dynamic_range);
    b.u32(0);  // no height map
    b.u32(0);
    b.u32(std::uint32_t(f.u.cols()));
    b.u8(2);
    b.u32(std::uint32_t(f.u.cols()));
    b.u32(std::uint32_t(f.u.rows()));
    b.u32(std::uint32_t(f.sxv.rows()));
    write_ubo_factors(b, f);
  }
  return b.bytes;
}

// btflib's YUV to RGB matrix (undecorrelate.m), inverted here to write YUV.
inline Eigen::Matrix3d ubo_rgb_to_yuv() {
  Eigen::Matrix3d yuv_to_rgb;
  yuv_to_rgb << 1, 0, 1.13983, 1, -0.39465, -0.5806, 1, 2.03211, 0;
  return yuv_to_rgb.inverse();
}

// The stored channels of one linear RGB value: the cosine multiplied in, then the colour model
// (DFMF) or the dynamic-range reduction (FMF).
inline Eigen::Vector3d ubo_stored(const UboSpec& s, Eigen::Vector3d rgb, double light_cos) {
  constexpr double eps = 1e-5;
  if (s.cosine) rgb *= light_cos;
  if (!s.dfmf) {
    if (s.dynamic_range != 0)
      for (int c = 0; c < 3; ++c) rgb(c) = std::log(rgb(c) + eps);
    return rgb;
  }
  if (s.colour_model == 0) return rgb;
  const Eigen::Vector3d yuv = ubo_rgb_to_yuv() * rgb;  // model 11: Ylog, U/(Y+eps), V/(Y+eps)
  return {std::log(yuv(0) + eps), yuv(1) / (yuv(0) + eps), yuv(2) / (yuv(0) + eps)};
}

// The file of known images: images[(l * nv + v) * w * h * 3 + (y * w + x) * 3 + c], linear
// RGB, light-major. Each matrix (rows: view-major pairs, FMF with the channel fastest; columns:
// pixels row by row) is factorised by an SVD and cut to s.components (0: full rank).
inline std::vector<std::uint8_t> write_ubo_btf_images(const UboSpec& s,
                                                      const std::vector<float>& images) {
  const std::size_t nl = s.lights.size(), nv = s.views.size(), px = std::size_t(s.width) * s.height;
  const int matrices = s.dfmf ? 3 : 1;
  const std::size_t rows = nl * nv * (s.dfmf ? 1 : 3);
  std::vector<Eigen::MatrixXd> a(std::size_t(matrices), Eigen::MatrixXd(rows, px));
  for (std::size_t l = 0; l < nl; ++l)
    for (std::size_t v = 0; v < nv; ++v)
      for (std::size_t p = 0; p < px; ++p) {
        const float* in = &images[((l * nv + v) * px + p) * 3];
        const Eigen::Vector3d st =
            ubo_stored(s, {in[0], in[1], in[2]}, std::cos(s.lights[l].theta));
        for (int c = 0; c < 3; ++c) {
          if (s.dfmf)
            a[std::size_t(c)](Eigen::Index(v * nl + l), Eigen::Index(p)) = st(c);
          else
            a[0](Eigen::Index((v * nl + l) * 3 + std::size_t(c)), Eigen::Index(p)) = st(c);
        }
      }
  std::vector<UboFactors> factors;
  for (const Eigen::MatrixXd& m : a) {
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(m, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::Index rank = std::min<Eigen::Index>(
        svd.singularValues().size(),
        s.components ? Eigen::Index(s.components) : svd.singularValues().size());
    UboFactors f;
    f.s = svd.singularValues().head(rank).cast<float>();
    f.u = svd.matrixU().leftCols(rank).cast<float>();
    f.sxv =
        (svd.matrixV().leftCols(rank) * svd.singularValues().head(rank).asDiagonal()).cast<float>();
    factors.push_back(std::move(f));
  }
  return write_ubo_btf(s, factors);
}

}  // namespace btfgmm::test
