#include "circtest/core/version.hpp"

#include <string>

namespace circtest {

std::string_view version() noexcept {
  return CIRCTEST_VERSION;
}

std::string version_line(std::string_view program) {
  std::string line(program);
  line += ' ';
  line += version();
  return line;
}

}  // namespace circtest
