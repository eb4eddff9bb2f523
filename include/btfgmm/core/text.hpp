// Text for messages and reports: sizes, durations, names. One copy of each, used by the
// library and the command alike.
#pragma once

#include <chrono>
#include <string>

namespace btfgmm {

// "1.5 GiB" (binary units; "512 bytes" below one KiB).
std::string human_bytes(double bytes);
// "12.3 s" below a minute, "m:ss" below an hour, then "h:mm:ss".
std::string human_seconds(double seconds);
// ASCII lower case (file extensions, names given on the command line).
std::string lower(std::string text);

// Wall-clock time for progress and timings.
using Clock = std::chrono::steady_clock;
// Seconds from `start` to now.
double seconds_since(Clock::time_point start);

}  // namespace btfgmm
