#pragma once
// circgen's command, as circana's commands are: from a parsed test specification to the
// program on disk or on stdout, after the machine's limits. gcode-gen/app/main.cpp only turns
// options into a GenerateRequest.
#include <array>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/gcode/generator.hpp"

namespace circtest {

struct GenerateRequest {
  // One spec per plane, in program order (a test set when more than one).
  std::vector<CircleTestSpec> planes;
  // A LinuxCNC INI file whose limits the test must keep (empty: no check); what was checked
  // goes into the program's header.
  std::string ini_path;
  // Machine coordinates of the work offset's origin, for the INI's soft limits.
  std::array<double, 3> work_offset_origin_mm{0.0, 0.0, 0.0};
  // The planes' work_offset_mm is the origin the running LinuxCNC uses (its status, as circtest
  // reads it): the parameter file, which LinuxCNC writes when it exits, is not held against it
  // (a warning says when the two differ).
  bool offset_from_linuxcnc = false;
  std::string output_path;  // written atomically (empty: to `out`)
};

// Validates the specification (UsageError), checks it against the INI (LimitError), writes
// the program and its warnings (to `err`, one "circgen: warning: " line each). Returns 0.
int run_generate(GenerateRequest request, std::ostream& out, std::ostream& err);

// circgen's words for the spec settings a library refusal names: its options ("--lead").
std::string_view circgen_option_words(SpecSetting setting) noexcept;

}  // namespace circtest
