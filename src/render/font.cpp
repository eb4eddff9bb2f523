// Labels drawn into images with FreeType (a TrueType font of the system), or a built-in 5 x 7
// pixel font where no font file is installed.
#include "btfgmm/render/font.hpp"

#include <ft2build.h>
#include FT_FREETYPE_H

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <vector>

namespace btfgmm {
namespace {

// The font files looked for, in order: BTFGMM_FONT, then DejaVu Sans where Debian puts it.
std::vector<std::string> font_candidates() {
  std::vector<std::string> c;
  if (const char* env = std::getenv("BTFGMM_FONT"); env && *env) c.emplace_back(env);
  c.emplace_back("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf");
  c.emplace_back("/usr/share/fonts/TTF/DejaVuSans.ttf");
  return c;
}

// One FreeType face for the process, loaded on first use; FreeType's faces are not safe to use
// from two threads at once, so every use holds `mutex`.
struct Face {
  FT_Library library = nullptr;
  FT_Face face = nullptr;
  std::string path;
  std::mutex mutex;

  Face() {
    if (FT_Init_FreeType(&library) != 0) return;
    for (const std::string& p : font_candidates()) {
      std::error_code ec;
      if (!std::filesystem::is_regular_file(p, ec)) continue;
      if (FT_New_Face(library, p.c_str(), 0, &face) == 0) {
        path = p;
        return;
      }
      face = nullptr;
    }
  }
  ~Face() {
    if (face) FT_Done_Face(face);
    if (library) FT_Done_FreeType(library);
  }
};

Face& the_face() {
  static Face f;
  return f;
}

// The next code point of UTF-8 `s` from `i` (advanced past it); a malformed byte reads as '?'.
char32_t next_code_point(std::string_view s, std::size_t& i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b = byte(i);
  const int extra = b < 0x80 ? 0 : (b >> 5) == 6 ? 1 : (b >> 4) == 14 ? 2 : (b >> 3) == 30 ? 3 : -1;
  if (extra < 0 || i + std::size_t(extra) >= s.size()) {
    ++i;
    return U'?';
  }
  char32_t cp = extra == 0 ? b : char32_t(b & (0x3F >> extra));
  for (int k = 1; k <= extra; ++k) {
    const unsigned char c = byte(i + std::size_t(k));
    if ((c >> 6) != 2) {
      i += std::size_t(k);
      return U'?';
    }
    cp = (cp << 6) | (c & 0x3F);
  }
  i += std::size_t(extra) + 1;
  return cp;
}

// Blends `alpha` (0-255) of `rgb` into the pixel (x, y) of `image`, if it is inside.
void blend(Image& image, int x, int y, unsigned alpha, const std::array<float, 3>& rgb) {
  if (x < 0 || y < 0 || x >= image.width || y >= image.height || alpha == 0) return;
  const float a = float(alpha) / 255.0f;
  float* o = &image.rgb[(std::size_t(y) * std::size_t(image.width) + std::size_t(x)) * 3];
  for (int c = 0; c < 3; ++c) o[c] = o[c] * (1.0f - a) + rgb[std::size_t(c)] * a;
}

// FreeType's drawing of `text`; `image` null: measures only. Returns the width in pixels.
int freetype_label(Face& f, Image* image, int x, int y, std::string_view text, int px,
                   const std::array<float, 3>& rgb) {
  std::lock_guard<std::mutex> lock(f.mutex);
  FT_Set_Pixel_Sizes(f.face, 0, FT_UInt(std::max(1, px)));
  const int ascender = int(f.face->size->metrics.ascender >> 6);
  int pen = 0;
  for (std::size_t i = 0; i < text.size();) {
    const char32_t cp = next_code_point(text, i);
    if (FT_Load_Char(f.face, cp, image ? FT_LOAD_RENDER : FT_LOAD_DEFAULT) != 0) continue;
    const FT_GlyphSlot g = f.face->glyph;
    if (image) {
      const FT_Bitmap& bm = g->bitmap;
      for (unsigned r = 0; r < bm.rows; ++r)
        for (unsigned c = 0; c < bm.width; ++c)
          blend(*image, x + pen + g->bitmap_left + int(c), y + ascender - g->bitmap_top + int(r),
                bm.buffer[std::ptrdiff_t(r) * bm.pitch + std::ptrdiff_t(c)], rgb);
    }
    pen += int(g->advance.x >> 6);
  }
  return pen;
}

// The built-in 5 x 7 pixel font: seven rows of five bits (bit 4 the leftmost pixel).
struct Glyph {
  char c;
  std::array<std::uint8_t, 7> rows;
};
constexpr Glyph kFont[] = {
    {'A', {14, 17, 17, 31, 17, 17, 17}}, {'B', {30, 17, 17, 30, 17, 17, 30}},
    {'C', {14, 17, 16, 16, 16, 17, 14}}, {'D', {28, 18, 17, 17, 17, 18, 28}},
    {'E', {31, 16, 16, 30, 16, 16, 31}}, {'F', {31, 16, 16, 30, 16, 16, 16}},
    {'G', {14, 17, 16, 23, 17, 17, 15}}, {'H', {17, 17, 17, 31, 17, 17, 17}},
    {'I', {14, 4, 4, 4, 4, 4, 14}},      {'J', {7, 2, 2, 2, 2, 18, 12}},
    {'K', {17, 18, 20, 24, 20, 18, 17}}, {'L', {16, 16, 16, 16, 16, 16, 31}},
    {'M', {17, 27, 21, 21, 17, 17, 17}}, {'N', {17, 17, 25, 21, 19, 17, 17}},
    {'O', {14, 17, 17, 17, 17, 17, 14}}, {'P', {30, 17, 17, 30, 16, 16, 16}},
    {'Q', {14, 17, 17, 17, 21, 18, 13}}, {'R', {30, 17, 17, 30, 20, 18, 17}},
    {'S', {15, 16, 16, 14, 1, 1, 30}},   {'T', {31, 4, 4, 4, 4, 4, 4}},
    {'U', {17, 17, 17, 17, 17, 17, 14}}, {'V', {17, 17, 17, 17, 17, 10, 4}},
    {'W', {17, 17, 17, 21, 21, 21, 10}}, {'X', {17, 17, 10, 4, 10, 17, 17}},
    {'Y', {17, 17, 17, 10, 4, 4, 4}},    {'Z', {31, 1, 2, 4, 8, 16, 31}},
    {'0', {14, 17, 19, 21, 25, 17, 14}}, {'1', {4, 12, 4, 4, 4, 4, 14}},
    {'2', {14, 17, 1, 2, 4, 8, 31}},     {'3', {31, 2, 4, 2, 1, 17, 14}},
    {'4', {2, 6, 10, 18, 31, 2, 2}},     {'5', {31, 16, 30, 1, 1, 17, 14}},
    {'6', {6, 8, 16, 30, 17, 17, 14}},   {'7', {31, 1, 2, 4, 8, 8, 8}},
    {'8', {14, 17, 17, 14, 17, 17, 14}}, {'9', {14, 17, 17, 15, 1, 2, 12}},
    {'.', {0, 0, 0, 0, 0, 12, 12}},      {',', {0, 0, 0, 0, 12, 4, 8}},
    {':', {0, 12, 12, 0, 12, 12, 0}},    {'/', {0, 1, 2, 4, 8, 16, 0}},
    {'|', {4, 4, 4, 4, 4, 4, 4}},        {'=', {0, 0, 31, 0, 31, 0, 0}},
    {'%', {24, 25, 2, 4, 8, 19, 3}},     {'+', {0, 4, 4, 31, 4, 4, 0}},
    {'-', {0, 0, 0, 31, 0, 0, 0}},       {'(', {2, 4, 8, 8, 8, 4, 2}},
    {')', {8, 4, 2, 2, 2, 4, 8}},        {' ', {0, 0, 0, 0, 0, 0, 0}},
};

const Glyph* glyph(char32_t cp) {
  if (cp > 127) return nullptr;
  const char u = char(std::toupper(int(cp)));
  for (const Glyph& g : kFont)
    if (g.c == u) return &g;
  return nullptr;
}

// The built-in font's drawing of `text` (a cell of 6 x 9 dots a character, each dot
// pixel_height / 9 pixels); `image` null: measures only.
int bitmap_label(Image* image, int x, int y, std::string_view text, int px,
                 const std::array<float, 3>& rgb) {
  const int scale = std::max(1, px / 9);
  int pen = 0;
  for (std::size_t i = 0; i < text.size();) {
    const Glyph* g = glyph(next_code_point(text, i));
    if (g && image)
      for (int row = 0; row < 7 * scale; ++row)
        for (int col = 0; col < 5 * scale; ++col)
          if ((g->rows[std::size_t(row / scale)] >> (4 - col / scale)) & 1)
            blend(*image, x + pen + col, y + scale + row, 255, rgb);
    pen += 6 * scale;
  }
  return pen;
}

int label(Image* image, int x, int y, std::string_view text, int px,
          const std::array<float, 3>& rgb) {
  Face& f = the_face();
  return f.face ? freetype_label(f, image, x, y, text, px, rgb)
                : bitmap_label(image, x, y, text, px, rgb);
}

}  // namespace

int draw_label(Image& image, int x, int y, std::string_view text, int pixel_height,
               std::array<float, 3> rgb) {
  return label(&image, x, y, text, pixel_height, rgb);
}

int label_width(std::string_view text, int pixel_height) {
  return label(nullptr, 0, 0, text, pixel_height, {0, 0, 0});
}

int label_line_height(int pixel_height) {
  Face& f = the_face();
  if (!f.face) return std::max(1, pixel_height / 9) * 9;
  std::lock_guard<std::mutex> lock(f.mutex);
  FT_Set_Pixel_Sizes(f.face, 0, FT_UInt(std::max(1, pixel_height)));
  return int(f.face->size->metrics.height >> 6);
}

std::string font_name() {
  const Face& f = the_face();
  return f.face ? f.path : std::string("built-in 5 x 7 pixel font");
}

}  // namespace btfgmm
