// Whole files in and out: every file btfgmm writes (models, checkpoints, images, reports) is
// written atomically through write_file_atomically; every file it reads whole is read by
// read_whole_file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "btfgmm/core/error.hpp"

namespace btfgmm {

// Writes `bytes` to a temporary file beside `path`, fsyncs it and renames it onto `path`: an
// interrupted or failed write never leaves a partial file under that name. Throws Error(kIo)
// naming `what` and the path (and the folder, when it does not exist).
void write_file_atomically(const std::filesystem::path& path, std::span<const std::uint8_t> bytes,
                           const char* what);
// The whole file, its size first checked against the memory. Error(kIo) naming `what`, the
// path and the system's reason if it cannot be read; a file larger than the memory is refused
// with Error(`too_large_kind`) saying `too_large_fix`.
std::vector<std::uint8_t> read_whole_file(
    const std::filesystem::path& path, const char* what,
    const char* too_large_fix = "it is not a file btfgmm wrote; give the right file",
    Error::Kind too_large_kind = Error::Kind::kFormat);

// The first `max_bytes` of a regular file (fewer when it is shorter), to tell what it holds
// (io/file_kind.hpp) before reading it whole; empty when it cannot be read (the reader that
// follows names the reason).
std::vector<std::uint8_t> read_file_start(const std::filesystem::path& path, std::size_t max_bytes);

}  // namespace btfgmm
