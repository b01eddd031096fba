#pragma once
// The configuration directory circcomp works in. It is resolved once (realpath of the INI's
// folder); every file circcomp writes, restores, renames or removes is then a regular file
// named relative to it and reached from it without following a symbolic link: a name with
// "..", an absolute name, a link anywhere on the way, or a FIFO, device or directory where a
// file is expected is refused with UnsafePathError (exit 12) before anything is touched.
// Reading a file outside (an #INCLUDE, a COMP_FILE named elsewhere) stays allowed: only
// changing one is refused.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "circtest/core/atomic_file.hpp"

namespace circtest::compensation {

// The largest configuration file (INI, include, HAL file, table, original, manifest) circcomp
// reads whole.
inline constexpr std::size_t kMaxConfigFileBytes = std::size_t{16} << 20;

class ConfigDir {
 public:
  // The folder of INI_PATH; throws IoError when it cannot be resolved.
  explicit ConfigDir(const std::string& ini_path);

  const std::string& root() const noexcept { return root_; }
  // ROOT/NAME, for messages and for the writes.
  std::string path(std::string_view name) const;

  // The name inside the directory of PATH (relative to the current folder or absolute, with
  // its folders' links resolved as the kernel resolves them); nullopt when PATH lies outside.
  std::optional<std::string> name_of(const std::string& path) const;
  // Throws UnsafePathError (naming SOURCE, e.g. "manifest line 3") unless NAME is a plain
  // relative name: not empty, not absolute, no "." or ".." component, no control character.
  static void check_name(std::string_view name, const std::string& source);

  // Whether NAME exists as a regular file (false: absent). Throws UnsafePathError when a
  // folder on the way is a link or not a folder, or NAME is a link, FIFO, device or folder.
  bool regular_or_absent(const std::string& name) const;
  // The content of the regular file NAME (bounded by kMaxConfigFileBytes); nullopt when absent.
  std::optional<std::string> read(const std::string& name) const;
  // An atomic replacement of NAME (a regular file or absent), checked as above just before.
  std::unique_ptr<AtomicOutput> output(const std::string& name) const;
  // Removes the regular file NAME (absent is fine); checked as above.
  void remove(const std::string& name) const;
  // The state folder NAME (one component): created when absent; a link or a file there is
  // refused. Returns false when it does not exist and CREATE is false.
  bool state_folder(const std::string& name, bool create) const;

 private:
  std::string root_;
};

// A configuration file as circcomp reads it for a plan (inside the directory or not): its
// text, bounded by kMaxConfigFileBytes, or nullopt when absent. Throws IoError for a FIFO, a
// device or a folder where a file is expected (a FIFO would block the plan).
std::optional<std::string> read_config_file(const std::string& path);

}  // namespace circtest::compensation
