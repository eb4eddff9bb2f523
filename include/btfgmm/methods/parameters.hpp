// The parameters of a fit as each method declares them (MethodInfo::parameters,
// methods/registry.hpp): a field's name, type, range or choices, default, the routes of a fit
// it may be given with, and one sentence of help. The front ends make their options from these
// declarations (the command its flags and their help, Python fit()'s keywords and docstring),
// read a value given into FitOptions with set_parameter, and leave every check to the library
// (check_fit_options, methods/fit_options.hpp), whose messages name the field.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "btfgmm/methods/representation.hpp"

namespace btfgmm {

// What a fit request does: a new fit, an interrupted mixture's fit resumed from its
// checkpoint, a finished mixture continued, the method and size chosen within a budget, or
// every method's ladder swept.
enum class FitRoute : unsigned { kNew = 1, kResume = 2, kContinue = 4, kBudget = 8, kSweep = 16 };
constexpr unsigned operator|(FitRoute a, FitRoute b) {
  return unsigned(a) | unsigned(b);
}
constexpr unsigned operator|(unsigned a, FitRoute b) {
  return a | unsigned(b);
}

enum class ParameterType {
  kCount,    // a whole number >= 0 (a size)
  kInteger,  // a whole number
  kReal,     // a real number
  kWord,     // one of `choices`
  kText,     // any text (a path)
  kFlag,     // given or not
};

// Where FitOptions holds a parameter; none (monostate) for an option of the fit job itself
// (its output, checkpoints, log), which the front end keeps.
static_assert(std::is_same_v<std::uint64_t, std::size_t>, "the seed is held as a count");
using FitOptionsMember =
    std::variant<std::monostate, std::size_t FitOptions::*, int FitOptions::*, double FitOptions::*,
                 std::optional<double> FitOptions::*, std::string FitOptions::*,
                 std::optional<FactorEncoding> FitOptions::*>;

struct FitParameter {
  // As messages name it (core/text.hpp, option_name) and Python spells it.
  std::string_view field = {};
  ParameterType type = ParameterType::kText;
  FitOptionsMember member = {};
  double min = 0.0, max = 0.0;         // kCount, kInteger, kReal: the range (inclusive)
  std::string_view choices = {};       // kWord: the words it takes, separated by spaces
  std::string_view default_text = {};  // the default as help states it; empty: none stated
  unsigned routes = 0;                 // the FitRoutes it may be given with
  std::string_view help = {};          // one sentence: what it sets

  bool takes_route(FitRoute route) const { return (routes & unsigned(route)) != 0; }
  bool is_number() const {
    return type == ParameterType::kCount || type == ParameterType::kInteger ||
           type == ParameterType::kReal;
  }
};

// A value as a front end gives it: a whole number, a real number or a word.
using ParameterValue = std::variant<std::int64_t, double, std::string>;

// "5", "0.25", "prediction".
std::string value_text(const ParameterValue& v);

// The one check of a value against its declaration: its type (a real number where a whole one
// is declared is refused), its range (a NaN is out of it) and its choices. Throws
// Error(kArgument) naming the field and the value given (core/text.hpp, option_value) with
// what it takes.
void check_parameter_value(const FitParameter& p, const ParameterValue& v);

// A value given as text (the command's): a number where the declaration takes one, else the
// word. Throws Error(kArgument) naming the field for a number that does not parse.
ParameterValue parse_parameter(const FitParameter& p, std::string_view text);

// Sets the FitOptions field of `p` to `v`, checked (check_parameter_value). Nothing for an
// option of the fit job (no member).
void set_parameter(FitOptions& o, const FitParameter& p, const ParameterValue& v);
// The value `o` holds in the field of `p`; none where it holds the default (FitOptions{}'s)
// or `p` has no member.
std::optional<ParameterValue> parameter_value(const FitOptions& o, const FitParameter& p);
// `to`'s field of `p` set to `from`'s.
void copy_parameter(const FitOptions& from, FitOptions& to, const FitParameter& p);

}  // namespace btfgmm
