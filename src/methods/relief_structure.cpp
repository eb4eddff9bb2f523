// The relief's structure of a subspace image; see relief_structure.hpp.
#include "methods/relief_structure.hpp"

#include "core/eigen_dense.hpp"

#include <cmath>

namespace btfgmm::detail {
namespace {

constexpr int kSlope = kReliefShapeFeatures;  // the gain of the slope along the light

// The slope along `light` at a pixel's features: -(hx lx + hy ly).
double slope_along(const double* f, const Vec3& light) {
  return -(f[kReliefShapeFeatures] * light.x + f[kReliefShapeFeatures + 1] * light.y);
}

const double* features_at(const ReliefFeatures& f, int x, int y) {
  const std::size_t p = std::size_t((y % f.height) * f.width + x % f.width);
  return &f.values[p * ReliefFeatures::kPerPixel];
}

}  // namespace

ReliefFeatures relief_features(std::span<const float> heights, int w, int h) {
  ReliefFeatures out{.width = w, .height = h, .values = {}};
  out.values.resize(heights.size() * ReliefFeatures::kPerPixel);
  const auto at = [&](int x, int y) {
    return double(heights[std::size_t(((y + h) % h) * w + (x + w) % w)]);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double z = at(x, y);
      const double hx = (at(x + 1, y) - at(x - 1, y)) / 2, hy = (at(x, y + 1) - at(x, y - 1)) / 2;
      const double laplacian = at(x + 1, y) + at(x - 1, y) + at(x, y + 1) + at(x, y - 1) - 4 * z;
      double* f = &out.values[std::size_t(y * w + x) * ReliefFeatures::kPerPixel];
      f[0] = 1, f[1] = z, f[2] = hx * hx, f[3] = hy * hy, f[4] = hx * hy, f[5] = laplacian;
      f[6] = hx, f[7] = hy;
    }
  return out;
}

ReliefStructure fit_relief_structure(const ReliefFeatures& f, const Vec3& light,
                                     const double* rgb) {
  // The normal equations (A^T A) g = A^T b of each channel, A the pixels' features.
  constexpr int n = kReliefFeatures;
  Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(n, n), atb = Eigen::MatrixXd::Zero(n, 3);
  const std::size_t pixels = std::size_t(f.width) * std::size_t(f.height);
  for (std::size_t p = 0; p < pixels; ++p) {
    const double* q = &f.values[p * ReliefFeatures::kPerPixel];
    double a[n];
    for (int j = 0; j < kReliefShapeFeatures; ++j) a[j] = q[j];
    a[kSlope] = slope_along(q, light);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) ata(i, j) += a[i] * a[j];
      for (int c = 0; c < 3; ++c) atb(i, c) += a[i] * rgb[p * 3 + std::size_t(c)];
    }
  }
  // A flat range map (or a light from the top) leaves features at zero: a small ridge keeps
  // the system solvable and their gains at zero.
  for (int i = 0; i < n; ++i) ata(i, i) += 1e-9 * (ata(0, 0) + 1.0);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(ata);
  ReliefStructure s;
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd g = ldlt.solve(atb.col(c));
    for (int j = 0; j < n; ++j)
      s.gain[std::size_t(c * n + j)] = std::isfinite(g[j]) ? float(g[j]) : 0.0f;
  }
  return s;
}

void add_relief_shape(const ReliefStructure& s, const ReliefFeatures& f, double* rgb, int width,
                      int height, double sign) {
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double* q = features_at(f, x, y);
      double* p = &rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3];
      for (int c = 0; c < 3; ++c) {
        double v = 0;
        for (int j = 0; j < kReliefShapeFeatures; ++j)
          v += double(s.gain[std::size_t(c * kReliefFeatures + j)]) * q[j];
        p[c] += sign * v;
      }
    }
}

template <typename T>
void add_relief_slope(const ReliefStructure& s, const ReliefFeatures& f, const Vec3& light, T* rgb,
                      int width, int height, double sign) {
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double slope = sign * slope_along(features_at(f, x, y), light);
      T* p = &rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3];
      for (int c = 0; c < 3; ++c)
        p[c] += T(double(s.gain[std::size_t(c * kReliefFeatures + kSlope)]) * slope);
    }
}
template void add_relief_slope<float>(const ReliefStructure&, const ReliefFeatures&, const Vec3&,
                                      float*, int, int, double);
template void add_relief_slope<double>(const ReliefStructure&, const ReliefFeatures&, const Vec3&,
                                       double*, int, int, double);

void add_relief_slope_at(const ReliefStructure& s, const ReliefFeatures& f, const Vec3& light,
                         long long x, long long y, float* rgb) {
  const double slope = slope_along(features_at(f, int(x % f.width), int(y % f.height)), light);
  for (int c = 0; c < 3; ++c)
    rgb[c] += float(double(s.gain[std::size_t(c * kReliefFeatures + kSlope)]) * slope);
}

void put_relief_structure(ByteWriter& w, const ReliefStructure& s) {
  for (float g : s.gain) w.put<float>(g);
}

ReliefStructure get_relief_structure(ByteReader& r) {
  ReliefStructure s;
  for (float& g : s.gain)
    if (!std::isfinite(g = r.get<float>("relief gains"))) r.fail("a relief gain is not finite");
  return s;
}

}  // namespace btfgmm::detail
