#include "btfgmm/core/parse.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>

#include "btfgmm/core/error.hpp"

namespace btfgmm {

std::pair<int, int> parse_size(const std::string& text, const std::string& option) {
  const std::size_t x = text.find('x');
  const std::string a = text.substr(0, x), b = x == std::string::npos ? a : text.substr(x + 1);
  int w = 0, h = 0;
  const auto ra = std::from_chars(a.data(), a.data() + a.size(), w);
  const auto rb = std::from_chars(b.data(), b.data() + b.size(), h);
  if (a.empty() || b.empty() || ra.ec != std::errc() || rb.ec != std::errc() ||
      ra.ptr != a.data() + a.size() || rb.ptr != b.data() + b.size() || w < 1 || h < 1 ||
      w > 65536 || h > 65536)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}' is not a size; give N or WxH pixels (1..65536), e.g. "
                            "256 or 320x240",
                            option, text));
  return {w, h};
}

std::vector<double> parse_numbers(const std::string& text, const std::string& option,
                                  std::size_t count, const std::string& example) {
  std::vector<double> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    double v = 0;
    const auto r = std::from_chars(item.data(), item.data() + item.size(), v);
    if (item.empty() || r.ec != std::errc() || r.ptr != item.data() + item.size() ||
        !std::isfinite(v))
      throw Error(Error::Kind::kArgument,
                  fmt::format("{} '{}': '{}' is not a finite number; write it like {}", option,
                              text, item, example));
    out.push_back(v);
    start = comma + 1;
  }
  if (out.size() != count)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}' needs {} numbers separated by commas, like {}", option, text,
                            count, example));
  return out;
}

Direction hemisphere_direction(double theta, double phi, const std::string& option,
                               const std::string& text) {
  if (!std::isfinite(theta) || !std::isfinite(phi))
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}': the angles must be finite numbers of degrees", option, text));
  if (theta < 0.0 || theta > 90.0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}': theta {} is off the upper hemisphere; give theta in [0, 90] "
                            "degrees",
                            option, text, theta));
  double wrapped = std::fmod(phi, 360.0);
  if (wrapped < 0) wrapped += 360.0;
  return {theta, wrapped};
}

Direction parse_direction(const std::string& text, const std::string& option) {
  const auto v = parse_numbers(text, option, 2, "30,45 (theta,phi in degrees)");
  return hemisphere_direction(v[0], v[1], option, text);
}

}  // namespace btfgmm
