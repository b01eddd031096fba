#pragma once
// How a session speaks with the operator: progress and results on standard output, and the
// one question before anything is written into the configuration.
#include <iosfwd>
#include <string>

namespace circtest::session {

struct Console {
  bool yes = false;  // the answer is given beforehand: apply without asking
  std::ostream* out = nullptr;
  // True with `yes`; else asks QUESTION on the terminal and reads "y"/"yes"; false without
  // a terminal on standard input (nothing is applied then, and the caller says so).
  bool confirm(const std::string& question) const;
  std::ostream& print() const;
};

}  // namespace circtest::session
