#include "circtest/core/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "circtest/core/error.hpp"
#include "input_lines.hpp"

namespace circtest {

namespace {

bool same_file(const struct stat& a, const struct stat& b) {
  return a.st_dev == b.st_dev && a.st_ino == b.st_ino && a.st_rdev == b.st_rdev;
}

}  // namespace

const char* file_kind_name(unsigned int st_mode) noexcept {
  const auto mode = static_cast<mode_t>(st_mode);
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISREG(mode)) return "a regular file";
  return "not a regular file";
}

namespace {

[[noreturn]] void refuse_kind(const std::string& path, mode_t mode) {
  throw IoError(path, std::string("is ") + file_kind_name(mode) + ", not a regular file");
}

}  // namespace

InputFile::InputFile(const std::string& path) : path_(path) {
  struct stat st {};
  if (path == "-") {
    fd_ = STDIN_FILENO;  // whatever the shell connected: a file, a pipe, a terminal
    if (::fstat(fd_, &st) != 0)
      throw IoError(path, std::string("cannot stat: ") + std::strerror(errno));
  } else {
    // Only a regular file is opened. A FIFO is refused before it is opened (opening it for
    // reading waits for a writer that may never come, and reading it waits for data), and a
    // device, folder or socket is no input either; standard input by another name
    // (/dev/stdin) is read as "-" is.
    struct stat pre {};
    if (::stat(path.c_str(), &pre) != 0) {
      throw IoError(path, std::string("cannot open: ") + std::strerror(errno));
    }
    struct stat in {};
    if (!S_ISREG(pre.st_mode) && ::fstat(STDIN_FILENO, &in) == 0 && same_file(pre, in)) {
      fd_ = STDIN_FILENO;
      st = in;
    } else {
      if (!S_ISREG(pre.st_mode)) refuse_kind(path, pre.st_mode);
      // O_NONBLOCK: should the path have become a FIFO or a device since the stat, the open
      // does not wait either; the fstat below refuses it. The flag is cleared again after.
      fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
      if (fd_ < 0) throw IoError(path, std::string("cannot open: ") + std::strerror(errno));
      owned_ = true;
      if (::fstat(fd_, &st) != 0) {
        const int err = errno;
        ::close(fd_);
        throw IoError(path, std::string("cannot stat: ") + std::strerror(err));
      }
      if (!S_ISREG(st.st_mode)) {
        ::close(fd_);
        refuse_kind(path, st.st_mode);
      }
      const int flags = ::fcntl(fd_, F_GETFL);
      if (flags >= 0) ::fcntl(fd_, F_SETFL, flags & ~O_NONBLOCK);
    }
  }
  regular_ = S_ISREG(st.st_mode);
  size_ = regular_ ? static_cast<std::uint64_t>(st.st_size) : 0;
}

InputFile::~InputFile() {
  if (owned_) ::close(fd_);
}

namespace {

std::string over_limit(std::size_t max_bytes) {
  const std::size_t mib = max_bytes >> 20;
  if (mib > 0 && (mib << 20) == max_bytes) {
    return "larger than the limit of " + std::to_string(mib) + " MiB for this input";
  }
  return "larger than the limit of " + std::to_string(max_bytes) + " bytes for this input";
}

// Reads IN to its end in blocks, handing each to CONSUME; refuses more than MAX_BYTES.
template <class Consume>
void read_blocks(const InputFile& in, std::size_t max_bytes, Consume&& consume) {
  char block[1 << 16];
  std::size_t total = 0;
  while (true) {
    const ssize_t n = ::read(in.fd(), block, sizeof block);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(in.path(), std::string("read failed: ") + std::strerror(errno));
    }
    if (n == 0) break;
    total += static_cast<std::size_t>(n);
    if (total > max_bytes) throw IoError(in.path(), over_limit(max_bytes));
    consume(std::string_view(block, static_cast<std::size_t>(n)));
  }
}

std::string read_whole(const std::string& path, std::size_t max_bytes, bool text) {
  InputFile in(path);
  if (in.regular() && in.size() > max_bytes) throw IoError(path, over_limit(max_bytes));
  std::string bytes;
  if (in.regular()) bytes.reserve(static_cast<std::size_t>(in.size()));
  LineLengthGuard guard(path);
  read_blocks(in, max_bytes, [&](std::string_view block) {
    if (text) guard.feed(block);
    bytes.append(block);
  });
  return bytes;
}

}  // namespace

std::string read_input_bytes(const std::string& path, std::size_t max_bytes) {
  return read_whole(path, max_bytes, false);
}

std::string read_input_text(const std::string& path, std::size_t max_bytes) {
  return read_whole(path, max_bytes, true);
}

void for_each_input_block(const std::string& path,
                          const std::function<void(std::string_view block)>& consume) {
  InputFile in(path);
  read_blocks(in, static_cast<std::size_t>(-1), consume);
}

}  // namespace circtest
