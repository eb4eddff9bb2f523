#include "btfgmm/io/files.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"

namespace btfgmm {

void write_file_atomically(const std::filesystem::path& path, std::span<const std::uint8_t> bytes,
                           const char* what) {
  static std::atomic<unsigned> counter{0};
  const std::filesystem::path tmp =
      path.string() + fmt::format(".tmp-{}-{}", ::getpid(), counter++);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int err = errno;
    const auto dir = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
    std::error_code ec;
    const std::string hint = std::filesystem::is_directory(dir, ec)
                                 ? "check that the folder is writable"
                                 : "the folder does not exist; create it first";
    throw Error(Error::Kind::kIo, fmt::format("cannot write {} '{}': {} ({})", what, path.string(),
                                              std::strerror(err), hint));
  }
  std::size_t done = 0;
  int err = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      err = errno;
      break;
    }
    done += std::size_t(n);
  }
  if (!err && ::fsync(fd) != 0) err = errno;
  if (::close(fd) != 0 && !err) err = errno;
  if (!err && std::rename(tmp.c_str(), path.c_str()) != 0) err = errno;
  if (err) {
    ::unlink(tmp.c_str());
    const char* fix =
        err == ENOSPC || err == EDQUOT ? "; free space on that disk or write elsewhere"
        : err == EROFS || err == EACCES || err == EPERM ? "; write to a folder you can write to"
                                                        : "";
    throw Error(Error::Kind::kIo,
                fmt::format("cannot write {} '{}': {}; nothing was written under that name{}", what,
                            path.string(), std::strerror(err), fix));
  }
}

std::vector<std::uint8_t> read_whole_file(const std::filesystem::path& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  if (!in || std::filesystem::is_directory(path, ec))
    throw Error(
        Error::Kind::kIo,
        fmt::format("cannot read {} '{}': {}", what, path.string(),
                    std::filesystem::exists(path, ec) ? "not a readable file" : "no such file"));
  // Its size against the memory before reading it whole.
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec)
    limits::check_memory(
        double(size), fmt::format("reading {} '{}' ({} bytes)", what, path.string(), size),
        "it is not a file btfgmm wrote; give the right file", Error::Kind::kFormat);
  return std::vector<std::uint8_t>((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
}

}  // namespace btfgmm
