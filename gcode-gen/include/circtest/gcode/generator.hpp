#pragma once
// The ISO 230-4 circular test program: what circgen writes for LinuxCNC 2.9 (RS274NGC).
// docs/circgen.md describes the program layout, the header keys and the marker scheme.
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "circtest/core/plane.hpp"
#include "circtest/core/setting_words.hpp"

namespace circtest {

enum class LengthUnit { mm, inch };

// What measures the circle; it decides the pauses and moves around the runs
// (docs/circgen.md "Instrument profiles").
//   encoder: nothing mounted (the machine's own feedback, or a non-contact head left in place)
//   grid:    a non-contact 2-D grid encoder: lead arcs only, no radial moves
//   ballbar: a telescoping ball bar: mount pause, radial feed-in/feed-out around each run,
//            overshoot arcs, remove pause before any retract
enum class Instrument { encoder, grid, ballbar };

const char* instrument_name(Instrument instrument) noexcept;
std::optional<Instrument> parse_instrument(std::string_view text);

// Limits circgen assumes for a telescoping ball bar (documented in docs/circgen.md).
inline constexpr double kBallbarMinRadiusMm = 50.0;
inline constexpr double kBallbarMaxRadiusMm = 600.0;
inline constexpr double kBallbarMaxFeedMmPerMin = 10000.0;
inline constexpr double kBallbarMinFeedInMm = 0.5;
inline constexpr double kBallbarMaxFeedInMm = 3.0;
inline constexpr double kBallbarDefaultFeedInMm = 1.5;
inline constexpr double kBallbarDefaultOvershootDeg = 20.0;
// A vertical-plane ballbar test travels this far in all, overshoot included (Renishaw's
// 220 deg = 180 deg of data + 2 x 20 deg), over the top of the circle.
inline constexpr double kBallbarVerticalTotalArcDeg = 220.0;
// Without --clearance a ballbar test approaches and leaves through this far from the circle
// on the plane's normal axis (+Z above an XY circle; +X, +Y beside a YZ, ZX circle): clear
// of the centre pivot and its magnetic base.
inline constexpr double kBallbarDefaultClearanceMm = 50.0;
// The bar lengths (= test radii) of the usual telescoping ball bar with its extensions.
inline const std::vector<double> kBallbarDefaultLengthsMm{50.0, 100.0, 150.0, 300.0};
// A radius matches a bar length within this (a diameter given in inch to 4 decimals).
inline constexpr double kBallbarLengthToleranceMm = 0.005;

// The approach feed when --approach-feed is not given: well below the test feed.
inline constexpr double kDefaultApproachFeedMmPerMin = 200.0;

inline constexpr double kMmPerInch = 25.4;

// Annex C scaling, kept for the header: V1 = V2 * sqrt(D1 / D2), in program units.
struct AnnexCNote {
  double test_diameter = 0.0;       // D1
  double reference_diameter = 0.0;  // D2
  double reference_feed = 0.0;      // V2, per minute
  double scaled_feed_exact = 0.0;   // V2 * sqrt(D1 / D2) before rounding
  double scaled_feed = 0.0;         // V1 as programmed
};

// Everything that defines a test. Lengths in mm and feeds in mm/min whatever the program
// units; `units` only selects G20/G21 and how numbers are written.
struct CircleTestSpec {
  Plane plane = Plane::XY;
  double radius_mm = 0.0;
  std::vector<double> feeds_mm_per_min;  // one run per direction per feed, in this order
  std::vector<Direction> directions{Direction::CCW, Direction::CW};
  std::array<double, 3> centre_mm{0.0, 0.0, 0.0};  // x, y, z in the active work offset
  // The measured (data) arc, 90..360. circgen's --arc is the total angle travelled, this
  // plus the lead arcs at both ends (docs/circgen.md "Arc").
  double arc_deg = 360.0;
  double start_deg = 0.0;         // from the plane's first axis toward its second
  double lead_deg = 10.0;         // lead-in and lead-out arcs on the same circle
  std::optional<double> safe_mm;  // clearance position on the plane's normal axis
  // The lowest Z the tool may reach, in the work offset (e.g. the table top plus a margin):
  // a path below it is refused (LimitError).
  std::optional<double> floor_mm;
  // Ballbar only: the lengths the bar can be set to; the radius must be one of them.
  std::vector<double> ballbar_lengths_mm = kBallbarDefaultLengthsMm;
  Instrument instrument = Instrument::encoder;
  // Feed of the descent to the circle's height and of the ballbar's radial moves; unset:
  // default_approach_feed_mm_per_min().
  std::optional<double> approach_feed_mm_per_min;
  double feed_in_mm = kBallbarDefaultFeedInMm;  // ballbar: radial feed-in/out, outside the circle
  // Origin of the active work offset in machine coordinates, when known (--offset): the
  // header then states the centre's machine position.
  std::optional<std::array<double, 3>> work_offset_mm;
  std::optional<std::string> work_offset_code;  // "G54".."G59.3" to select; unset: inherited
  std::optional<int> tool_length_offset;        // G43 H<n>; unset: inherited
  double dwell_s = 0.0;                         // pause where the direction reverses
  LengthUnit units = LengthUnit::mm;
  int marker_output = 0;   // M62/M63 P
  int segment_output = 0;  // M67 E
  std::optional<AnnexCNote> annex_c;
  std::string date;                                               // header `date`, ISO 8601
  std::vector<std::pair<std::string, std::string>> extra_header;  // e.g. the INI check
};

// One measured arc of the program.
struct MeasuredRun {
  int segment_id = 0;  // 1, 2, ... in program order, across the planes of a set
  Plane plane = Plane::XY;
  Direction direction = Direction::CCW;
  double feed_mm_per_min = 0.0;
  double start_deg = 0.0;  // where this run's measured arc begins
  double sweep_deg = 0.0;  // positive; the run turns by this much in `direction`
};

struct TestProgram {
  std::vector<std::pair<std::string, std::string>> header;  // (key, value), in order
  std::vector<MeasuredRun> runs;
  std::string text;  // the whole program, ready to load
};

// The spec setting a refusal or warning is about. The library names it by its field of
// CircleTestSpec ("lead_deg"); a front end words it as its own (circgen: its options, in
// gcode-gen/app/commands.cpp), so library text names no command-line option.
enum class SpecSetting {
  radius,
  any_feed,  // no feed at all: what could give one
  feeds,
  directions,
  arc,
  start,
  lead,
  centre,
  safe,
  dwell,
  marker,
  segment_out,
  approach_feed,
  work_offset,
  tool,
  feed_in,
  ballbar,  // the ball bar instrument
  ballbar_lengths,
  floor,
  planes,  // the planes of a test set
  // Annex C's feed scaling (annex_c.hpp) and the work offset's values.
  test_diameter,
  reference_diameter,
  reference_feed,
  work_offset_values,
};
using SpecWords = SettingWords<SpecSetting>;
std::string_view library_spec_words(SpecSetting setting) noexcept;

// Throws UsageError naming the setting (in `words`) when the spec cannot give a valid test
// (non-positive radius or feed, arc outside 90..360, overlapping leads, bad output numbers,
// numbers outside the plausible ranges of plausible_ranges.hpp, ...).
void validate(const CircleTestSpec& spec, SpecWords words = library_spec_words);

// The runs in program order (CCW then CW for each feed when both directions are asked).
std::vector<MeasuredRun> plan_runs(const CircleTestSpec& spec);

// Validates and builds the whole program in memory.
TestProgram generate_test_program(const CircleTestSpec& spec);

// A test set: one program that runs the planes in the given order, each with its own
// approach, operator pause, runs and retract; segment ids run on across the planes. The
// specs differ only in plane, arc_deg, start_deg and safe_mm (validate_set says which
// else differs). A set of one is generate_test_program's program.
TestProgram generate_test_set(const std::vector<CircleTestSpec>& planes);
void validate_set(const std::vector<CircleTestSpec>& planes, SpecWords words = library_spec_words);

// The lowest Z (work offset, mm) the tool reaches in this plane's part of the program: the
// circle's height in XY, the lowest point of the swept range (at the ballbar's feed-in
// radius too) in YZ and ZX.
double lowest_z_mm(const CircleTestSpec& spec);

// Throws LimitError when the path goes below spec.floor_mm, naming both heights.
void check_floor(const CircleTestSpec& spec, SpecWords words = library_spec_words);

// The ballbar's clearance without --clearance: kBallbarDefaultClearanceMm beyond the centre
// on the plane's normal axis.
double ballbar_default_clearance_mm(const CircleTestSpec& spec);

// min(kDefaultApproachFeedMmPerMin, half the lowest test feed), or the given one.
double approach_feed_mm_per_min(const CircleTestSpec& spec);

// The default start angle: 0, or for a partial arc in YZ/ZX the start that centres the
// swept range (leads included) on the top of the circle (+Z), away from the table.
double default_start_deg(Plane plane, double arc_deg);

// Non-fatal concerns about a valid spec, one line each (e.g. a vertical-plane arc that
// passes below the centre, towards the table).
std::vector<std::string> program_warnings(const CircleTestSpec& spec,
                                          SpecWords words = library_spec_words);

// The angular range every motion of the test stays in, [first, last] degrees (CCW sense);
// a range of 360 deg or more means the whole circle.
std::pair<double, double> swept_range_deg(const CircleTestSpec& spec);

const char* length_unit_name(LengthUnit units) noexcept;  // "mm", "inch"

// The generator's name and version for the header, e.g. "circgen 0.1.0".
std::string generator_version();

}  // namespace circtest
