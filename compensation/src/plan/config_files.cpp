// The configuration's files as the planner reads them: bounded, a FIFO or folder refused,
// and every file a plan changes checked inside the configuration directory first.
#include <fmt/format.h>

#include <string>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/core/error.hpp"
#include "context.hpp"

namespace circtest::compensation::detail {

// A configuration file's text (bounded; a FIFO or a folder refused), "" when absent.
std::string slurp_if(const std::string& path, bool& existed) {
  const auto text = read_config_file(path);
  existed = text.has_value();
  return text.value_or("");
}

// The name inside CONFIG of a file the plan changes; UnsafePathError when it lies outside, is a
// link or is not a regular file (checked before it is read: a FIFO would block).
std::string target_name(const ConfigDir& config, const std::string& path) {
  const auto name = config.name_of(path);
  if (!name) {
    throw UnsafePathError(path,
                          fmt::format("outside the configuration directory {}: circcomp changes "
                                      "only files inside it (reading one outside is fine); move "
                                      "it in, or make this change by hand",
                                      config.root()));
  }
  config.regular_or_absent(*name);
  return *name;
}

// The text of a file the plan changes, "" when absent.
std::string read_target(const ConfigDir& config, const std::string& path, bool& existed) {
  target_name(config, path);
  return slurp_if(path, existed);
}

// The INI's own text, for its SHA-256.
std::string ini_text(const std::string& ini_path) {
  bool existed = false;
  std::string text = slurp_if(ini_path, existed);
  if (!existed) throw IoError(ini_path, "no such file (expected the machine's LinuxCNC INI)");
  return text;
}

}  // namespace circtest::compensation::detail
