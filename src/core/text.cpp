#include "btfgmm/core/text.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <vector>

namespace btfgmm {

std::string human_bytes(double b) {
  const char* unit[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (b >= 1024.0 && u < 6) {
    b /= 1024.0;
    ++u;
  }
  return u == 0 ? fmt::format("{:.0f} bytes", b) : fmt::format("{:.1f} {}", b, unit[u]);
}

std::string human_seconds(double s) {
  if (s < 0.1) return fmt::format("{:.1f} ms", s * 1000.0);
  if (s < 60) return fmt::format("{:.1f} s", s);
  const long t = std::lround(s);
  if (t < 3600) return fmt::format("{}:{:02d}", t / 60, t % 60);
  return fmt::format("{}:{:02d}:{:02d}", t / 3600, (t / 60) % 60, t % 60);
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

namespace {

// The names that start with `given` (case aside), when there are a few: "pca" for "pca-btf".
std::vector<std::string> names_with_prefix(const std::string& given,
                                           std::span<const std::string_view> names) {
  constexpr std::size_t kMostShown = 3;
  std::vector<std::string> out;
  if (given.size() < 2) return out;
  for (const std::string_view name : names)
    if (lower(std::string(name)).starts_with(given)) out.emplace_back(name);
  if (out.size() > kMostShown) out.clear();
  return out;
}

}  // namespace

std::vector<std::string> nearest_names(std::string_view given,
                                       std::span<const std::string_view> names) {
  const std::string g = lower(std::string(given));
  for (const std::string_view name : names)  // the same name in other case: "PCA-BTF"
    if (lower(std::string(name)) == g) return {std::string(name)};
  if (std::vector<std::string> prefixed = names_with_prefix(g, names); !prefixed.empty())
    return prefixed;
  std::string nearest;
  std::size_t best = 3;  // within two edits
  for (const std::string_view name : names) {
    const std::size_t d = edit_distance(g, lower(std::string(name)));
    // At most half the name's letters changed: "gn" is near "gm", "xy" is not.
    if (d < best && 2 * d <= name.size()) {
      best = d;
      nearest = std::string(name);
    }
  }
  if (nearest.empty()) return {};
  return {nearest};
}

std::string nearest_name(std::string_view given, std::span<const std::string_view> names) {
  const std::vector<std::string> n = nearest_names(given, names);
  return n.empty() ? std::string() : n.front();
}

std::string did_you_mean(std::string_view given, std::span<const std::string_view> names) {
  const std::vector<std::string> n = nearest_names(given, names);
  if (n.empty()) return {};
  std::string list = fmt::format("'{}'", n.front());
  for (std::size_t i = 1; i < n.size(); ++i)
    list += fmt::format("{}'{}'", i + 1 == n.size() ? " or " : ", ", n[i]);
  return fmt::format(" (did you mean {}?)", list);
}

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string option_name(std::string_view field) {
  return fmt::format("`{}`", field);
}

namespace {

bool is_field_character(char c) {
  return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
}

}  // namespace

std::string option_value(std::string_view field, std::string_view value) {
  return fmt::format("`{}={}`", field, value);
}

std::string spell_options(std::string_view message,
                          const std::function<std::string(std::string_view field)>& spelling,
                          std::string_view value_separator) {
  std::string out;
  std::size_t i = 0;
  while (i < message.size()) {
    std::size_t end = i + 1;
    if (message[i] == '`')
      while (end < message.size() && is_field_character(message[end])) ++end;
    const bool named = message[i] == '`' && end > i + 1 && end < message.size();
    const std::size_t close = named && message[end] == '=' ? message.find('`', end) : end;
    if (named && close != std::string_view::npos && message[close] == '`') {
      out += spelling(message.substr(i + 1, end - i - 1));
      if (close > end)
        out += std::string(value_separator) + std::string(message.substr(end + 1, close - end - 1));
      i = close + 1;
    } else {
      out += message[i++];
    }
  }
  return out;
}

}  // namespace btfgmm
