#include "circtest/gcode/plausible_ranges.hpp"

#include <fmt/format.h>

#include <cmath>
#include <string>

#include "circtest/core/error.hpp"
#include "circtest/gcode/generator.hpp"

namespace circtest {

void check_plausible(const PlausibleRange& range, double value, SpecWords words) {
  if (std::isfinite(value) && value >= range.min && value <= range.max) return;
  throw UsageError(fmt::format(
      "{}: {} of {} {} is outside the plausible range {}..{} {} (docs/circgen.md)",
      words(range.setting), range.what, value, range.unit, range.min, range.max, range.unit));
}

void check_plausible(const PlausibleRange& range, double value_mm, LengthUnit units,
                     SpecWords words) {
  if (units == LengthUnit::mm || std::isnan(value_mm) ||
      (value_mm >= range.min && value_mm <= range.max)) {
    return check_plausible(range, value_mm, words);
  }
  const std::string unit = range.unit == "mm" ? "in" : "in/min";
  throw UsageError(fmt::format(
      "{}: {} of {:.6g} {} is outside the plausible range {:.4g}..{:.4g} {} (docs/circgen.md)",
      words(range.setting), range.what, value_mm / kMmPerInch, unit, range.min / kMmPerInch,
      range.max / kMmPerInch, unit));
}

void check_plausible(const CircleTestSpec& spec, SpecWords words) {
  const LengthUnit u = spec.units;
  check_plausible(plausible::diameter, 2.0 * spec.radius_mm, u, words);
  if (spec.feeds_mm_per_min.size() > plausible::kMaxFeeds) {
    throw UsageError(fmt::format("{}: {} feeds, at most {} (one run pair each)",
                                 words(SpecSetting::feeds), spec.feeds_mm_per_min.size(),
                                 plausible::kMaxFeeds));
  }
  // The smallest feed, 1 mm/min, is F0.039 in inch (three decimals): no feed word is F0.
  for (double f : spec.feeds_mm_per_min) check_plausible(plausible::feed, f, u, words);
  if (spec.approach_feed_mm_per_min) {
    check_plausible(plausible::approach_feed, *spec.approach_feed_mm_per_min, u, words);
  }
  for (double c : spec.centre_mm) check_plausible(plausible::position, c, u, words);
  if (spec.work_offset_mm) {
    for (double c : *spec.work_offset_mm) check_plausible(plausible::offset, c, u, words);
  }
  if (spec.safe_mm) check_plausible(plausible::safe, *spec.safe_mm, u, words);
  if (spec.floor_mm) check_plausible(plausible::floor, *spec.floor_mm, u, words);
  check_plausible(plausible::start, spec.start_deg, words);
  check_plausible(plausible::arc, spec.arc_deg, words);
  check_plausible(plausible::lead, spec.lead_deg, words);
  check_plausible(plausible::dwell, spec.dwell_s, words);
}

}  // namespace circtest
