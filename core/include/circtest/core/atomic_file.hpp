#pragma once
// Never leave a file half-written: write a temporary beside it, fsync, rename over it,
// fsync the directory. Configuration files keep a backup of the previous version.
#include <string>
#include <string_view>

namespace circtest {

struct AtomicWriteOptions {
  bool keep_backup = false;  // copy the old file to <path><backup_suffix> first
  std::string backup_suffix = ".bak";
};

// Throws IoError naming the path on any failure; the original file is then untouched.
void write_file_atomic(const std::string& path, std::string_view content,
                       const AtomicWriteOptions& options = {});

// fsync a file's directory so a rename survives a crash.
void fsync_parent_directory(const std::string& path);

// Reads a whole file; throws IoError.
std::string read_file(const std::string& path);

}  // namespace circtest
