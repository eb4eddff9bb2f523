// Text for messages and reports: sizes, durations, names. One copy of each, used by the
// library and the command alike.
#pragma once

#include <chrono>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace btfgmm {

// "1.5 GiB" (binary units; "512 bytes" below one KiB).
std::string human_bytes(double bytes);
// "12.3 s" below a minute, "m:ss" below an hour, then "h:mm:ss".
std::string human_seconds(double seconds);
// ASCII lower case (file extensions, names given on the command line).
std::string lower(std::string text);

// The Levenshtein distance between two names: insertions, deletions and substitutions.
std::size_t edit_distance(std::string_view a, std::string_view b);
// The names among `names` that `given` likely meant, case aside: the name itself in another
// case; else the names it begins (up to three: "pca" gives pca-btf and pca-rf); else the
// nearest by edit distance (at most two edits, and at most half of the name's letters; ties
// go to the first listed). Empty when none is likely.
std::vector<std::string> nearest_names(std::string_view given,
                                       std::span<const std::string_view> names);
// The first of nearest_names, or empty.
std::string nearest_name(std::string_view given, std::span<const std::string_view> names);
// " (did you mean 'A'?)", " (did you mean 'A' or 'B'?)" for nearest_names, or empty: the
// suffix of an error message.
std::string did_you_mean(std::string_view given, std::span<const std::string_view> names);

// Options in messages. The library names an option by its field name ("refine_steps", as
// FitOptions and the other settings spell it), marked: option_name("refine_steps") is
// "`refine_steps`". Each front end writes the marked names in its own spelling before it shows
// a message: spell_options(message, spelling) replaces each by spelling(field) (the command:
// "--refine-steps"), and leaves any other text as it is.
// An option given with a value is marked so too, option_value("epsilon", "5") being
// "`epsilon=5`": spell_options writes spelling(field), `value_separator` and the value (the
// command: "--epsilon 5"; Python: "epsilon=5").
std::string option_name(std::string_view field);
std::string option_value(std::string_view field, std::string_view value);
std::string spell_options(std::string_view message,
                          const std::function<std::string(std::string_view field)>& spelling,
                          std::string_view value_separator = " ");

// Wall-clock time for progress and timings.
using Clock = std::chrono::steady_clock;
// Seconds from `start` to now.
double seconds_since(Clock::time_point start);

}  // namespace btfgmm
