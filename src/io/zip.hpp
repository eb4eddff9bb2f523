// Bonn material zips, read in place with libzip: the entries listed, one entry inflated into
// memory with its claimed size checked first.
#pragma once

#include <zip.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace btfgmm::detail {

struct ZipCloser {
  void operator()(zip_t* z) const { zip_discard(z); }
};
using Zip = std::unique_ptr<zip_t, ZipCloser>;

// The archive opened for reading; Error(kFormat) if it is not a readable zip.
Zip open_zip(const std::filesystem::path& path);
// How messages name an entry: archive.zip:entry.
std::string entry_display(const std::filesystem::path& zip, const std::string& entry);
// The files of the archive (folders left out), each with its stored (compressed) size, in
// the archive's order.
std::vector<std::pair<std::string, std::uint64_t>> list_zip_files(
    const std::filesystem::path& path);
// One entry, inflated.
std::vector<std::uint8_t> read_zip_entry(zip_t* z, const std::filesystem::path& zip,
                                         const std::string& entry);

}  // namespace btfgmm::detail
