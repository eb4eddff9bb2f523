// Whole files in and out: every file btfgmm writes (models, checkpoints, images, reports) is
// written atomically through write_file_atomically; every file it reads whole is read by
// read_whole_file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace btfgmm {

// Writes `bytes` to a temporary file beside `path`, fsyncs it and renames it onto `path`: an
// interrupted or failed write never leaves a partial file under that name. Throws Error(kIo)
// naming `what` and the path.
void write_file_atomically(const std::filesystem::path& path, std::span<const std::uint8_t> bytes,
                           const char* what);
// The whole file, its size first checked against the memory; Error(kIo) naming `what` and the
// path if it cannot be read.
std::vector<std::uint8_t> read_whole_file(const std::filesystem::path& path, const char* what);

}  // namespace btfgmm
