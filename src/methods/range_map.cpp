// The range map: photometric stereo (Woodham 1980) and Frankot-Chellappa integration (1988),
// as Haindl & Filip (PAMI 2007, Sec. 3) estimate the relief of a BTF tile.
#include "btfgmm/methods/range_map.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/image.hpp"
#include "core/eigen_dense.hpp"
#include "methods/fft.hpp"

namespace btfgmm {
namespace {

// IEC 61966-2-1: an sRGB level (0-255) as linear intensity.
double linear_from_level(double level) {
  const double e = std::clamp(level / 255.0, 0.0, 1.0);
  return e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
}

// The lights photometric stereo uses, and the pseudo-inverse (3 x n) of their unit vectors.
struct LightSystem {
  std::vector<std::size_t> lights;
  Eigen::MatrixXd directions;  // n x 3, a unit vector a row
};

LightSystem light_system(const DirectionSet& lights, const RangeMapSettings& s) {
  LightSystem sys;
  for (std::size_t i = 0; i < lights.size(); ++i)
    if (lights[i].theta_deg <= s.max_light_theta_deg + 1e-9) sys.lights.push_back(i);
  const auto n = Eigen::Index(sys.lights.size());
  const auto refuse = [&] {
    throw Error(Error::Kind::kArgument,
                fmt::format("photometric stereo needs at least 3 lights, not all in one plane, "
                            "at elevations up to {} degrees; this BTF has {} there",
                            s.max_light_theta_deg, n));
  };
  if (n < 3) refuse();
  Eigen::MatrixXd l(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 v = to_vector(lights[sys.lights[std::size_t(i)]]);
    l.row(i) << v.x, v.y, v.z;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(l, Eigen::ComputeThinU | Eigen::ComputeThinV);
  if (svd.singularValues()(2) < 1e-6 * svd.singularValues()(0)) refuse();
  sys.directions = l;
  return sys;
}

// One pixel's g = rho n by least squares over its lights (Woodham 1980), the darkest and the
// brightest left out (shadow and highlight, which the Lambertian I = rho n . l does not hold).
Eigen::Vector3d pixel_normal(std::vector<std::pair<double, std::size_t>>& lit,
                             const Eigen::MatrixXd& l, const RangeMapSettings& s) {
  std::sort(lit.begin(), lit.end());
  const std::size_t n = lit.size();
  std::size_t lo = std::size_t(s.shadow_fraction * double(n));
  std::size_t hi = n - std::size_t(s.highlight_fraction * double(n));
  if (hi < lo + 6) lo = 0, hi = n;  // too few left: every light
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (std::size_t k = lo; k < hi; ++k) {
    const Eigen::Vector3d row = l.row(Eigen::Index(lit[k].second)).transpose();
    ata += row * row.transpose();
    atb += row * lit[k].first;
  }
  Eigen::Vector3d g = ata.ldlt().solve(atb);
  if (!(g.norm() > 0.0) || !std::isfinite(g.norm())) g = Eigen::Vector3d(0, 0, 1);
  return g.normalized();
}

}  // namespace

std::size_t top_view(const Btf& btf) {
  std::size_t best = 0;
  for (std::size_t v = 1; v < btf.views().size(); ++v)
    if (btf.views()[v].theta_deg < btf.views()[best].theta_deg) best = v;
  return best;
}

std::vector<float> photometric_normals(const Btf& btf, std::size_t view,
                                       const RangeMapSettings& settings) {
  const LightSystem sys = light_system(btf.lights(), settings);
  const bool srgb = btf.format() != SampleFormat::kHdr;
  const std::size_t pixels = std::size_t(btf.width()) * std::size_t(btf.height());
  std::vector<float> normals(pixels * 3);
  std::vector<std::pair<double, std::size_t>> lit(sys.lights.size());
  for (std::size_t p = 0; p < pixels; ++p) {
    for (std::size_t i = 0; i < sys.lights.size(); ++i) {
      const float* rgb = btf.image(sys.lights[i], view) + p * 3;
      double sum = 0.0;
      for (int c = 0; c < 3; ++c) sum += srgb ? linear_from_level(rgb[c]) : double(rgb[c]);
      lit[i] = {sum / 3.0, i};
    }
    const Eigen::Vector3d g = pixel_normal(lit, sys.directions, settings);
    for (int c = 0; c < 3; ++c) normals[p * 3 + std::size_t(c)] = float(g(c));
  }
  return normals;
}

// Frankot & Chellappa 1988: with P, Q the spectra of p = dz/dx, q = dz/dy,
// Z(w) = -j (wx P + wy Q) / (wx^2 + wy^2), Z(0) = 0.
std::vector<float> frankot_chellappa(const std::vector<float>& normals, int width, int height) {
  detail::Field p(width, height, 1), q(width, height, 1);
  for (std::size_t i = 0; i < p.pixels(); ++i) {
    const double nz = std::max(double(normals[i * 3 + 2]), 0.1);
    p.values[i] = -double(normals[i * 3]) / nz;
    q.values[i] = -double(normals[i * 3 + 1]) / nz;
  }
  const auto fp = detail::forward_dft(p), fq = detail::forward_dft(q);
  std::vector<std::complex<double>> fz(fp.size());
  const std::complex<double> j(0.0, 1.0);
  for (int k2 = 0; k2 < height; ++k2)
    for (int k1 = 0; k1 < width; ++k1) {
      const double wx = detail::angular_frequency(k1, width);
      const double wy = detail::angular_frequency(k2, height);
      const double d = wx * wx + wy * wy;
      const std::size_t k = std::size_t(k2) * std::size_t(width) + std::size_t(k1);
      fz[k] = d > 0.0 ? -j * (wx * fp[k] + wy * fq[k]) / d : 0.0;
    }
  const detail::Field z = detail::inverse_dft(fz, width, height);
  return std::vector<float>(z.values.begin(), z.values.end());
}

RangeMap estimate_range_map(const Btf& btf, const RangeMapSettings& settings) {
  RangeMap map;
  map.width = btf.width();
  map.height = btf.height();
  map.normals = photometric_normals(btf, top_view(btf), settings);
  map.heights = frankot_chellappa(map.normals, map.width, map.height);
  return map;
}

std::filesystem::path write_range_map(const std::filesystem::path& path, const RangeMap& map) {
  const ImageFormat format = output_image_format(path);
  if (format != ImageFormat::kExr && format != ImageFormat::kPng)
    throw Error(Error::Kind::kArgument,
                fmt::format("range map '{}': give a .exr (heights as they are) or a .png "
                            "(heights scaled to 0-255) file",
                            path.string()));
  const std::size_t n = map.heights.size();
  const auto [lo, hi] = std::minmax_element(map.heights.begin(), map.heights.end());
  const double scale = format == ImageFormat::kPng && *hi > *lo ? 255.0 / (*hi - *lo) : 1.0;
  const double offset = format == ImageFormat::kPng ? *lo : 0.0;
  std::vector<float> rgb(n * 3), normal_rgb(n * 3);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t c = 0; c < 3; ++c) {
      rgb[i * 3 + c] = float((map.heights[i] - offset) * scale);
      normal_rgb[i * 3 + c] = (map.normals[i * 3 + c] + 1.0f) * 127.5f;
    }
  std::filesystem::path normals_path = path;
  normals_path.replace_filename(path.stem().string() + "-normals.png");
  if (format == ImageFormat::kExr)
    write_exr(path, map.width, map.height, rgb);
  else
    write_png(path, map.width, map.height, rgb);
  write_png(normals_path, map.width, map.height, normal_rgb);
  return normals_path;
}

}  // namespace btfgmm
