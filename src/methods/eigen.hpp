// Eigen for the methods' linear algebra. GCC 12 warns, falsely, that Eigen's AVX-512
// matrix-vector kernel reads an uninitialised register (-Wmaybe-uninitialized inside
// avx512fintrin.h); the warning is silenced for Eigen's code only.
#pragma once

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Dense>
#pragma GCC diagnostic pop
