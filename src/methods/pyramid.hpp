// The Gaussian-Laplacian pyramid on a torus (internal; Burt & Adelson 1983, as Haindl & Filip,
// PAMI 2007, Sec. 4, decompose each subspace image before modelling it): the Gaussian levels
//   G_0 = Y,   G_{k+1} = REDUCE(G_k)   (the binomial 5-tap low-pass [1 4 6 4 1]/16, then
//                                       every other pixel),
// the Laplacian levels L_k = G_k - EXPAND(G_{k+1}) for k < K - 1 and L_{K-1} = G_{K-1}, and
// the image again from any such levels: G_{K-1} = L_{K-1}, G_k = L_k + EXPAND(G_{k+1}). Every
// operation wraps around the image's edges, so that a pyramid of a tileable image and the
// image collapsed from independently synthesised levels tile. A level's side is half the
// finer one's, rounded up, so that any size has a pyramid: REDUCE and EXPAND sample at the
// pixel centres of the other grid, bilinearly (at a ratio of 2, the classic half-pixel phase).
#pragma once

#include <utility>
#include <vector>

#include "methods/texture_field.hpp"

namespace btfgmm::detail {

// The side of level `level` of a pyramid whose finest level has side `side`.
int level_side(int side, int level);

// The most levels a tile of width x height holds with every level's sides at least
// `min_side` pixels (1 when the tile itself is smaller).
int max_levels(int width, int height, int min_side);

// G_{k+1} from G_k; EXPAND of a coarse level to width x height. Any number of channels.
Field reduce(const Field& fine);
Field expand(const Field& coarse, int width, int height);

// L_0 .. L_{levels-1} (L_0 the finest, the image's size). levels >= 1; levels = 1: the image.
std::vector<Field> laplacian_pyramid(const Field& image, int levels);

// The image whose Laplacian pyramid `levels` is: exact for what laplacian_pyramid made.
Field collapse(const std::vector<Field>& levels);

}  // namespace btfgmm::detail
