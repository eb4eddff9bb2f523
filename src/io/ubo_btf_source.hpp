// The bytes of a Bonn .btf file (io/ubo_btf.hpp): a file read in place (pread, so threads may
// read at once) or bytes in memory, and a cursor that reads its fields little-endian, each
// read checked against the end of the file.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "btfgmm/io/ubo_btf.hpp"

namespace btfgmm {

static_assert(std::endian::native == std::endian::little,
              "the .btf reader reads little-endian fields in place");

class UboBtf::Source {
 public:
  virtual ~Source() = default;
  virtual std::uint64_t size() const = 0;
  // Read n bytes at offset into dst; the caller has checked offset + n <= size().
  virtual void read(std::uint64_t offset, std::size_t n, void* dst) const = 0;
};

namespace detail {

// Convert `count` stored scalars of `scalar_bytes` (2: IEEE half, 4: float, 8: double) to
// floats. The double form is range-checked by the caller through std::isfinite on the result.
void scalars_to_floats(const std::uint8_t* bytes, std::size_t count, int scalar_bytes, float* out);

}  // namespace detail
}  // namespace btfgmm
