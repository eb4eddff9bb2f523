// A fit's parameters as declared, and their values; see parameters.hpp.
#include "btfgmm/methods/parameters.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <type_traits>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"

namespace btfgmm {
namespace {

// The words of a kWord parameter's choices, separated by spaces.
std::vector<std::string_view> words_of(std::string_view choices) {
  std::vector<std::string_view> words;
  for (std::size_t at = 0; at < choices.size();) {
    const std::size_t end = std::min(choices.find(' ', at), choices.size());
    words.push_back(choices.substr(at, end - at));
    at = end + 1;
  }
  return words;
}

// "a, b or c".
std::string choices_text(std::string_view choices) {
  const std::vector<std::string_view> words = words_of(choices);
  std::string out;
  for (std::size_t k = 0; k < words.size(); ++k)
    out += fmt::format("{}{}", k == 0 ? "" : (k + 1 == words.size() ? " or " : ", "), words[k]);
  return out;
}

bool is_choice(std::string_view choices, std::string_view word) {
  const std::vector<std::string_view> words = words_of(choices);
  return std::find(words.begin(), words.end(), word) != words.end();
}

std::string range_text(const FitParameter& p) {
  return fmt::format("{} {:g} to {:g}",
                     p.type == ParameterType::kReal ? "a number from" : "a whole number from",
                     p.min, p.max);
}

// `why` the value `v` is refused ("out of range"), and what `p` takes.
[[noreturn]] void refuse(const FitParameter& p, const ParameterValue& v, std::string_view why,
                         std::string_view takes) {
  throw Error(Error::Kind::kArgument,
              fmt::format("{}: {}; give {}", option_value(p.field, value_text(v)), why, takes));
}

double as_number(const ParameterValue& v) {
  if (const auto* i = std::get_if<std::int64_t>(&v)) return double(*i);
  return std::get<double>(v);
}

}  // namespace

std::string value_text(const ParameterValue& v) {
  if (const auto* i = std::get_if<std::int64_t>(&v)) return std::to_string(*i);
  if (const auto* d = std::get_if<double>(&v)) return fmt::format("{:g}", *d);
  return std::get<std::string>(v);
}

void check_parameter_value(const FitParameter& p, const ParameterValue& v) {
  if (p.type == ParameterType::kWord) {
    const auto* word = std::get_if<std::string>(&v);
    if (!word || !is_choice(p.choices, *word))
      refuse(p, v, "not one of its choices", choices_text(p.choices));
    return;
  }
  if (!p.is_number()) return;
  if (std::holds_alternative<std::string>(v)) refuse(p, v, "not a number", range_text(p));
  const bool whole = p.type != ParameterType::kReal;
  if (whole && std::holds_alternative<double>(v)) refuse(p, v, "not a whole number", range_text(p));
  const double x = as_number(v);
  if (!(x >= p.min && x <= p.max)) refuse(p, v, "out of range", range_text(p));
}

ParameterValue parse_parameter(const FitParameter& p, std::string_view text) {
  if (!p.is_number()) return std::string(text);
  if (p.type != ParameterType::kReal) {
    std::int64_t i = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), i);
    if (ec == std::errc() && end == text.data() + text.size()) return i;
  }
  {  // a real number (refused where a whole one is declared: not a whole number)
    try {
      std::size_t used = 0;
      const double d = std::stod(std::string(text), &used);
      if (used == text.size()) return d;
    } catch (const std::exception&) {
    }
  }
  refuse(p, std::string(text), "not a number", range_text(p));
}

void set_parameter(FitOptions& o, const FitParameter& p, const ParameterValue& v) {
  check_parameter_value(p, v);
  std::visit(
      [&](auto member) {
        using M = decltype(member);
        if constexpr (std::is_same_v<M, std::size_t FitOptions::*>)
          o.*member = std::size_t(std::get<std::int64_t>(v));
        else if constexpr (std::is_same_v<M, int FitOptions::*>)
          o.*member = int(std::get<std::int64_t>(v));
        else if constexpr (std::is_same_v<M, double FitOptions::*> ||
                           std::is_same_v<M, std::optional<double> FitOptions::*>)
          o.*member = as_number(v);
        else if constexpr (std::is_same_v<M, std::string FitOptions::*>)
          o.*member = std::get<std::string>(v);
        else if constexpr (std::is_same_v<M, std::optional<FactorEncoding> FitOptions::*>)
          o.*member = parse_factor_encoding(std::get<std::string>(v), option_name(p.field));
      },
      p.member);
}

std::optional<ParameterValue> parameter_value(const FitOptions& o, const FitParameter& p) {
  static const FitOptions defaults;
  return std::visit(
      [&](auto member) -> std::optional<ParameterValue> {
        using M = decltype(member);
        if constexpr (std::is_same_v<M, std::monostate>) {
          return std::nullopt;
        } else {
          if (o.*member == defaults.*member) return std::nullopt;
          if constexpr (std::is_same_v<M, std::size_t FitOptions::*> ||
                        std::is_same_v<M, int FitOptions::*>)
            return std::int64_t(o.*member);
          else if constexpr (std::is_same_v<M, double FitOptions::*>)
            return o.*member;
          else if constexpr (std::is_same_v<M, std::optional<double> FitOptions::*>)
            return *(o.*member);
          else if constexpr (std::is_same_v<M, std::string FitOptions::*>)
            return o.*member;
          else
            return std::string(to_string(*(o.*member)));
        }
      },
      p.member);
}

void copy_parameter(const FitOptions& from, FitOptions& to, const FitParameter& p) {
  std::visit(
      [&](auto member) {
        if constexpr (!std::is_same_v<decltype(member), std::monostate>) to.*member = from.*member;
      },
      p.member);
}

}  // namespace btfgmm
