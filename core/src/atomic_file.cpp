#include "circtest/core/atomic_file.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"

namespace circtest {

namespace {

constexpr std::string_view kTmpMarker = ".circtest-tmp.";

std::string errno_text(int err = errno) {
  return std::strerror(err);
}

std::string directory_of(const std::string& path) {
  std::string dir = std::filesystem::path(path).parent_path().string();
  return dir.empty() ? std::string(".") : dir;
}

std::string name_of(const std::string& path) {
  return std::filesystem::path(path).filename().string();
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

// `.NAME.circtest-tmp.PID` beside the target.
std::string named_temporary(const std::string& target, long pid) {
  const std::string dir = std::filesystem::path(target).parent_path().string();
  // Appended, not `"." + ...`: GCC 12 warns falsely (-Wrestrict) on prepending to a temporary.
  std::string name = std::string(".").append(name_of(target)).append(kTmpMarker);
  name += std::to_string(pid);
  return dir.empty() ? name : dir + "/" + name;
}

// Removes the named temporaries of `target` left by processes that no longer exist (killed
// between creating and renaming one). A live PID's file is left alone: it may be writing.
void sweep_stale_temporaries(const std::string& target) {
  const std::string prefix = std::string(".").append(name_of(target)).append(kTmpMarker);
  const std::string dir = directory_of(target);
  DIR* d = ::opendir(dir.c_str());
  if (!d) return;
  while (const dirent* e = ::readdir(d)) {
    const std::string_view name(e->d_name);
    if (!name.starts_with(prefix)) continue;
    const std::string_view digits = name.substr(prefix.size());
    long pid = 0;
    const auto res = std::from_chars(digits.data(), digits.data() + digits.size(), pid);
    if (res.ec != std::errc{} || res.ptr != digits.data() + digits.size() || pid <= 0) continue;
    if (pid == ::getpid()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    struct stat st {};
    const std::string path = dir + "/" + std::string(name);
    if (::lstat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) ::unlink(path.c_str());
  }
  ::closedir(d);
}

// Gives the unnamed temporary behind `fd` the name `name`; false with errno set on failure.
bool link_unnamed(int fd, const std::string& name) {
  const std::string proc = "/proc/self/fd/" + std::to_string(fd);
  if (::linkat(AT_FDCWD, proc.c_str(), AT_FDCWD, name.c_str(), AT_SYMLINK_FOLLOW) == 0) {
    return true;
  }
  const int err = errno;
  if (err == EEXIST) return false;
  // Without /proc, AT_EMPTY_PATH does the same (it needs CAP_DAC_READ_SEARCH).
  if (::linkat(fd, "", AT_FDCWD, name.c_str(), AT_EMPTY_PATH) == 0) return true;
  errno = err;
  return false;
}

}  // namespace

std::string checked_output_target(const std::string& path) {
  if (path.empty()) throw IoError(path, "empty output path");
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return path;  // a new file; its directory is checked on open
    throw IoError(path, "cannot inspect the output path: " + errno_text());
  }
  if (S_ISREG(st.st_mode)) return path;
  if (!S_ISLNK(st.st_mode)) {
    throw IoError(path, std::string("is ") + file_kind_name(st.st_mode) +
                            ", not a regular file; refusing to replace it");
  }
  // A symbolic link: the file it names is the output, and the link stays.
  char* resolved = ::realpath(path.c_str(), nullptr);
  if (!resolved) {
    throw IoError(path, "is a symbolic link to a missing file (" + errno_text() +
                            "); refusing to write through it");
  }
  std::string target(resolved);
  std::free(resolved);
  if (::stat(target.c_str(), &st) != 0) {
    throw IoError(path, "cannot inspect the link target " + target + ": " + errno_text());
  }
  if (!S_ISREG(st.st_mode)) {
    throw IoError(path, "is a symbolic link to " + target + ", which is " +
                            file_kind_name(st.st_mode) +
                            ", not a regular file; refusing to replace it");
  }
  return target;
}

AtomicOutput::AtomicOutput(const std::string& path) : path_(path) {
  target_ = checked_output_target(path);
  struct stat st {};
  target_exists_ = ::stat(target_.c_str(), &st) == 0;
  sweep_stale_temporaries(target_);
  const std::string dir = directory_of(target_);
  fd_ = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    if (errno == ENOENT || errno == ENOTDIR || errno == EACCES || errno == EROFS) {
      throw IoError(path_, "cannot create a file in " + dir + ": " + errno_text());
    }
    // No O_TMPFILE on this filesystem (EOPNOTSUPP, EISDIR on old kernels): a named
    // temporary, swept by the next write if this process dies before the rename.
    named_tmp_ = named_temporary(target_, ::getpid());
    fd_ = ::open(named_tmp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd_ < 0) {
      throw IoError(path_, "cannot create temporary file " + named_tmp_ + ": " + errno_text());
    }
  }
  // Keep the permissions of the file being replaced.
  if (target_exists_) ::fchmod(fd_, st.st_mode & 07777);
}

AtomicOutput::~AtomicOutput() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !named_tmp_.empty()) ::unlink(named_tmp_.c_str());
}

void AtomicOutput::write(std::string_view bytes) {
  if (fd_ < 0 || committed_) throw IoError(path_, "write after commit");
  write_all(fd_, bytes, path_);
}

void AtomicOutput::commit(const AtomicWriteOptions& options) {
  if (committed_) return;
  if (::fsync(fd_) != 0) throw IoError(path_, "fsync failed: " + errno_text());
  if (options.keep_backup && target_exists_) {
    // Through the same checks: a backup name that is a FIFO or a device is refused too.
    write_file_atomic(target_ + options.backup_suffix, read_file(target_));
  }
  if (named_tmp_.empty()) {
    // A new file gets its name in one step; an existing one through a temporary name and a
    // rename (link cannot replace). Only between those two calls does a name exist.
    bool placed = false;
    if (!target_exists_) {
      placed = link_unnamed(fd_, target_);
      if (!placed && errno != EEXIST) {
        throw IoError(path_, "cannot link the new file into place: " + errno_text());
      }
    }
    if (!placed) {
      named_tmp_ = named_temporary(target_, ::getpid());
      ::unlink(named_tmp_.c_str());
      if (!link_unnamed(fd_, named_tmp_)) {
        const std::string why = errno_text();
        named_tmp_.clear();
        throw IoError(path_, "cannot name the temporary file: " + why);
      }
    }
  }
  if (!named_tmp_.empty()) {
    if (::rename(named_tmp_.c_str(), target_.c_str()) != 0) {
      const std::string why = errno_text();
      throw IoError(path_, "cannot rename temporary file into place: " + why);
    }
    named_tmp_.clear();
  }
  committed_ = true;
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) throw IoError(path_, "close failed: " + errno_text());
  fsync_parent_directory(target_);
}

void write_file_atomic(const std::string& path, std::string_view content,
                       const AtomicWriteOptions& options) {
  AtomicOutput out(path);
  out.write(content);
  out.commit(options);
}

void fsync_parent_directory(const std::string& path) {
  const std::string dir = directory_of(path);
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;  // best effort: some filesystems refuse directory fds
  ::fsync(fd);
  ::close(fd);
}

std::string read_file(const std::string& path) {
  return read_input_bytes(path);
}

}  // namespace circtest
