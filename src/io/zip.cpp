// Bonn material zips, read in place with libzip.
#include "io/zip.hpp"

#include <fmt/format.h>

#include <system_error>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"

namespace btfgmm::detail {

namespace fs = std::filesystem;

Zip open_zip(const fs::path& path) {
  int code = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_RDONLY, &code);
  if (!z) {
    zip_error_t err;
    zip_error_init_with_code(&err, code);
    const std::string reason = zip_error_strerror(&err);
    zip_error_fini(&err);
    throw Error(Error::Kind::kFormat,
                fmt::format("{} is not a readable zip archive (libzip: {}); give a Bonn "
                            "material .zip as downloaded, or a folder of images",
                            path.string(), reason));
  }
  return Zip(z);
}

std::string entry_display(const fs::path& zip, const std::string& entry) {
  return fmt::format("{}:{}", zip.string(), entry);
}

std::vector<std::pair<std::string, std::uint64_t>> list_zip_files(const fs::path& path) {
  std::vector<std::pair<std::string, std::uint64_t>> files;
  Zip z = open_zip(path);
  const zip_int64_t n = zip_get_num_entries(z.get(), 0);
  // Every entry has a central directory record of at least 46 bytes.
  std::error_code size_ec;
  const std::uintmax_t zip_bytes = fs::file_size(path, size_ec);
  if (n < 0 || (!size_ec && std::uintmax_t(n) > zip_bytes / 46))
    throw Error(Error::Kind::kFormat,
                fmt::format("{} claims {} entries, more than its {} bytes can hold; the "
                            "archive is corrupt, download it again",
                            path.string(), n, zip_bytes));
  for (zip_int64_t i = 0; i < n; ++i) {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat_index(z.get(), zip_uint64_t(i), 0, &st) != 0 || !(st.valid & ZIP_STAT_NAME))
      throw Error(Error::Kind::kFormat,
                  fmt::format("{}: cannot read entry {} (libzip: {}); the archive is "
                              "corrupt, download it again",
                              path.string(), i, zip_strerror(z.get())));
    const std::string name = st.name;
    if (!name.empty() && name.back() == '/') continue;  // a folder
    files.emplace_back(name, (st.valid & ZIP_STAT_COMP_SIZE) ? st.comp_size : 0);
  }
  return files;
}

std::vector<std::uint8_t> read_zip_entry(zip_t* z, const fs::path& zip, const std::string& entry) {
  const zip_int64_t index = zip_name_locate(z, entry.c_str(), 0);
  zip_stat_t st;
  zip_stat_init(&st);
  if (index < 0 || zip_stat_index(z, zip_uint64_t(index), 0, &st) != 0)
    throw Error(Error::Kind::kIo, fmt::format("cannot read {}: entry not found ({})",
                                              entry_display(zip, entry), zip_strerror(z)));
  if (st.size > (zip_uint64_t(1) << 31))
    throw Error(Error::Kind::kFormat,
                fmt::format("{} is {} bytes uncompressed, too large for a BTF image",
                            entry_display(zip, entry), st.size));
  // The entry's stored bytes must lie in the archive: its directory may claim any size.
  std::error_code size_ec;
  const std::uintmax_t zip_bytes = fs::file_size(zip, size_ec);
  if ((st.valid & ZIP_STAT_COMP_SIZE) && !size_ec && st.comp_size > zip_bytes)
    throw Error(Error::Kind::kFormat,
                fmt::format("{} claims {} stored bytes, more than the archive's {} bytes; the "
                            "archive is corrupt, download it again",
                            entry_display(zip, entry), st.comp_size, zip_bytes));
  // What the entry's stored bytes can hold: deflate expands at most 1032 times, a stored
  // entry not at all. (Other methods are bounded by the check above and the memory's.)
  if ((st.valid & ZIP_STAT_COMP_SIZE) && (st.valid & ZIP_STAT_COMP_METHOD) &&
      ((st.comp_method == ZIP_CM_STORE && st.size > st.comp_size) ||
       (st.comp_method == ZIP_CM_DEFLATE &&
        double(st.size) > limits::kDeflateMaxRatio * double(st.comp_size) + 1032.0)))
    throw Error(Error::Kind::kFormat,
                fmt::format("{} claims {} bytes uncompressed from {} stored bytes, more than "
                            "they can hold; the archive is corrupt, download it again",
                            entry_display(zip, entry), st.size, st.comp_size));
  limits::check_memory(
      double(st.size), fmt::format("reading {} ({} bytes)", entry_display(zip, entry), st.size),
      "the archive is corrupt, or the entry too large for this machine", Error::Kind::kFormat);
  zip_file_t* f = zip_fopen_index(z, zip_uint64_t(index), 0);
  if (!f)
    throw Error(Error::Kind::kIo, fmt::format("cannot read {}: libzip: {}",
                                              entry_display(zip, entry), zip_strerror(z)));
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(st.size));
  const zip_int64_t n = zip_fread(f, bytes.data(), bytes.size());
  std::string reason = n < 0 ? zip_error_strerror(zip_file_get_error(f)) : "";
  zip_fclose(f);
  if (n < 0 || zip_uint64_t(n) != st.size)
    throw Error(Error::Kind::kFormat,
                fmt::format("cannot read {}: {}; the archive is corrupt or truncated, "
                            "download it again",
                            entry_display(zip, entry),
                            n < 0 ? "libzip: " + reason : "the entry ended early"));
  return bytes;
}

}  // namespace btfgmm::detail
