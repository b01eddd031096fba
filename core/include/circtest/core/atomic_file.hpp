#pragma once
// Never leave a file half-written: write an unnamed temporary beside it, fsync, put it in
// place with one rename, fsync the directory. Configuration files keep a backup of the
// previous version.
//
// Output paths (docs/development.md, "Output files"):
// - a path that exists and is not a regular file (device, FIFO, socket, directory) is
//   refused with IoError (exit 3), never replaced;
// - a symbolic link is followed: its regular target is replaced in the target's directory
//   and the link stays; a link to a missing file or to a non-regular file is refused;
// - the temporary is an O_TMPFILE inode with no name until commit, so a process killed
//   mid-write leaves nothing. Where the filesystem has no O_TMPFILE a named temporary
//   `.NAME.circtest-tmp.PID` is used, and such names of processes no longer alive are
//   swept by the next write to NAME.
#include <string>
#include <string_view>

namespace circtest {

struct AtomicWriteOptions {
  bool keep_backup = false;  // copy the old file to <path><backup_suffix> first
  std::string backup_suffix = ".bak";
};

// An output file that appears at its path only on commit(), complete. Destroyed without
// commit(), nothing appears and no temporary stays behind.
class AtomicOutput {
 public:
  // Checks the path (see above) and opens the temporary; throws IoError.
  explicit AtomicOutput(const std::string& path);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  void write(std::string_view bytes);
  // fsync, optional backup of the old file, rename into place, fsync the directory.
  void commit(const AtomicWriteOptions& options = {});

  const std::string& path() const noexcept { return path_; }
  // The file actually replaced: `path` with symbolic links resolved.
  const std::string& target() const noexcept { return target_; }

 private:
  std::string path_;
  std::string target_;
  std::string named_tmp_;  // empty while the temporary is an unnamed O_TMPFILE inode
  bool target_exists_ = false;
  bool committed_ = false;
  int fd_ = -1;
};

// Throws IoError naming the path on any failure; the original file is then untouched.
void write_file_atomic(const std::string& path, std::string_view content,
                       const AtomicWriteOptions& options = {});

// The path an output to `path` would replace (symbolic links resolved); throws IoError when
// that is not a regular file or a new name in an existing directory.
std::string checked_output_target(const std::string& path);

// fsync a file's directory so a rename survives a crash.
void fsync_parent_directory(const std::string& path);

// Reads a whole file: read_input_bytes with its limit (kMaxWholeInputBytes); throws IoError
// for a device, a directory or a file over the limit.
std::string read_file(const std::string& path);

}  // namespace circtest
