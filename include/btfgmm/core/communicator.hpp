// The processes of a fit that runs on several of them (MPI ranks, src/dist/), as the fit needs
// them: which one this is, how many there are, and one collective exchange. The library knows
// processes through this interface alone; a fit in one process uses SingleProcess.
//
// A distributed fit gives the model of a fit in one process, bit for bit: every process holds
// a fixed share of the samples (whole lights, light_share in model/samples.hpp), and what
// they exchange is added in an order that does not depend on the number of processes.
#pragma once

#include <cstdint>
#include <cstring>
#include <span>
#include <type_traits>
#include <vector>

namespace btfgmm {

class Communicator {
 public:
  virtual ~Communicator() = default;
  // This process, 0 .. size() - 1; process 0 writes the files.
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // Every process's bytes (any number each), in process order, on every process. A collective
  // call: every process makes the same calls in the same order. Throws Error(kIo) if the
  // exchange fails.
  virtual std::vector<std::vector<std::uint8_t>> all_gather(std::span<const std::uint8_t> mine) = 0;
  // Bytes this process has sent and received through all_gather so far.
  virtual std::uint64_t bytes_exchanged() const { return 0; }
};

// One process: all_gather returns its own bytes.
class SingleProcess final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  std::vector<std::vector<std::uint8_t>> all_gather(std::span<const std::uint8_t> mine) override {
    return {std::vector<std::uint8_t>(mine.begin(), mine.end())};
  }
};

// all_gather of trivially copyable values: every process's values, in process order.
template <class T>
std::vector<std::vector<T>> all_gather_values(Communicator& c, std::span<const T> mine) {
  static_assert(std::is_trivially_copyable_v<T>);
  const auto bytes =
      c.all_gather({reinterpret_cast<const std::uint8_t*>(mine.data()), mine.size() * sizeof(T)});
  std::vector<std::vector<T>> out(bytes.size());
  for (std::size_t r = 0; r < bytes.size(); ++r) {
    out[r].resize(bytes[r].size() / sizeof(T));
    if (!out[r].empty()) std::memcpy(out[r].data(), bytes[r].data(), out[r].size() * sizeof(T));
  }
  return out;
}

}  // namespace btfgmm
