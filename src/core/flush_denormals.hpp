// Flush-to-zero and denormals-are-zero for the current thread, restored on scope exit. The
// float kernels sum exponentials normalised to their maximum: terms below float's normal range
// (1.2e-38 relative) are negligible there, but on x86 every arithmetic operation that
// produces or reads a denormal takes a slow microcode path. Used inside parallel regions
// (each thread sets its own flags).
#pragma once

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

namespace btfgmm::detail {

class FlushDenormals {
 public:
#if defined(__SSE__)
  FlushDenormals() : saved_(_mm_getcsr()) {
    _mm_setcsr(saved_ | 0x8040u);
  }  // FTZ | DAZ
  ~FlushDenormals() {
    _mm_setcsr(saved_);
  }

 private:
  unsigned saved_;
#else
  FlushDenormals() = default;
#endif
 public:
  FlushDenormals(const FlushDenormals&) = delete;
  FlushDenormals& operator=(const FlushDenormals&) = delete;
};

}  // namespace btfgmm::detail
