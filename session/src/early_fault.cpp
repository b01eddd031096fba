// What ended a program before its first run was recorded (the marker output never came on:
// nothing in the trace to search), named in one line from what the LinuxCNC link saw, with
// the exit code of the same fault mid-run; and the refusal of a moved work offset.
#include <fmt/format.h>
#include <cmath>
#include <filesystem>

#include "circtest/core/error.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace {

constexpr const char* kNothing = "nothing was recorded; nothing analysed or applied";

std::string where(const EarlyEnd& e, const std::string& program) {
  const std::string name = std::filesystem::path(program).filename().string();
  return e.line > 0
             ? fmt::format("at line {} of {}, before its first run was recorded", e.line, name)
             : fmt::format("in {}, before its first run was recorded", name);
}

const FerrorLimit* limit_of(const std::vector<FerrorLimit>& limits, int joint) {
  for (const FerrorLimit& f : limits) {
    if (f.joint == joint) return &f;
  }
  return nullptr;
}

}  // namespace

std::optional<LinkFerror> parse_ferror_event(const std::string& rest) {
  LinkFerror f;
  char extra = 0;
  if (std::sscanf(rest.c_str(), "%d %lf %c", &f.joint, &f.error, &extra) != 2 || f.joint < 0 ||
      !std::isfinite(f.error)) {
    return std::nullopt;
  }
  return f;
}

EarlyFault early_fault(const EarlyEnd& e, const std::string& program,
                       const std::vector<FerrorLimit>& limits) {
  const std::string at = where(e, program);
  if (e.servo_stopped || e.end == "gone") {
    return {fmt::format("the test is incomplete (LinuxCNC quit {}): {}", at, kNothing), 7};
  }
  if (e.end == "idle") {
    return {fmt::format("the test is incomplete (the program was aborted {}): {}", at, kNothing),
            5};
  }
  if (e.end == "estop") {
    return {fmt::format("the test is incomplete (E-stop {}): {}", at, kNothing), 5};
  }
  if (e.end == "off") {
    const FerrorLimit* f = e.ferror ? limit_of(limits, e.ferror->joint) : nullptr;
    if (f && e.ferror->error > f->min_ferror) {
      return {fmt::format("the test is incomplete (joint {} ({}): a following error {}: its "
                          "error reached {:.4f} {}, over [JOINT_{}] MIN_FERROR {:.4f} (FERROR "
                          "{:.4f} at MAX_VELOCITY); LinuxCNC switched the machine off): {}",
                          f->joint, f->axis, at, e.ferror->error, f->units, f->joint, f->min_ferror,
                          f->ferror, kNothing),
              5};
    }
    return {fmt::format("the test is incomplete (the machine was switched off {}; no joint's "
                        "following error high mark rose above its MIN_FERROR: an amplifier "
                        "fault, a limit switch, the operator, or a following error no larger "
                        "than an earlier one since LinuxCNC started; the machine's screen says "
                        "which): {}",
                        at, kNothing),
            5};
  }
  if (e.end == "timeout") {
    return {fmt::format("the test is incomplete (no end within --timeout {}): {}", at, kNothing),
            5};
  }
  const std::string why = e.end.empty() ? "the LinuxCNC link stopped" : e.end;
  return {fmt::format("the test is incomplete ({}, {}): {}", why, at, kNothing), 5};
}

std::string offset_moved_message(const std::array<double, 3>& recorded_mm,
                                 const std::array<double, 3>& now_mm,
                                 const std::string& origin_file,
                                 const std::string& parameter_file) {
  std::string moved;
  for (std::size_t i = 0; i < 3; ++i) {
    if (std::abs(recorded_mm[i] - now_mm[i]) <= kSameOriginMm) continue;
    moved += fmt::format("{}{} was {:.4f} mm, is {:.4f} mm", moved.empty() ? "" : ", ", "XYZ"[i],
                         recorded_mm[i], now_mm[i]);
  }
  return fmt::format(
      "the work offset moved since the session's run ({}), so the program's soft-limit check "
      "does not hold: nothing run. LinuxCNC may not have saved its work offsets at the last "
      "shutdown (it writes them to its parameter file {} only when it shuts down within the "
      "linuxcnc script's time limit): touch off again as for the first run. The session's "
      "work offset, in machine coordinates (G5x + G92, tool length on Z; {}): X {:.4f} Y "
      "{:.4f} Z {:.4f} (in G54 without G92 and tool length offsets: G10 L2 P1 X{:.4f} "
      "Y{:.4f} Z{:.4f})",
      moved, parameter_file.empty() ? "([RS274NGC] PARAMETER_FILE)" : parameter_file, origin_file,
      recorded_mm[0], recorded_mm[1], recorded_mm[2], recorded_mm[0], recorded_mm[1],
      recorded_mm[2]);
}

}  // namespace circtest::session
