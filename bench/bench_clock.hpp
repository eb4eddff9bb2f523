// Wall and CPU clocks of the benchmark programs, in seconds.
#pragma once

#include <chrono>
#include <ctime>

namespace bench {

inline double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// CPU time of the whole process (all threads): on a machine shared with other work, the
// figure that does not count the time spent waiting for a core.
inline double cpu_now() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace bench
