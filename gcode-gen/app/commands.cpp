#include "circtest/circgen/commands.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <optional>
#include <utility>

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

namespace {

// "5,0,0 mm", or in inch for an inch program.
std::string position_list(const std::array<double, 3>& mm, LengthUnit units) {
  const double per = units == LengthUnit::inch ? kMmPerInch : 1.0;
  return fmt::format("{:g},{:g},{:g} {}", mm[0] / per, mm[1] / per, mm[2] / per,
                     units == LengthUnit::inch ? "in" : "mm");
}

// The origin of the work offset the program runs in, in machine coordinates, and what it
// rests on (docs/circgen.md "Work offsets"): --offset, else the parameter file's origin of
// --work-offset, else the file's selected system (the program inherits it: said on stderr),
// else machine zero (not known: said in the header and on stderr). --offset against a
// different origin in the file is refused.
std::pair<std::array<double, 3>, std::string> work_offset_origin(
    const GenerateRequest& request, const MachineLimits& limits,
    std::vector<std::string>& warnings) {
  const CircleTestSpec& spec = request.planes.front();
  const std::optional<WorkOffsets> file =
      limits.parameter_file.empty()
          ? std::nullopt
          : read_work_offsets(limits.parameter_file, limits.mm_per_machine_unit,
                              limits.g92_persistence);
  const int index = spec.work_offset_code ? work_offset_index(*spec.work_offset_code)
                                          : (file ? file->selected : 0);
  std::optional<std::array<double, 3>> from_file;
  std::string file_source;
  if (file && index > 0) {
    static constexpr const char* kCodes[] = {"",    "G54", "G55",   "G56",   "G57",
                                             "G58", "G59", "G59.1", "G59.2", "G59.3"};
    if (file->rotation_deg[index] != 0.0) {
      throw DataError(file->path, 0,
                      fmt::format("{} has an XY rotation of {:g} deg (#{}): circgen cannot check "
                                  "the path in a rotated work offset",
                                  kCodes[index], file->rotation_deg[index], 5210 + 20 * index));
    }
    std::array<double, 3> o = file->origin_mm[index];
    if (file->g92_applied)
      for (int i = 0; i < 3; ++i) o[i] += file->g92_mm[i];
    from_file = o;
    file_source =
        fmt::format("{} #{}..#{}{} in {}", kCodes[index], 5201 + 20 * index, 5203 + 20 * index,
                    file->g92_applied ? " plus G92 #5211..#5213" : "", file->path);
    if (!spec.work_offset_code && !spec.work_offset_mm) {
      warnings.push_back(fmt::format(
          "the program inherits the work offset; the path is checked in {}, the one selected "
          "when LinuxCNC saved {} (#5220): give --work-offset to be sure",
          kCodes[index], file->path));
      file_source += ", selected when saved (#5220)";
    }
  }
  if (spec.work_offset_mm) {
    constexpr double kAgreeMm = 1e-6;
    for (int i = 0; i < 3 && from_file; ++i) {
      if (std::abs((*from_file)[i] - (*spec.work_offset_mm)[i]) <= kAgreeMm) continue;
      if (request.offset_from_linuxcnc) {
        warnings.push_back(fmt::format(
            "--offset {} (the origin the running LinuxCNC uses) differs from {} = {}, which "
            "LinuxCNC writes when it exits: the path is checked from --offset",
            position_list(*spec.work_offset_mm, spec.units), file_source,
            position_list(*from_file, spec.units)));
        return {*spec.work_offset_mm, "--offset, the origin the running LinuxCNC uses"};
      }
      throw UsageError(fmt::format(
          "--offset {} disagrees with {} = {}: give the origin that is right, or drop --offset",
          position_list(*spec.work_offset_mm, spec.units), file_source,
          position_list(*from_file, spec.units)));
    }
    return {*spec.work_offset_mm, from_file ? "--offset, as " + file_source : "--offset"};
  }
  if (from_file) return {*from_file, file_source};
  const std::string why = limits.parameter_file.empty()
                              ? std::string("no parameter file")
                              : fmt::format("no parameter file {}", limits.parameter_file);
  warnings.push_back(fmt::format(
      "the work offset's origin is not known ({}, no --offset): the path is checked as if it "
      "were machine zero",
      why));
  return {{0.0, 0.0, 0.0}, fmt::format("not known: {}, no --offset; checked as machine zero", why)};
}

}  // namespace

int run_generate(GenerateRequest request, std::ostream& out, std::ostream& err) {
  std::vector<CircleTestSpec>& planes = request.planes;
  std::vector<std::string> warnings;  // written once the program is
  validate_set(planes, circgen_option_words);
  for (const CircleTestSpec& spec : planes) check_floor(spec, circgen_option_words);
  if (!request.ini_path.empty()) {
    const MachineLimits limits = read_machine_limits(request.ini_path);
    const auto [origin, source] = work_offset_origin(request, limits, warnings);
    std::vector<std::string> checks;
    for (const CircleTestSpec& spec : planes) {
      checks = check_against_machine(spec, limits, origin, circgen_option_words);
    }
    const bool known = !source.starts_with("not known");
    // A G-code comment ends at ')': a file name's brackets are written square.
    auto comment_safe = [](std::string text) {
      for (char& c : text) c = c == '(' ? '[' : (c == ')' ? ']' : (c == '\n' ? ' ' : c));
      return text;
    };
    for (CircleTestSpec& spec : planes) {
      if (known) spec.work_offset_mm = origin;
      spec.extra_header.emplace_back(meta_key::ini, comment_safe(request.ini_path));
      spec.extra_header.emplace_back(meta_key::ini_checked, join(checks));
      spec.extra_header.emplace_back("work_offset_origin_source", comment_safe(source));
    }
  }

  const TestProgram program = generate_test_set(planes);
  for (const CircleTestSpec& spec : planes) {
    for (std::string& warning : program_warnings(spec, circgen_option_words)) {
      warnings.push_back(std::move(warning));
    }
  }
  for (const std::string& warning : warnings) err << "circgen: warning: " << warning << '\n';
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
