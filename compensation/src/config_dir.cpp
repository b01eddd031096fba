#include "circtest/compensation/config_dir.hpp"

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;

namespace {}  // namespace

ConfigDir::ConfigDir(const std::string& ini_path) {
  std::string dir = fs::path(ini_path).parent_path().string();
  if (dir.empty()) dir = ".";
  char* resolved = ::realpath(dir.c_str(), nullptr);
  if (resolved == nullptr) {
    throw IoError(
        dir, std::string("cannot resolve the configuration directory: ") + std::strerror(errno));
  }
  root_ = resolved;
  std::free(resolved);
}

std::string ConfigDir::path(std::string_view name) const {
  return root_ == "/" ? "/" + std::string(name) : root_ + "/" + std::string(name);
}

std::optional<std::string> ConfigDir::name_of(const std::string& path) const {
  std::error_code ec;
  const fs::path abs = fs::absolute(path, ec);
  if (ec || !abs.has_filename()) return std::nullopt;
  const std::string file = abs.filename().string();
  if (file == "." || file == "..") return std::nullopt;
  const fs::path folder = fs::weakly_canonical(abs.parent_path(), ec);
  if (ec) return std::nullopt;
  const std::string full = (folder / file).string();
  const std::string prefix = root_ == "/" ? root_ : root_ + "/";
  if (!full.starts_with(prefix) || full.size() == prefix.size()) return std::nullopt;
  return full.substr(prefix.size());
}

void ConfigDir::check_name(std::string_view name, const std::string& source) {
  auto refuse = [&](const std::string& why) {
    throw UnsafePathError(source, fmt::format("'{}' {}: expected a file name inside the "
                                              "configuration directory",
                                              name, why));
  };
  if (name.empty()) refuse("is empty");
  if (name.front() == '/') refuse("is an absolute path");
  for (const char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) refuse("holds a control character");
  }
  std::size_t begin = 0;
  while (begin <= name.size()) {
    std::size_t end = name.find('/', begin);
    if (end == std::string_view::npos) end = name.size();
    const std::string_view part = name.substr(begin, end - begin);
    if (part.empty() || part == "." || part == "..") refuse("has an empty, '.' or '..' component");
    begin = end + 1;
  }
}

bool ConfigDir::regular_or_absent(const std::string& name) const {
  check_name(name, path(name));
  // Each folder on the way, then NAME itself, without following a link: false when absent.
  std::size_t end = name.find('/');
  for (;;) {
    const bool last = end == std::string::npos;
    const std::string at = path(last ? name : name.substr(0, end));
    struct stat st {};
    if (::lstat(at.c_str(), &st) != 0) {
      if (errno == ENOENT) return false;
      throw IoError(at, std::string("cannot inspect: ") + std::strerror(errno));
    }
    if (last && S_ISREG(st.st_mode)) return true;
    if (!last && S_ISDIR(st.st_mode)) {
      end = name.find('/', end + 1);
      continue;
    }
    throw UnsafePathError(
        at, last ? fmt::format("is {}, expected a regular file; circcomp reads back, writes and "
                               "removes only regular files inside {}",
                               file_kind_name(st.st_mode), root_)
                 : fmt::format("is {}, expected a directory inside {}; circcomp follows no link "
                               "out of the configuration",
                               file_kind_name(st.st_mode), root_));
  }
}

std::optional<std::string> ConfigDir::read(const std::string& name) const {
  if (!regular_or_absent(name)) return std::nullopt;
  return read_input_text(path(name), kMaxConfigFileBytes);
}

std::unique_ptr<AtomicOutput> ConfigDir::output(const std::string& name) const {
  regular_or_absent(name);
  return std::make_unique<AtomicOutput>(path(name));
}

void ConfigDir::remove(const std::string& name) const {
  if (!regular_or_absent(name)) return;
  const std::string full = path(name);
  if (::unlink(full.c_str()) != 0 && errno != ENOENT) {
    throw IoError(full, std::string("cannot remove: ") + std::strerror(errno));
  }
  fsync_parent_directory(full);
}

bool ConfigDir::state_folder(const std::string& name, bool create) const {
  check_name(name, path(name));
  const std::string full = path(name);
  struct stat st {};
  if (::lstat(full.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) return true;
    throw UnsafePathError(full, fmt::format("is {}, expected circcomp's own directory; move it "
                                            "away (circcomp follows no link out of {})",
                                            file_kind_name(st.st_mode), root_));
  }
  if (errno != ENOENT) throw IoError(full, std::string("cannot inspect: ") + std::strerror(errno));
  if (!create) return false;
  if (::mkdir(full.c_str(), 0755) != 0) {
    // Another circcomp made it meanwhile: what is there now is checked as above.
    if (errno == EEXIST) return state_folder(name, false);
    throw IoError(full, std::string("cannot create: ") + std::strerror(errno));
  }
  return true;
}

std::optional<std::string> read_config_file(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return std::nullopt;
    throw IoError(path, std::string("cannot inspect: ") + std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    throw IoError(path, fmt::format("is {}, expected a regular file", file_kind_name(st.st_mode)));
  }
  return read_input_text(path, kMaxConfigFileBytes);
}

}  // namespace circtest::compensation
