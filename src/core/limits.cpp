#include "btfgmm/core/limits.hpp"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <fstream>
#include <limits>
#include <string>
#include <system_error>

#include "btfgmm/core/text.hpp"

namespace btfgmm::limits {
namespace {

// A cgroup's memory limit in bytes (v2 memory.max, else v1 memory.limit_in_bytes); none: max.
std::uint64_t cgroup_limit() {
  for (const char* path :
       {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::ifstream in(path);
    std::string text;
    if (!(in >> text)) continue;
    std::uint64_t v = 0;  // "max": no limit
    const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
    if (r.ec == std::errc() && v > 0) return v;
  }
  return std::numeric_limits<std::uint64_t>::max();
}

std::uint64_t compute_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  std::uint64_t m = pages > 0 && page > 0 ? std::uint64_t(pages) * std::uint64_t(page)
                                          : std::numeric_limits<std::uint64_t>::max();
  m = std::min(m, cgroup_limit());
  for (const int resource : {RLIMIT_AS, RLIMIT_DATA}) {
    rlimit r{};
    if (::getrlimit(resource, &r) == 0 && r.rlim_cur != RLIM_INFINITY)
      m = std::min<std::uint64_t>(m, r.rlim_cur);
  }
  return m;
}

}  // namespace

std::uint64_t memory_bytes() {
  static const std::uint64_t bytes = compute_memory_bytes();
  return bytes;
}

void check_memory(double bytes, const std::string& what, const std::string& fix, Error::Kind kind) {
  const double have = double(memory_bytes());
  if (!(bytes <= have))
    throw Error(kind, fmt::format("{} needs about {} of memory, more than the {} this machine "
                                  "has; {}",
                                  what, human_bytes(bytes), human_bytes(have), fix));
}

}  // namespace btfgmm::limits
