// The servo thread's timing during a recording: the servo_period channel install adds
// (motion.servo.last-period through conv_u32_float) against the thread's own period.
// motion.servo.last-period counts CPU clocks in LinuxCNC 2.9 (rtapi_get_clocks) and
// nanoseconds in later versions (rtapi_get_time). The thread sleeps to absolute deadlines and
// runs a late period's successors at once, so over a run its periods average the nominal one
// whatever their unit: that mean is one nominal period in the column's unit.
#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <ostream>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/session/install.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace fs = std::filesystem;

ServoPeriods servo_periods(const Trace& trace, std::optional<double> ini_period_ns) {
  ServoPeriods p;
  const std::vector<double>* column = trace.column(kServoPeriodColumn);
  if (column == nullptr) return p;
  p.logged = true;
  // The period circlog was called with (the thread's), else the INI's SERVO_PERIOD.
  const std::optional<double> sample_s =
      trace.metadata.number(meta_key::sample_period_s, trace.source);
  if (sample_s && *sample_s > 0) {
    p.nominal_ns = *sample_s * 1e9;
  } else if (ini_period_ns && *ini_period_ns > 0) {
    p.nominal_ns = *ini_period_ns;
  } else {
    throw DataError(trace.source, trace.header_line,
                    "the servo thread's period is unknown (no sample_period_s in the trace, no "
                    "[EMCMOT] SERVO_PERIOD in the INI): its late periods cannot be counted");
  }
  p.samples = column->size();
  if (p.samples == 0) return p;
  double sum = 0;
  for (const double v : *column) sum += v;
  const double mean = sum / static_cast<double>(p.samples);
  // Within 10 % of the nominal period in ns: the unit is ns; else CPU clocks, scaled by it.
  p.unit_is_ns = std::abs(mean / p.nominal_ns - 1.0) < 0.1;
  const double ns_per_unit = p.unit_is_ns || !(mean > 0) ? 1.0 : p.nominal_ns / mean;
  p.units_per_us = 1000.0 / ns_per_unit;
  const double limit_ns = kLatePeriodFactor * p.nominal_ns;
  for (const double value : *column) {
    const double period_ns = value * ns_per_unit;
    p.longest_ns = std::max(p.longest_ns, period_ns);
    if (period_ns > limit_ns) ++p.late;
  }
  return p;
}

std::string servo_period_line(const ServoPeriods& p, bool noted) {
  if (!p.logged) {
    return "the servo thread's period is not logged (see circtest install's note): late "
           "periods would go unseen";
  }
  if (p.late > 0 && noted) {
    return fmt::format(
        "the servo thread missed its period {} times (longest {:.0f} us of {:.0f} us): noted "
        "only, as [CIRCTEST] LATE_SERVO_PERIODS = note asks (a simulated machine)",
        p.late, p.longest_ns / 1000, p.nominal_ns / 1000);
  }
  if (p.late > 0) {
    return fmt::format(
        "the servo thread missed its period {} times (longest {:.0f} us of {:.0f} us): a latency "
        "problem of this PC, not a machine error; nothing applied from this run",
        p.late, p.longest_ns / 1000, p.nominal_ns / 1000);
  }
  return fmt::format(
      "the servo thread kept its period ({} samples, longest {:.0f} us of {:.0f} us)", p.samples,
      p.longest_ns / 1000, p.nominal_ns / 1000);
}

std::string servo_period_json(const ServoPeriods& p, const std::string& trace_name, bool noted) {
  nlohmann::ordered_json j;
  j["trace"] = trace_name;
  j["logged"] = p.logged;
  if (p.logged) {
    j["samples"] = p.samples;
    j["nominal_period_us"] = p.nominal_ns / 1000;
    j["late_limit_us"] = kLatePeriodFactor * p.nominal_ns / 1000;
    j["late_periods"] = p.late;
    j["longest_period_us"] = p.longest_ns / 1000;
    // motion.servo.last-period's unit: ns, or CPU clocks (this many per us)
    j["unit"] = p.unit_is_ns ? "ns" : "cpu clocks";
    j["units_per_us"] = p.units_per_us;
  }
  j["late_periods_noted_only"] = noted;
  j["run_usable"] = !p.logged || p.late == 0 || noted;
  j["says"] = servo_period_line(p, noted);
  return json_text(j, 2) + "\n";
}

int check_servo_periods(const SessionSetup& setup, const std::string& trace, std::ostream& out) {
  TraceReadOptions options;
  options.keep = {std::string(kServoPeriodColumn)};
  options.check_time_monotonic = false;
  const ServoPeriods p = servo_periods(read_trace(trace, options), setup.servo_period_ns);
  // trace.csv -> servo-period.json, verify-trace.csv -> verify-servo-period.json
  const fs::path path(trace);
  const std::string stem = path.stem().string();
  const std::string prefix = stem.ends_with("trace") ? stem.substr(0, stem.size() - 5) : "";
  write_file_atomic((path.parent_path() / (prefix + "servo-period.json")).string(),
                    servo_period_json(p, path.filename().string(), setup.late_periods_noted));
  out << "circtest: " << servo_period_line(p, setup.late_periods_noted) << "\n";
  out.flush();
  const bool refused = p.logged && p.late > 0 && !setup.late_periods_noted;
  return refused ? static_cast<int>(ExitCode::data) : 0;
}

}  // namespace circtest::session
