// Writing a BTF in the nested UTIA layout. Data sets are read by btfgmm/io/dataset.hpp.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/image.hpp"

namespace btfgmm {

// Write a BTF in the nested UTIA layout under `folder` (created if needed):
// tv000_pv000/tl000_pl000_tv000_pv000.png for 8-bit data, .exr for HDR (or as forced by
// `format`). Each file is written under a temporary name and renamed. `progress`, if given, is
// called with the fraction of the images written (1 last), from one thread at a time; it
// must not throw.
void write_utia(const Btf& btf, const std::filesystem::path& folder,
                std::optional<ImageFormat> format = std::nullopt,
                const std::function<void(double fraction)>& progress = {});

}  // namespace btfgmm
