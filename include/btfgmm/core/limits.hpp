// Limits checked before allocating: every size read from a file or an option is held against
// what the data can hold and against the memory of the machine, so an absurd value is a
// btfgmm::Error that names its source, not an out-of-memory kill.
#pragma once

#include <cstdint>
#include <string>

#include "btfgmm/core/error.hpp"

namespace btfgmm::limits {

// Images: at most this many pixels a side and in all (a BTF image is a few hundred pixels on a
// side; a model's tile is cut from one).
constexpr int kMaxImageSide = 1 << 16;
constexpr std::int64_t kMaxImagePixels = std::int64_t(1) << 28;

// The largest expansion of deflate (zlib, PNG, zip): a 258-byte match costs at least two
// bits, so n compressed bytes inflate to at most 1032 n bytes (plus a few for the stream's
// end). Used to bound what a PNG's IDAT chunks or a deflated zip entry can hold.
constexpr double kDeflateMaxRatio = 1032.0;

// The bytes of memory this process can use: the machine's physical memory
// (sysconf(_SC_PHYS_PAGES) * page size), lowered by a cgroup memory limit and by RLIMIT_AS /
// RLIMIT_DATA where they are set. Computed once.
std::uint64_t memory_bytes();

// Throws Error(kind) when `bytes` (an estimate in double, so products of sizes cannot
// overflow) exceed memory_bytes(): "<what> needs about X of memory, more than the Y this
// machine has; <fix>". `what` names the file or option the size came from.
void check_memory(double bytes, const std::string& what, const std::string& fix,
                  Error::Kind kind = Error::Kind::kArgument);

}  // namespace btfgmm::limits
