// Labels drawn into images (the comparison figure): FreeType renders a TrueType font of the
// system, anti-aliased, from UTF-8 text (θ, φ, ×, ·). The font is the file BTFGMM_FONT names,
// else DejaVu Sans (Debian's fonts-dejavu-core); where neither is found, a built-in 5 x 7 pixel
// font of capitals, digits and a few signs stands in, and font_name() says so.
#pragma once

#include <array>
#include <string>
#include <string_view>

#include "btfgmm/io/image.hpp"

namespace btfgmm {

// Draws `text` with the top of its line box at (x, y), `pixel_height` the font's size in
// pixels, blended into `image` in the levels `rgb` (clipped at the image's edges). Returns the
// text's width in pixels.
int draw_label(Image& image, int x, int y, std::string_view text, int pixel_height,
               std::array<float, 3> rgb);
// The width `draw_label` would take, drawing nothing.
int label_width(std::string_view text, int pixel_height);
// The line height of the font at `pixel_height`: the distance between two lines of labels.
int label_line_height(int pixel_height);
// The font file in use, or "built-in 5 x 7 pixel font" where none was found.
std::string font_name();

}  // namespace btfgmm
