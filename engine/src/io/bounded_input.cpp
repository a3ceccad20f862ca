// Untrusted files read within bounds: regular files, a size limit, nesting measured without recursion.
#include "io/bounded_input.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "haustra/error.hpp"

namespace haustra::io {
namespace {

const char* kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string size_of(std::uintmax_t bytes) {
  return bytes >= (1 << 20) ? fmt::format("{} MiB", bytes >> 20) : fmt::format("{} bytes", bytes);
}

[[noreturn]] void refuse_kind(const std::filesystem::path& file, std::string_view what, mode_t mode) {
  throw Error(ErrorCode::io, fmt::format("{}: {}, not a {} (the engine reads regular files only)", file.string(),
                                         kind_of(mode), what));
}

[[noreturn]] void refuse_size(const std::filesystem::path& file, std::string_view what, std::uintmax_t bytes,
                              std::uintmax_t max_bytes) {
  throw Error(ErrorCode::invalid_argument,
              fmt::format("{}: {} bytes, more than the {} a {} may have: is it the right file?", file.string(), bytes,
                          size_of(max_bytes), what));
}

// Closes a descriptor on every way out.
struct Descriptor {
  int fd;
  ~Descriptor() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

std::uintmax_t regular_file_size(const std::filesystem::path& file, std::string_view what, std::uintmax_t max_bytes) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0)
    throw Error(ErrorCode::io, fmt::format("{}: cannot open the {} ({})", file.string(), what, std::strerror(errno)));
  if (!S_ISREG(st.st_mode)) refuse_kind(file, what, st.st_mode);
  const auto bytes = static_cast<std::uintmax_t>(st.st_size);
  if (bytes > max_bytes) refuse_size(file, what, bytes, max_bytes);
  return bytes;
}

std::string read_bounded_file(const std::filesystem::path& file, std::string_view what, std::uintmax_t max_bytes) {
  (void)regular_file_size(file, what, max_bytes);
  // O_NONBLOCK: should the path have become a FIFO since, opening it does not wait for a writer.
  const Descriptor d{::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
  if (d.fd < 0)
    throw Error(ErrorCode::io, fmt::format("{}: cannot open the {} ({})", file.string(), what, std::strerror(errno)));
  struct stat st {};
  if (::fstat(d.fd, &st) != 0 || !S_ISREG(st.st_mode)) refuse_kind(file, what, st.st_mode);
  std::string text;
  std::vector<char> block(1 << 16);
  for (;;) {
    const ssize_t n = ::read(d.fd, block.data(), block.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0)
      throw Error(ErrorCode::io,
                  fmt::format("{}: reading the {} failed ({})", file.string(), what, std::strerror(errno)));
    if (n == 0) break;
    text.append(block.data(), static_cast<std::size_t>(n));
    if (text.size() > max_bytes) refuse_size(file, what, text.size(), max_bytes);  // it grew while read
  }
  return text;
}

}  // namespace haustra::io
