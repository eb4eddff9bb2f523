// Bonn University's binary BTF files (the UBO2014 and ATRIUM databases): one .btf file per
// material holding a matrix factorisation of its images. Two kinds are read:
//
//   !DFMF08FCR  decorrelated full matrix factorisation: the colour decorrelated (a colour
//               model, mean and transformation matrix), then per channel an SVD (S, U, S x V)
//   !FMF12FCER  full matrix factorisation of the three channels together, with the extended
//               header (dynamic-range reduction, height map)
//
// docs/FORMAT.md lays out every field and names the convention each decoding step follows.
// Opening a file reads its header and its angular factors (U: one row per (light, view) pair,
// small); the spatial factors (S x V: one row per pixel, the large part) are read per tile, so
// decoding a tile needs memory proportional to the tile.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"

namespace btfgmm {

enum class UboKind { kDfmf, kFmf };

// Everything a .btf file says about itself (docs/FORMAT.md names each field).
struct UboBtfHeader {
  UboKind kind = UboKind::kDfmf;
  std::string signature;                                      // "!DFMF08FCR" or "!FMF12FCER"
  std::uint32_t version = 0;                                  // the common header's version, 1..4
  std::string measurement_setup, image_sensor, light_source;  // 80-byte fields, to the first NUL
  float ppmm = 0;                                             // pixels per millimetre
  std::array<float, 3> rgb_scale{1, 1, 1};  // stored; the Bonn readers do not apply it
  bool cosine_in_data = false;  // the data holds the light's cos(theta): decoding divides it out
  std::string xml;              // the measurement's XML description
  std::vector<std::string> channel_names;
  DirectionSet lights, views;  // as the file lists them: the first view's lights, the views
  int width = 0, height = 0;
  std::uint32_t rotations = 0;  // local frames stored after the size (3x3 each), unused here
  // DFMF: the colour model (btflib's numbering), its mean and matrix (row-major)
  std::int32_t colour_model = 0;
  std::array<float, 3> colour_mean{};
  std::array<float, 9> colour_matrix{};
  // FMF: the extended header's version, the dynamic-range reduction (0: none, else the data
  // holds log(value + 1e-5)), the height map's size (skipped)
  std::uint32_t fmf_header_version = 0;
  std::uint32_t dynamic_range_reduction = 0;
  std::uint32_t height_map_width = 0, height_map_height = 0;
  std::uint32_t max_components = 0;       // the header's count (DFMF: the largest channel's)
  std::vector<std::uint32_t> components;  // per matrix: DFMF one per channel, FMF one
  std::uint8_t scalar_bytes = 2;          // 2 (half floats), 4 or 8
  std::uint64_t file_bytes = 0;
};

// The name of a colour model as btflib numbers it: 0 "RGB", 11 "Ylog U/Y V/Y", ...
std::string ubo_colour_model_name(std::int32_t model);

// Whether a path is a regular file named .btf or starting with a Bonn BTF signature.
bool is_ubo_btf_file(const std::filesystem::path& path);
// Whether bytes (the first 16 or more of a file) start with a Bonn BTF signature ('!' and the
// name of a Bonn format: DFMF, FMF, BDI, PVF), read or not.
bool has_ubo_signature(std::span<const std::uint8_t> head);

// The spatial factors of one tile: per matrix, the rows of its pixels (components x pixels,
// component-major, as floats).
struct UboTileFactors {
  Tile tile;
  std::vector<std::vector<float>> sxv;
};

class UboBtf {
 public:
  // Read the header and the angular factors of a file. Throws Error naming the file, the
  // field and the fix for a wrong signature, a truncated section, sizes that disagree, NaN or
  // infinite factors, light counts that differ between views.
  static UboBtf open(const std::filesystem::path& path);
  // The same from bytes in memory; `name` is used in messages.
  static UboBtf from_bytes(std::vector<std::uint8_t> bytes, const std::string& name);

  const UboBtfHeader& header() const { return header_; }
  const std::string& name() const { return name_; }

  // The memory load_tile needs for a tile, in bytes.
  double tile_bytes(const Tile& tile) const;
  // Read the spatial factors of a tile (inside the image; checked). Error for NaN or infinite
  // values among them.
  UboTileFactors load_tile(const Tile& tile) const;
  // Decode the image of one (light, view) pair over the tile into rgb (width * height * 3
  // floats, row-major, RGB): the channels' sums of U x (S x V), then the colour model's
  // inverse, the dynamic-range transform, the cosine factor (docs/FORMAT.md).
  void decode(const UboTileFactors& factors, std::size_t light, std::size_t view,
              std::span<float> rgb) const;

  // Where a section lies in the file (for the decoder and the tests).
  struct Matrix {
    std::uint32_t components = 0, rows = 0, columns = 0;
    std::uint64_t sxv_offset = 0;  // byte offset of S x V in the file
    std::vector<float> u;          // rows x components, row-major
  };
  const std::vector<Matrix>& matrices() const { return matrices_; }

  class Source;  // the bytes: a file read in place or bytes in memory

 private:
  UboBtfHeader header_;
  std::string name_;
  std::shared_ptr<const Source> source_;
  std::vector<Matrix> matrices_;
};

}  // namespace btfgmm
