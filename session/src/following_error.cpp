// A following error mid-run, found in the trace as LinuxCNC's motion finds it (control.c): a
// joint's |pos_cmd - pos_fb| over its limit, FERROR scaled by |vel_cmd| / MAX_VELOCITY and
// never below MIN_FERROR ([JOINT_n], machine units; LinuxCNC's defaults FERROR 1, MIN_FERROR
// = FERROR, MAX_VELOCITY 1). The trace's x_cmd - x_fb (motor-pos-cmd - motor-pos-fb) is that
// difference: both carry the same backlash and motor offset. vel_cmd is the command's change
// over one sample; a gap in the samples (between runs) starts afresh.
#include <fmt/format.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/session/machine.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace {

double joint_value(const IniDocument& ini, const std::string& section, const char* key,
                   double fallback) {
  const auto entry = ini.find(section, key);
  if (!entry) return fallback;
  const auto value = parse_finite(entry->value);
  if (!value || *value < 0) {
    throw ParseError(
        entry->file, entry->line,
        fmt::format("[{}] {} = {}: expected a number of 0 or more", section, key, entry->value));
  }
  return *value;
}

}  // namespace

std::vector<FerrorLimit> ferror_limits(const IniDocument& ini, const std::string& ini_path) {
  std::vector<FerrorLimit> out;
  for (const JointAxis& j : machine_axes(ini, ini_path).joints) {
    const std::string section = fmt::format("JOINT_{}", j.joint);
    FerrorLimit f;
    f.joint = j.joint;
    f.axis = j.axis;
    f.ferror = joint_value(ini, section, "FERROR", 1.0);
    f.min_ferror = joint_value(ini, section, "MIN_FERROR", f.ferror);
    f.max_velocity = joint_value(ini, section, "MAX_VELOCITY", 1.0);
    f.units = ini.get("TRAJ", "LINEAR_UNITS").value_or("mm");
    out.push_back(f);
  }
  return out;
}

std::optional<FollowingError> find_following_error(const Trace& trace,
                                                   const std::vector<FerrorLimit>& limits) {
  const std::vector<double>* t = trace.column(column_name::t);
  const std::optional<double> period =
      trace.metadata.number(meta_key::sample_period_s, trace.source);
  if (t == nullptr || !period || !(*period > 0)) return std::nullopt;
  std::optional<FollowingError> worst;
  std::set<char> axes_done;
  for (const FerrorLimit& f : limits) {
    const std::string axis(1, static_cast<char>(std::tolower(f.axis)));
    const std::vector<double>* cmd = trace.column(axis + "_cmd");
    const std::vector<double>* fb = trace.column(axis + "_fb");
    // An axis' first joint is the one logged (install: a gantry's second joint is not).
    if (cmd == nullptr || fb == nullptr || !axes_done.insert(f.axis).second) continue;
    for (std::size_t i = 1; i < trace.rows(); ++i) {
      const double dt = (*t)[i] - (*t)[i - 1];
      if (!(dt > 0) || dt > 1.5 * *period) continue;
      const double vel = ((*cmd)[i] - (*cmd)[i - 1]) / dt;
      const double limit = f.max_velocity > 0
                               ? std::max(f.min_ferror, f.ferror * std::abs(vel) / f.max_velocity)
                               : f.min_ferror;
      const double error = std::abs((*cmd)[i] - (*fb)[i]);
      if (error > limit && (!worst || error - limit > worst->error - worst->limit)) {
        worst =
            FollowingError{f.joint, f.axis, error, limit, (*t)[i], trace.line_of_row[i], f.units};
      }
    }
  }
  return worst;
}

std::string following_error_line(const FollowingError& e, const std::string& trace) {
  return fmt::format(
      "the test is incomplete (joint {} ({}): a following error, {:.4f} {} over its limit "
      "{:.4f} of [JOINT_{}] FERROR and MIN_FERROR, {}:{}, t = {:.3f} s; LinuxCNC switched the "
      "machine off): {} keeps what was recorded; nothing analysed or applied",
      e.joint, e.axis, e.error, e.units, e.limit, e.joint, trace, e.line, e.time_s, trace);
}

}  // namespace circtest::session
