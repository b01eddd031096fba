#pragma once
// Lengths and feeds in the refusals and notes of the evaluation, in the user's units. The
// evaluation works in mm (resolve_units converts a trace in inch before anything is checked),
// so every bound is in mm and holds at the same physical size for a trace in inch; a trace
// whose program ran in inch (`units: inch`) says its sizes in inch and mm: "0.00236 in
// (0.0600 mm)".
#include <fmt/format.h>

#include <string>

#include "circtest/core/trace.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest::detail {

inline constexpr double kUserMmPerInch = 25.4;

// Whether the trace's program ran in inch (its `units` metadata).
inline bool trace_in_inch(const Trace& trace) {
  const std::string* units = trace.metadata.find(meta_key::units);
  return units && *units == "inch";
}

// MM with `decimals` decimals ("0.0600 mm"), in inch first on an inch trace with two more
// ("0.002362 in (0.0600 mm)").
inline std::string user_length(double mm, int decimals, bool inch) {
  if (!inch) return fmt::format("{:.{}f} mm", mm, decimals);
  return fmt::format("{:.{}f} in ({:.{}f} mm)", mm / kUserMmPerInch, decimals + 2, mm, decimals);
}

// A feed: "300 mm/min", on an inch trace "11.811 in/min (300 mm/min)".
inline std::string user_feed(double mm_per_min, bool inch) {
  if (!inch) return fmt::format("{:.0f} mm/min", mm_per_min);
  return fmt::format("{:.3f} in/min ({:.0f} mm/min)", mm_per_min / kUserMmPerInch, mm_per_min);
}

}  // namespace circtest::detail
