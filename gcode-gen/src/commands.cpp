#include "circtest/gcode/commands.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/gcode/machine_limits.hpp"

namespace circtest {

// circgen's words for the spec settings the library's refusals name: its options. The
// messages' tests (tests/gcode-gen) hold the text users see.
std::string_view circgen_option_words(SpecSetting setting) noexcept {
  switch (setting) {
    case SpecSetting::radius:
      return "--d/--r";
    case SpecSetting::any_feed:
      return "--f, --feeds or --ref-f";
    case SpecSetting::feeds:
      return "--f/--feeds";
    case SpecSetting::directions:
      return "--dir";
    case SpecSetting::arc:
      // --arc is the total angle travelled; the library's arc is the data arc.
      return "the data arc [--arc less 2 x --lead]";
    case SpecSetting::start:
      return "--start";
    case SpecSetting::lead:
      return "--lead";
    case SpecSetting::centre:
      return "--centre";
    case SpecSetting::safe:
      return "--clearance";
    case SpecSetting::dwell:
      return "--dwell";
    case SpecSetting::marker:
      return "--marker";
    case SpecSetting::segment_out:
      return "--segment-out";
    case SpecSetting::approach_feed:
      return "--approach-feed";
    case SpecSetting::work_offset:
      return "--work-offset";
    case SpecSetting::tool:
      return "--tool";
    case SpecSetting::feed_in:
      return "--feed-in";
    case SpecSetting::ballbar:
      return "--instrument ballbar";
    case SpecSetting::ballbar_lengths:
      return "--ballbar-lengths";
    case SpecSetting::floor:
      return "--floor";
    case SpecSetting::planes:
      return "--plane";
    case SpecSetting::test_diameter:
      return "--d";
    case SpecSetting::reference_diameter:
      return "--ref-d";
    case SpecSetting::reference_feed:
      return "--ref-f";
    case SpecSetting::work_offset_values:
      return "--offset";
  }
  return library_spec_words(setting);
}

int run_generate(GenerateRequest request, std::ostream& out, std::ostream& err) {
  std::vector<CircleTestSpec>& planes = request.planes;
  validate_set(planes, circgen_option_words);
  for (const CircleTestSpec& spec : planes) check_floor(spec, circgen_option_words);
  if (!request.ini_path.empty()) {
    const MachineLimits limits = read_machine_limits(request.ini_path);
    std::vector<std::string> checks;
    for (const CircleTestSpec& spec : planes) {
      checks =
          check_against_machine(spec, limits, request.work_offset_origin_mm, circgen_option_words);
    }
    for (CircleTestSpec& spec : planes) {
      spec.extra_header.emplace_back(meta_key::ini, request.ini_path);
      spec.extra_header.emplace_back(meta_key::ini_checked, join(checks));
    }
  }

  const TestProgram program = generate_test_set(planes);
  for (const CircleTestSpec& spec : planes) {
    for (const std::string& warning : program_warnings(spec, circgen_option_words)) {
      err << "circgen: warning: " << warning << '\n';
    }
  }
  if (!request.output_path.empty()) {
    write_file_atomic(request.output_path, program.text);
  } else {
    // A failed write (a full disk under `> test.ngc`) is an error with the system's reason,
    // worded as run_cli words it for every program.
    errno = 0;
    out.write(program.text.data(), static_cast<std::streamsize>(program.text.size()));
    out.flush();
    if (!out) {
      throw IoError("standard output", errno != 0
                                           ? std::string("write failed: ") + std::strerror(errno)
                                           : std::string("write failed"));
    }
  }
  return 0;
}

}  // namespace circtest
