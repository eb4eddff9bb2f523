// The names of BTF images: the angles of the light and view an image file name carries, and
// the UTIA name of an image. Data sets on disk are read and written by btfgmm/io/dataset.hpp.
//
// Names understood (angles in degrees, whole or with a fraction such as tl023.5):
//   UTIA:          tl000_pl000_tv000_pv000.png   (also .jpg, .exr)
//   Bonn UBO2003:  00008 tl000 pl000 tv030 pv030.jpg  (or with '_' separators)
#pragma once

#include <optional>
#include <string>

#include "btfgmm/core/directions.hpp"

namespace btfgmm {

// The angles a file name carries.
struct ParsedName {
  Direction light, view;
  std::optional<long> index;  // the Bonn image index, when present
};
// Parse the file name part (no folders) of an image name. Throws Error(kFormat) naming the
// file and the expected pattern.
ParsedName parse_image_name(const std::string& file_name);
// The UTIA name of an image: tl000_pl000_tv000_pv000 (angles with one decimal if fractional).
std::string utia_image_stem(const Direction& light, const Direction& view);

}  // namespace btfgmm
