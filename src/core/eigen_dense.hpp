// Eigen's dense linear algebra for the library's sources (the methods, the mixture's refit). GCC 12 reports a false
// -Wmaybe-uninitialized (and, at -O1 under the sanitizers, -Wuninitialized) inside its AVX-512
// intrinsics as Eigen 3.4 inlines them (the packet transposes of its matrix products, where
// _mm512_undefined_pd is meant to be undefined); the warnings are silenced for those headers
// only, which must be included here first.
#pragma once

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include <Eigen/Dense>
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
