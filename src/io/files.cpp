#include "btfgmm/io/files.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "btfgmm/core/limits.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

// Closes a file descriptor when it goes out of scope.
class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }
  // Closes now; the error of close(2), 0 if none.
  int close() {
    const int r = ::close(fd_);
    fd_ = -1;
    return r == 0 ? 0 : errno;
  }

 private:
  int fd_;
};

// The temporary file cannot be created: say whether the folder is missing or not writable.
[[noreturn]] void refuse_to_create(const fs::path& path, const char* what, int err) {
  const fs::path dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  std::error_code ec;
  const std::string hint =
      fs::is_directory(dir, ec)
          ? "check that the folder is writable"
          : fmt::format("the folder '{}' does not exist; create it first", dir.string());
  throw Error(Error::Kind::kIo, fmt::format("cannot write {} '{}': {} ({})", what, path.string(),
                                            std::strerror(err), hint));
}

// All of `bytes` to `fd`; the error of write(2), 0 if none.
int write_all(int fd, std::span<const std::uint8_t> bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    done += std::size_t(n);
  }
  return 0;
}

[[noreturn]] void cannot_read(const fs::path& path, const char* what, int err) {
  throw Error(Error::Kind::kIo,
              fmt::format("cannot read {} '{}': {}", what, path.string(), std::strerror(err)));
}

}  // namespace

void write_file_atomically(const fs::path& path, std::span<const std::uint8_t> bytes,
                           const char* what) {
  static std::atomic<unsigned> counter{0};
  const fs::path tmp = path.string() + fmt::format(".tmp-{}-{}", ::getpid(), counter++);
  Fd fd(::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
  if (fd.get() < 0) refuse_to_create(path, what, errno);
  int err = write_all(fd.get(), bytes);
  if (!err && ::fsync(fd.get()) != 0) err = errno;
  if (const int close_err = fd.close(); !err) err = close_err;
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

std::vector<std::uint8_t> read_whole_file(const fs::path& path, const char* what,
                                          const char* too_large_fix, Error::Kind too_large_kind) {
  Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (fd.get() < 0) cannot_read(path, what, errno);
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0) cannot_read(path, what, errno);
  if (S_ISDIR(st.st_mode)) cannot_read(path, what, EISDIR);
  // Its size against the memory before reading it whole.
  const std::uint64_t size = S_ISREG(st.st_mode) ? std::uint64_t(st.st_size) : 0;
  limits::check_memory(double(size),
                       fmt::format("reading {} '{}' ({} bytes)", what, path.string(), size),
                       too_large_fix, too_large_kind);
  // The stated size first; a file that grows meanwhile (or has no size) is read to its end.
  std::vector<std::uint8_t> bytes(std::max<std::size_t>(std::size_t(size) + 1, 1 << 16));
  std::size_t used = 0;
  for (;;) {
    if (used == bytes.size()) bytes.resize(bytes.size() * 2);
    const ssize_t n = ::read(fd.get(), bytes.data() + used, bytes.size() - used);
    if (n < 0) {
      if (errno == EINTR) continue;
      cannot_read(path, what, errno);
    }
    if (n == 0) break;
    used += std::size_t(n);
  }
  bytes.resize(used);
  return bytes;
}

std::vector<std::uint8_t> read_file_start(const fs::path& path, std::size_t max_bytes) {
  Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  struct stat st {};
  if (fd.get() < 0 || ::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode)) return {};
  std::vector<std::uint8_t> bytes(max_bytes);
  std::size_t used = 0;
  while (used < bytes.size()) {
    const ssize_t n = ::read(fd.get(), bytes.data() + used, bytes.size() - used);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    used += std::size_t(n);
  }
  bytes.resize(used);
  return bytes;
}

}  // namespace btfgmm
