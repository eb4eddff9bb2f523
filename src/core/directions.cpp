// Directions and the onion-slice parameterisation (docs/ALGORITHM.md, "Onion-slice coordinates,
// signed").
#include "btfgmm/core/directions.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>

#include "btfgmm/core/error.hpp"

namespace btfgmm {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

double wrap_degrees(double phi) {
  double p = std::fmod(phi, 360.0);
  if (p < 0) p += 360.0;
  if (p >= 360.0) p -= 360.0;
  return p;
}

}  // namespace

Vec3 to_vector(const Direction& d) {
  const double t = d.theta_deg * kDeg, p = d.phi_deg * kDeg;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

Direction to_direction(const Vec3& v) {
  const double r_xy = std::hypot(v.x, v.y);
  const double theta = std::atan2(r_xy, v.z) / kDeg;
  const double phi = r_xy == 0.0 ? 0.0 : wrap_degrees(std::atan2(v.y, v.x) / kDeg);
  return {theta, phi};
}

// The paper prints xi_4 = asin(sin t cos p), xi_3 = acos(cos t / cos xi_4). The arccos loses
// the sign of sin p, folding (t, p) and (t, -p) onto one point; Havran et al. 2010's signed
// form keeps it: alpha = atan2(sin t sin p, cos t) (= asin(sin t sin p / cos beta)).
OnionSlice to_onion_slice(const Vec3& v) {
  const double n = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  const double x = v.x / n, y = v.y / n, z = v.z / n;
  return {std::atan2(y, z), std::asin(std::clamp(x, -1.0, 1.0))};
}

OnionSlice to_onion_slice(const Direction& d) {
  return to_onion_slice(to_vector(d));
}

Vec3 from_onion_slice(const OnionSlice& o) {
  const double cb = std::cos(o.beta);
  return {std::sin(o.beta), std::sin(o.alpha) * cb, std::cos(o.alpha) * cb};
}

double angular_distance_deg(const Direction& a, const Direction& b) {
  const Vec3 u = to_vector(a), v = to_vector(b);
  // atan2 of |u x v| and u.v is accurate for small and large angles alike.
  const double cx = u.y * v.z - u.z * v.y, cy = u.z * v.x - u.x * v.z, cz = u.x * v.y - u.y * v.x;
  return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), u.x * v.x + u.y * v.y + u.z * v.z) /
         kDeg;
}

DirectionSet DirectionSet::rings(const std::vector<std::pair<double, int>>& ring_list) {
  std::vector<Direction> dirs;
  for (const auto& [theta, count] : ring_list) {
    if (!(theta >= 0.0 && theta <= 90.0) || count < 1)
      throw Error(Error::Kind::kArgument,
                  fmt::format("direction ring theta={} count={} is invalid: theta must be in "
                              "[0, 90] degrees and count at least 1",
                              theta, count));
    for (int k = 0; k < count; ++k) dirs.push_back({theta, 360.0 * k / count});
  }
  return DirectionSet(std::move(dirs));
}

DirectionSet DirectionSet::ubo81() {
  return rings({{0, 1}, {15, 6}, {30, 12}, {45, 18}, {60, 20}, {75, 24}});
}

DirectionSet DirectionSet::spiral(int n, double theta_max_deg) {
  if (n < 1 || n > 100000 || !(theta_max_deg > 0.0 && theta_max_deg <= 90.0))
    throw Error(Error::Kind::kArgument,
                fmt::format("spiral direction set of {} directions up to theta {} is invalid: "
                            "use 1..100000 directions and theta_max in (0, 90]",
                            n, theta_max_deg));
  // Equal-area Fibonacci spiral over the spherical cap theta <= theta_max.
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  const double cos_max = std::cos(theta_max_deg * kDeg);
  std::vector<Direction> dirs;
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - (1.0 - cos_max) * (k + 0.5) / n;
    const double theta = std::acos(z) / kDeg;
    const double phi = wrap_degrees(k * golden / kDeg);
    Direction d{std::round(theta * 10.0) / 10.0, std::round(phi * 10.0) / 10.0};
    if (d.phi_deg >= 360.0) d.phi_deg = 0.0;
    dirs.push_back(d);
  }
  // The order readers give a set discovered from file names: theta, then phi.
  std::sort(dirs.begin(), dirs.end(), [](const Direction& a, const Direction& b) {
    return a.theta_deg != b.theta_deg ? a.theta_deg < b.theta_deg : a.phi_deg < b.phi_deg;
  });
  return DirectionSet(std::move(dirs));
}

namespace {

double parse_number(const std::string& s, const std::string& spec) {
  double v = 0.0;
  const char* end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, v);
  if (ec != std::errc() || ptr != end || !std::isfinite(v))
    throw Error(Error::Kind::kArgument,
                fmt::format("direction set '{}': '{}' is not a number", spec, s));
  return v;
}

}  // namespace

DirectionSet DirectionSet::parse(const std::string& spec) {
  const std::string help =
      "use 'ubo81', 'spiral:N' (N directions) or 'rings:THETA/COUNT,...' (e.g. "
      "rings:0/1,30/6,60/12)";
  if (spec == "ubo81" || spec == "utia81") return ubo81();
  if (spec.rfind("spiral:", 0) == 0) {
    const double n = parse_number(spec.substr(7), spec);
    if (n != std::floor(n) || n < 1 || n > 100000)
      throw Error(Error::Kind::kArgument,
                  fmt::format("direction set '{}': N must be a whole number 1..100000", spec));
    return spiral(int(n));
  }
  if (spec.rfind("rings:", 0) == 0) {
    std::vector<std::pair<double, int>> list;
    std::string rest = spec.substr(6);
    std::size_t start = 0;
    while (start <= rest.size()) {
      const std::size_t comma = std::min(rest.find(',', start), rest.size());
      const std::string item = rest.substr(start, comma - start);
      const std::size_t slash = item.find('/');
      if (slash == std::string::npos)
        throw Error(
            Error::Kind::kArgument,
            fmt::format("direction set '{}': ring '{}' is not THETA/COUNT; {}", spec, item, help));
      const double theta = parse_number(item.substr(0, slash), spec);
      const double count = parse_number(item.substr(slash + 1), spec);
      if (count != std::floor(count) || count < 1 || count > 100000)
        throw Error(Error::Kind::kArgument,
                    fmt::format("direction set '{}': ring count '{}' must be a whole number "
                                "1..100000",
                                spec, item.substr(slash + 1)));
      list.emplace_back(theta, int(count));
      start = comma + 1;
    }
    return rings(list);
  }
  throw Error(Error::Kind::kArgument, fmt::format("unknown direction set '{}': {}", spec, help));
}

std::optional<std::size_t> DirectionSet::find(const Direction& d, double tol_deg) const {
  std::optional<std::size_t> best;
  double best_dist = tol_deg;
  for (std::size_t i = 0; i < dirs_.size(); ++i) {
    const double dist = angular_distance_deg(d, dirs_[i]);
    if (dist <= best_dist) {
      best = i;
      best_dist = dist;
    }
  }
  return best;
}

bool DirectionSet::operator==(const DirectionSet& other) const {
  if (dirs_.size() != other.dirs_.size()) return false;
  for (std::size_t i = 0; i < dirs_.size(); ++i)
    if (dirs_[i].theta_deg != other.dirs_[i].theta_deg ||
        dirs_[i].phi_deg != other.dirs_[i].phi_deg)
      return false;
  return true;
}

}  // namespace btfgmm
