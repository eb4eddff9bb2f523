// Parallel loops over the images of a data set (reading headers, loading tiles, writing
// images), whose errors do not depend on thread timing.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>

namespace btfgmm::detail {

// The first exception of a parallel loop by loop index, so the error reported does not
// depend on thread timing. Work past the first failure is skipped.
class FirstError {
 public:
  void capture(std::size_t i) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (i < index_.load()) {
      index_ = i;
      error_ = std::current_exception();
    }
  }
  bool skip(std::size_t i) const { return i > index_.load(); }
  void rethrow() const {
    if (error_) std::rethrow_exception(error_);
  }

 private:
  std::mutex mutex_;
  std::atomic<std::size_t> index_{std::numeric_limits<std::size_t>::max()};
  std::exception_ptr error_;
};

// Run body(i) for i in [0, n) in parallel; body may throw. The first error (by index) is
// rethrown after the loop. make_state() builds a per-thread state (e.g. a zip handle)
// passed to body.
template <class State, class MakeState, class Body>
void parallel_each(std::size_t n, MakeState make_state, Body body) {
  FirstError first;
  const auto count = static_cast<std::int64_t>(n);
#pragma omp parallel
  {
    std::optional<State> state;
    try {
      state.emplace(make_state());
    } catch (...) {
      first.capture(0);
    }
#pragma omp for schedule(dynamic)
    for (std::int64_t i = 0; i < count; ++i) {
      const auto u = static_cast<std::size_t>(i);
      if (!state || first.skip(u)) continue;
      try {
        body(*state, u);
      } catch (...) {
        first.capture(u);
      }
    }
  }
  first.rethrow();
}

struct NoState {};

}  // namespace btfgmm::detail
