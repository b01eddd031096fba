#pragma once
// The plausible ranges of circgen's numbers, in one table: every number written to a program
// comes from these, so bounding them keeps every word finite and short enough for the
// interpreter. docs/circgen.md ("Plausible ranges") lists the same table.
#include <cstddef>
#include <string_view>

#include "circtest/gcode/generator.hpp"

namespace circtest {

struct PlausibleRange {
  SpecSetting setting;    // what it bounds, worded by the front end (SpecWords)
  std::string_view what;  // e.g. "circle diameter"
  double min;
  double max;
  std::string_view unit;  // the unit of min and max (lengths in mm, feeds in mm/min)
};

namespace plausible {
// Lengths in mm and feeds in mm/min whatever the program units (inch options are converted
// first). 100 m is beyond any machine table; a 1 mm circle is the smallest a ballbar or a
// grid encoder measures; 100 m/min is beyond any machine's feed.
inline constexpr PlausibleRange diameter{SpecSetting::radius, "circle diameter", 1.0, 10'000.0,
                                         "mm"};
inline constexpr PlausibleRange feed{SpecSetting::feeds, "feed", 1.0, 100'000.0, "mm/min"};
inline constexpr PlausibleRange approach_feed{SpecSetting::approach_feed, "approach feed", 1.0,
                                              100'000.0, "mm/min"};
inline constexpr PlausibleRange reference_diameter{
    SpecSetting::reference_diameter, "Annex C reference diameter", 1.0, 10'000.0, "mm"};
inline constexpr PlausibleRange reference_feed{SpecSetting::reference_feed,
                                               "Annex C reference feed", 1.0, 100'000.0, "mm/min"};
inline constexpr PlausibleRange position{SpecSetting::centre, "position", -100'000.0, 100'000.0,
                                         "mm"};
inline constexpr PlausibleRange safe{SpecSetting::safe, "clearance position", -100'000.0, 100'000.0,
                                     "mm"};
inline constexpr PlausibleRange floor{SpecSetting::floor, "floor height", -100'000.0, 100'000.0,
                                      "mm"};
inline constexpr PlausibleRange offset{SpecSetting::work_offset_values, "work offset", -100'000.0,
                                       100'000.0, "mm"};
inline constexpr PlausibleRange start{SpecSetting::start, "start angle", -360.0, 360.0, "deg"};
inline constexpr PlausibleRange arc{SpecSetting::arc, "measured arc", 90.0, 360.0, "deg"};
// The smallest angle circgen writes as one arc, and the smallest gap it leaves between two
// points of the circle that are not the same point. Below it, on a small circle, the end
// point written with the program's decimals lands on (or just behind) the start point, and
// the interpreter then runs a full circle (a G2/G3 whose end is its start, or nearly).
inline constexpr double kMinArcStepDeg = 1.0;
inline constexpr PlausibleRange lead{SpecSetting::lead, "lead arc", kMinArcStepDeg, 180.0, "deg"};
inline constexpr PlausibleRange dwell{SpecSetting::dwell, "dwell", 0.0, 2.0, "s"};
// One run per direction per feed: a sweep is a handful of feeds, not a data file.
inline constexpr std::size_t kMaxFeeds = 100;
}  // namespace plausible

// Throws UsageError "SETTING: WHAT of VALUE UNIT is outside the plausible range MIN..MAX UNIT"
// (SETTING in `words`) unless min <= value <= max (a NaN or an infinity is never inside).
void check_plausible(const PlausibleRange& range, double value,
                     SpecWords words = library_spec_words);

// A length (mm) or feed (mm/min) given in `units`: the message says it, and the range, in
// inch for an inch program.
void check_plausible(const PlausibleRange& range, double value_mm, LengthUnit units,
                     SpecWords words = library_spec_words);

// Every number of the spec against the table (validate() calls it).
void check_plausible(const CircleTestSpec& spec, SpecWords words = library_spec_words);

}  // namespace circtest
