#include "circtest/core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "circtest/core/error.hpp"

namespace circtest {

namespace {
std::string errno_text() {
  return std::strerror(errno);
}

void write_all(int fd, std::string_view content, const std::string& path) {
  const char* p = content.data();
  std::size_t left = content.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(path, "cannot write: " + errno_text());
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
}
}  // namespace

void fsync_parent_directory(const std::string& path) {
  std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (dir.empty()) dir = ".";
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return;  // best effort: some filesystems refuse directory fds
  ::fsync(fd);
  ::close(fd);
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path, std::string("cannot open for reading: ") + errno_text());
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw IoError(path, "read failed");
  return ss.str();
}

void write_file_atomic(const std::string& path, std::string_view content,
                       const AtomicWriteOptions& options) {
  namespace fs = std::filesystem;
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw IoError(path, "cannot create temporary file " + tmp + ": " + errno_text());
  try {
    // Keep the permissions of the file being replaced.
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) ::fchmod(fd, st.st_mode & 07777);
    write_all(fd, content, tmp);
    if (::fsync(fd) != 0) throw IoError(tmp, "fsync failed: " + errno_text());
    if (::close(fd) != 0) throw IoError(tmp, "close failed: " + errno_text());
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  std::error_code ec;
  if (options.keep_backup && fs::exists(path, ec)) {
    const std::string backup = path + options.backup_suffix;
    fs::copy_file(path, backup, fs::copy_options::overwrite_existing, ec);
    if (ec) {
      ::unlink(tmp.c_str());
      throw IoError(path, "cannot write backup " + backup + ": " + ec.message());
    }
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = errno_text();
    ::unlink(tmp.c_str());
    throw IoError(path, "cannot rename temporary file into place: " + why);
  }
  fsync_parent_directory(path);
}

}  // namespace circtest
