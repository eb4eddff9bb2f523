// Image names: parsing the angles out of UTIA and Bonn file names, and writing UTIA names.
#include "btfgmm/io/image_names.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <system_error>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "io/angle_names.hpp"

namespace btfgmm {
namespace {

constexpr const char* kExpectedNames =
    "expected tlTTT_plPPP_tvTTT_pvPPP.png (UTIA) or 'NNNNN tlTTT plPPP tvTTT pvPPP.jpg' (Bonn)";

bool is_digit(char c) {
  return c >= '0' && c <= '9';
}

std::vector<std::string> split_tokens(const std::string& s) {
  std::vector<std::string> tokens;
  std::string cur;
  for (char c : s) {
    if (c == '_' || c == ' ') {
      if (!cur.empty()) tokens.push_back(std::move(cur));
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) tokens.push_back(std::move(cur));
  return tokens;
}

// "023.5" -> 23.5: digits with an optional fraction, nothing else.
std::optional<double> parse_number(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size() && is_digit(s[i])) ++i;
  if (i == 0) return std::nullopt;
  if (i < s.size()) {
    if (s[i] != '.') return std::nullopt;
    std::size_t j = i + 1;
    while (j < s.size() && is_digit(s[j])) ++j;
    if (j == i + 1 || j != s.size()) return std::nullopt;
  }
  double v = 0.0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v, std::chars_format::fixed);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

// "tl023.5" with prefix "tl" -> 23.5.
std::optional<double> parse_angle_token(const std::string& token, const char* prefix) {
  if (token.size() < 3 || lower(token.substr(0, 2)) != prefix) return std::nullopt;
  return parse_number(token.substr(2));
}

// An angle as it appears in a UTIA name: 3 integer digits, then the shortest fraction (at
// most 3 decimals) that reads back as the same double.
std::string format_angle(double a) {
  if (a == std::floor(a) && std::fabs(a) < 1e9)
    return fmt::format("{:03d}", static_cast<long long>(a));
  std::string best;
  for (int k = 1; k <= 3; ++k) {
    std::string s = fmt::format("{:0{}.{}f}", a, 4 + k, k);
    while (!s.empty() && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
    best = s;
    double back = 0.0;
    std::from_chars(s.data(), s.data() + s.size(), back);
    if (back == a) break;
  }
  return best;
}

}  // namespace

namespace detail {

std::string angles(const Direction& d, const char* t, const char* p, char sep) {
  return fmt::format("{}{}{}{}{}", t, format_angle(d.theta_deg), sep, p, format_angle(d.phi_deg));
}

// A folder named after a view: tv030_pv060 (or with a space); the view it names.
std::optional<Direction> parse_view_folder(const std::string& folder) {
  const auto tokens = split_tokens(folder);
  if (tokens.size() != 2) return std::nullopt;
  const auto tv = parse_angle_token(tokens[0], "tv");
  const auto pv = parse_angle_token(tokens[1], "pv");
  if (!tv || !pv) return std::nullopt;
  return Direction{*tv, *pv};
}

}  // namespace detail

ParsedName parse_image_name(const std::string& file_name) {
  const std::string file = file_name.substr(file_name.find_last_of('/') + 1);
  // The stem: drop an extension made of letters (not the fraction of "pv022.5").
  std::string stem = file;
  if (const auto dot = file.rfind('.'); dot != std::string::npos) {
    const std::string ext = file.substr(dot + 1);
    if (!ext.empty() && std::all_of(ext.begin(), ext.end(), [](char c) {
          return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
        }))
      stem = file.substr(0, dot);
  }
  const auto bad = [&]() {
    return Error(Error::Kind::kFormat,
                 fmt::format("'{}' is not a BTF image name: {}", file, kExpectedNames));
  };
  auto tokens = split_tokens(stem);
  ParsedName out;
  if (!tokens.empty() && std::all_of(tokens[0].begin(), tokens[0].end(), is_digit)) {
    long index = 0;
    const auto& t = tokens[0];
    const auto r = std::from_chars(t.data(), t.data() + t.size(), index);
    if (r.ec != std::errc()) throw bad();
    out.index = index;
    tokens.erase(tokens.begin());
  }
  if (tokens.size() != 4) throw bad();
  const auto tl = parse_angle_token(tokens[0], "tl");
  const auto pl = parse_angle_token(tokens[1], "pl");
  const auto tv = parse_angle_token(tokens[2], "tv");
  const auto pv = parse_angle_token(tokens[3], "pv");
  if (!tl || !pl || !tv || !pv) throw bad();
  const auto check = [&](double v, const char* what, bool theta) {
    if (theta ? (v < 0.0 || v > 90.0) : (v < 0.0 || v >= 360.0))
      throw Error(Error::Kind::kFormat,
                  fmt::format("'{}': {} angle {} is outside {}; elevations (tl, tv) lie in "
                              "[0, 90] degrees and azimuths (pl, pv) in [0, 360)",
                              file, what, v, theta ? "[0, 90]" : "[0, 360)"));
  };
  check(*tl, "tl (light elevation)", true);
  check(*pl, "pl (light azimuth)", false);
  check(*tv, "tv (view elevation)", true);
  check(*pv, "pv (view azimuth)", false);
  out.light = {*tl, *pl};
  out.view = {*tv, *pv};
  return out;
}

std::string utia_image_stem(const Direction& light, const Direction& view) {
  return detail::angles(light, "tl", "pl", '_') + "_" + detail::angles(view, "tv", "pv", '_');
}

}  // namespace btfgmm
