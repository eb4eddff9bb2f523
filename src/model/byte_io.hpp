// Little-endian byte writing and bounds-checked reading for the project's binary files (the
// model file, checkpoints). Whole files are read and written by io/files.hpp.
#pragma once

#include <fmt/format.h>

#include <Imath/half.h>
#include <zlib.h>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm::detail {

// The largest magnitude a 16-bit float (IEEE binary16) holds; beyond it a value becomes
// infinite, and a file holding it does not read back.
inline constexpr double kHalfMax = 65504.0;

class ByteWriter {
 public:
  template <class T>
  void put(T v) {
    static_assert(std::is_arithmetic_v<T>);
    std::uint8_t b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));  // little-endian hosts only (x86-64, AArch64)
    bytes.insert(bytes.end(), b, b + sizeof(T));
  }
  void real(double v, Precision p) {
    if (p == Precision::kF16)
      put<std::uint16_t>(Imath::half(float(v)).bits());
    else
      put<float>(float(v));
  }
  void text(const std::string& s) {
    put<std::uint32_t>(std::uint32_t(s.size()));
    bytes.insert(bytes.end(), s.begin(), s.end());
  }
  std::vector<std::uint8_t> bytes;
};

// Reads fields in order; running past the end or fail() throws Error(kFormat) naming the
// file ("<what> '<name>'") and the fix.
class ByteReader {
 public:
  ByteReader(std::span<const std::uint8_t> b, std::string what, std::string name, std::string fix)
      : b_(b), what_(std::move(what)), name_(std::move(name)), fix_(std::move(fix)) {}
  template <class T>
  T get(const char* field) {
    if (pos_ + sizeof(T) > b_.size())
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} '{}' ends inside field '{}' (at byte {}); the file is "
                              "truncated: {}",
                              what_, name_, field, pos_, fix_));
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  double real(Precision p, const char* field) {
    if (p == Precision::kF16) {
      Imath::half h;
      h.setBits(get<std::uint16_t>(field));
      return double(float(h));
    }
    return double(get<float>(field));
  }
  std::string text(const char* field) { return text_of_size(get<std::uint32_t>(field), field); }
  // `n` bytes of text (its length already read).
  std::string text_of_size(std::uint32_t n, const char* field) {
    if (n > remaining()) fail(fmt::format("field '{}' claims {} bytes", field, n));
    std::string s(reinterpret_cast<const char*>(b_.data() + pos_), n);
    pos_ += n;
    return s;
  }
  std::size_t remaining() const { return b_.size() - pos_; }
  std::size_t pos() const { return pos_; }
  [[noreturn]] void fail(const std::string& problem) const {
    throw Error(Error::Kind::kFormat, fmt::format("{} '{}' is invalid: {} (at byte {}); {}", what_,
                                                  name_, problem, pos_, fix_));
  }

 private:
  std::span<const std::uint8_t> b_;
  std::string what_, name_, fix_;
  std::size_t pos_ = 0;
};

// The trailer of the project's checkpoints: a CRC-32 (zlib's) of every byte before it.
inline void append_crc32(ByteWriter& w) {
  w.put<std::uint32_t>(std::uint32_t(crc32(0L, w.bytes.data(), uInt(w.bytes.size()))));
}
// Whether the last 4 bytes of `bytes` (at least 4) are the CRC-32 of those before them.
inline bool crc32_holds(std::span<const std::uint8_t> bytes) {
  std::uint32_t stored;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  return std::uint32_t(crc32(0L, bytes.data(), uInt(bytes.size() - 4))) == stored;
}

// The model file's direction sets and tile (docs/FORMAT.md; model_file.cpp): shared by the
// mixture's payload and every other method's frame.
void put_directions(ByteWriter& w, const DirectionSet& s);
DirectionSet get_directions(ByteReader& r, const char* what);
void put_tile(ByteWriter& w, int width, int height, const Tile& origin, SampleFormat format);
void get_tile(ByteReader& r, int& width, int& height, Tile& origin, SampleFormat& format);
// The model file's provenance section (docs/FORMAT.md, "Provenance"; provenance.cpp): the
// reader takes all of `r`'s bytes, and refuses a field out of range or bytes left over.
void put_provenance(ByteWriter& w, const Provenance& p);
Provenance get_provenance(ByteReader& r);

}  // namespace btfgmm::detail
