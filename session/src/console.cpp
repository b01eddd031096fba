#include "circtest/session/console.hpp"

#include <unistd.h>

#include <iostream>
#include <string>

namespace circtest::session {

std::ostream& Console::print() const {
  return out ? *out : std::cout;
}

bool Console::confirm(const std::string& question) const {
  if (yes) return true;
  if (::isatty(STDIN_FILENO) == 0) return false;
  print() << question << " [y/N] " << std::flush;
  std::string answer;
  if (!std::getline(std::cin, answer)) return false;
  return answer == "y" || answer == "Y" || answer == "yes";
}

}  // namespace circtest::session
