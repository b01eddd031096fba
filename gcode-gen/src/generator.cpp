#include "circtest/gcode/generator.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "circtest/core/angles.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/core/version.hpp"
#include "circtest/gcode/plausible_ranges.hpp"

namespace circtest {

namespace {

constexpr double kAngleEpsilonDeg = 1e-9;
// LinuxCNC 2.9 builds with 64 motion digital and analog outputs at most (num_dio, num_aio).
constexpr int kMaxOutputIndex = 63;
// "Short dwell at most" between the directions: clause 5 wants the runs back to back.
constexpr double kMaxDwellS = 2.0;

int axis_index(char axis) {
  return axis - 'x';
}

char upper(char axis) {
  return static_cast<char>(axis - 'a' + 'A');
}

// Arc centre offset words, by axis: I for X, J for Y, K for Z.
char offset_word(char axis) {
  return static_cast<char>('I' + axis_index(axis));
}

// Header numbers: shortest form that survives a round trip, after dropping float noise
// (38.099999999999994 mm from 1.5 in is 38.1).
std::string header_number(double value) {
  // Beyond 1e9 there is no float noise below 1e-9 to drop (and value * 1e9 could overflow).
  if (!(std::abs(value) < 1e9)) return fmt::format("{}", value);
  double rounded = std::round(value * 1e9) / 1e9;
  if (rounded == 0.0) rounded = 0.0;  // no "-0"
  return fmt::format("{}", rounded);
}

std::string header_list(const std::vector<double>& values) {
  std::vector<std::string> texts;
  for (double v : values) texts.push_back(header_number(v));
  return join(texts);
}

// A length in the program's units for a message, to the program's digits: "50" or "1.9685",
// and with its unit.
std::string units_number(const CircleTestSpec& spec, double mm) {
  const double value = spec.units == LengthUnit::inch ? mm / kMmPerInch : mm;
  const double digits = spec.units == LengthUnit::inch ? 1e5 : 1e4;  // as the program writes
  return header_number(std::abs(value) < 1e9 ? std::round(value * digits) / digits : value);
}
std::string length_text(const CircleTestSpec& spec, double mm) {
  return units_number(spec, mm) + (spec.units == LengthUnit::inch ? " in" : " mm");
}

// A length or a feed in the program's units for a message, all its digits: "-51.816051714
// mm", "2.04 in", "20 in/min".
std::string units_value(const CircleTestSpec& spec, double mm) {
  return header_number(spec.units == LengthUnit::inch ? mm / kMmPerInch : mm);
}
std::string exact_length_text(const CircleTestSpec& spec, double mm) {
  return units_value(spec, mm) + (spec.units == LengthUnit::inch ? " in" : " mm");
}
// A range fixed in mm, and in inch too for an inch program: "0.5..3 mm [0.019685..0.11811 in]".
std::string mm_range_text(const CircleTestSpec& spec, double low_mm, double high_mm) {
  std::string text = fmt::format("{}..{} mm", header_number(low_mm), header_number(high_mm));
  if (spec.units == LengthUnit::inch) {
    text += fmt::format(" [{:.5g}..{:.5g} in]", low_mm / kMmPerInch, high_mm / kMmPerInch);
  }
  return text;
}
std::string feed_text(const CircleTestSpec& spec, double mm_per_min) {
  return exact_length_text(spec, mm_per_min) + "/min";
}

// Two positions the program would write as one number (4 decimals in mm, 5 in inch).
bool written_equal(const CircleTestSpec& spec, double a_mm, double b_mm) {
  const double per_unit = spec.units == LengthUnit::inch ? 1e5 / kMmPerInch : 1e4;
  return std::round(a_mm * per_unit) == std::round(b_mm * per_unit);
}

double normalize_deg(double deg) {
  double r = std::fmod(deg, 360.0);
  if (r < 0.0) r += 360.0;
  if (r >= 360.0 - kAngleEpsilonDeg) r = 0.0;
  return r;
}

// Writes the program body in program units with a fixed number of decimals. Positions are
// kept as written so that each arc's centre offsets are taken from the rounded start point,
// which keeps the interpreter's centre on the nominal centre to the last written digit.
class ProgramWriter {
 public:
  ProgramWriter(const CircleTestSpec& spec)
      : spec_(spec),
        axes_(plane_axes(spec.plane)),
        scale_(spec.units == LengthUnit::mm ? 1.0 : 1.0 / kMmPerInch),
        decimals_(spec.units == LengthUnit::mm ? 4 : 5) {
    for (int i = 0; i < 3; ++i) centre_[i] = round_units(spec.centre_mm[i] * scale_);
    radius_ = spec.radius_mm * scale_;
  }

  void line(const std::string& text) {
    text_ += text;
    text_ += '\n';
  }

  std::string number(double value) const {
    check_word(value);
    std::string s = fmt::format("{:.{}f}", round_units(value), decimals_);
    while (!s.empty() && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
    if (s == "-0") s = "0";
    return s;
  }

  std::string feed(double feed_mm_per_min) const {
    check_word(feed_mm_per_min * scale_);
    // mm/min feeds keep one decimal (they are whole numbers); inch/min ones three, so that
    // a feed converted from mm/min (200 mm/min = 7.874 in/min) is the feed asked for to
    // 0.03 mm/min, not F7.9.
    std::string s = fmt::format("{:.{}f}", feed_mm_per_min * scale_, feed_decimals());
    while (s.find('.') != std::string::npos && (s.back() == '0' || s.back() == '.')) {
      const bool point = s.back() == '.';
      s.pop_back();
      if (point) break;
    }
    return s;
  }

  int feed_decimals() const { return decimals_ == 4 ? 1 : 3; }

  // A point on the test circle, or on a concentric one `extra` program units further out.
  std::array<double, 3> point_at(double angle_deg, double extra = 0.0) const {
    std::array<double, 3> p = centre_;
    const double t = deg_to_rad(angle_deg);
    const double r = radius_ + extra;
    p[axis_index(axes_.first)] = round_units(centre_[axis_index(axes_.first)] + r * std::cos(t));
    p[axis_index(axes_.second)] = round_units(centre_[axis_index(axes_.second)] + r * std::sin(t));
    return p;
  }

  // "X65 Y-13.02": the in-plane coordinates of a point, for operator messages.
  std::string plane_point_text(const std::array<double, 3>& p) const {
    return fmt::format("{}{} {}{}", upper(axes_.first), number(p[axis_index(axes_.first)]),
                       upper(axes_.second), number(p[axis_index(axes_.second)]));
  }

  // "X65 Y-13.02 Z0": a point for operator messages.
  std::string point_text(const std::array<double, 3>& p) const {
    return fmt::format("X{} Y{} Z{}", number(p[0]), number(p[1]), number(p[2]));
  }

  // G0/G1 to a point; only the listed axes are written.
  void move(const char* code, const std::array<double, 3>& target, std::string_view axes,
            const std::string& suffix = {}) {
    std::string s = code;
    for (char axis : std::string_view("xyz")) {
      if (axes.find(axis) == std::string_view::npos) continue;
      s += fmt::format(" {}{}", upper(axis), number(target[axis_index(axis)]));
      position_[axis_index(axis)] = target[axis_index(axis)];
    }
    line(s + suffix);
  }

  // An arc on the test circle from `from_deg`, turning `sweep_deg` (positive) in `direction`.
  // A sweep of 360 deg is written as a full circle (end point = start point).
  void arc(Direction direction, double from_deg, double sweep_deg, const std::string& suffix,
           double extra = 0.0) {
    const double to_deg = direction == Direction::CCW ? from_deg + sweep_deg : from_deg - sweep_deg;
    const std::array<double, 3> end =
        std::abs(sweep_deg - 360.0) < kAngleEpsilonDeg ? position_ : point_at(to_deg, extra);
    check_written_sweep(direction, end, sweep_deg);
    std::string s = direction == Direction::CCW ? "G3" : "G2";
    for (char axis : std::string_view("xyz")) {
      if (axis == axes_.normal) continue;
      s += fmt::format(" {}{}", upper(axis), number(end[axis_index(axis)]));
    }
    for (char axis : std::string_view("xyz")) {
      if (axis == axes_.normal) continue;
      const int i = axis_index(axis);
      s += fmt::format(" {}{}", offset_word(axis), number(centre_[i] - position_[i]));
    }
    position_ = end;
    line(s + suffix);
  }

  void set_position(const std::array<double, 3>& p) { position_ = p; }
  const std::array<double, 3>& position() const { return position_; }
  double to_units(double mm) const { return mm * scale_; }
  const std::array<double, 3>& centre() const { return centre_; }
  std::string take() { return std::move(text_); }

 private:
  // validate() keeps every input in its plausible range, so any word is far inside this;
  // a value beyond it would be a bug, not a user's number.
  static void check_word(double value) {
    if (!(std::abs(value) < 1e7)) {
      throw Error(ExitCode::internal, fmt::format("refusing to write a G-code word of {}", value));
    }
  }

  // What the interpreter runs for the written words: the turn from the start to the end
  // point in `direction`, a full one when they are the same point. validate() keeps every
  // arc and gap at least kMinArcStepDeg from 0 and 360 deg, far beyond the written digits,
  // so a mismatch is a bug, never a user's number: refuse rather than write a full circle.
  void check_written_sweep(Direction direction, const std::array<double, 3>& end,
                           double sweep_deg) const {
    const int a = axis_index(axes_.first), b = axis_index(axes_.second);
    double turn_deg = 360.0;
    if (end[a] != position_[a] || end[b] != position_[b]) {
      const double from = std::atan2(position_[b] - centre_[b], position_[a] - centre_[a]);
      const double to = std::atan2(end[b] - centre_[b], end[a] - centre_[a]);
      const double ccw_deg = rad_to_deg(to - from);
      turn_deg = std::fmod((direction == Direction::CCW ? ccw_deg : -ccw_deg) + 720.0, 360.0);
      if (turn_deg == 0.0) turn_deg = 360.0;
    }
    if (!(std::abs(turn_deg - sweep_deg) <= plausible::kMinArcStepDeg / 2.0)) {
      throw Error(ExitCode::internal,
                  fmt::format("refusing to write an arc meant to turn {} deg that the "
                              "interpreter would run as {} deg",
                              header_number(sweep_deg), header_number(turn_deg)));
    }
  }

  double round_units(double v) const {
    const double f = std::pow(10.0, decimals_);
    return std::round(v * f) / f;
  }

  const CircleTestSpec& spec_;
  PlaneAxes axes_;
  double scale_;
  int decimals_;
  std::array<double, 3> centre_{};
  double radius_ = 0.0;
  std::array<double, 3> position_{};
  std::string text_;
};

double lead_in_start_deg(const CircleTestSpec& spec, Direction direction) {
  return direction == Direction::CCW ? spec.start_deg - spec.lead_deg
                                     : spec.start_deg + spec.arc_deg + spec.lead_deg;
}

// id:DIRECTION:Ffeed:PLANE for each run, the feed as programmed (program units).
std::string segments_value(const std::vector<MeasuredRun>& runs, const ProgramWriter& writer) {
  std::vector<std::string> texts;
  for (const MeasuredRun& run : runs) {
    texts.push_back(fmt::format("{}:{}:F{}:{}", run.segment_id, direction_name(run.direction),
                                writer.feed(run.feed_mm_per_min), plane_name(run.plane)));
  }
  return join(texts);
}

}  // namespace

const char* instrument_name(Instrument instrument) noexcept {
  switch (instrument) {
    case Instrument::grid:
      return "grid";
    case Instrument::ballbar:
      return "ballbar";
    case Instrument::encoder:
      break;
  }
  return "encoder";
}

std::optional<Instrument> parse_instrument(std::string_view text) {
  for (Instrument i : {Instrument::encoder, Instrument::grid, Instrument::ballbar}) {
    if (text == instrument_name(i)) return i;
  }
  return std::nullopt;
}

double approach_feed_mm_per_min(const CircleTestSpec& spec) {
  if (spec.approach_feed_mm_per_min) return *spec.approach_feed_mm_per_min;
  double lowest = kDefaultApproachFeedMmPerMin * 2.0;
  for (double f : spec.feeds_mm_per_min) lowest = std::min(lowest, f);
  return lowest / 2.0;
}

namespace {
// The angle of +Z, the top of the circle, in the plane's angle convention (from the first
// axis toward the second); nullopt for XY, which has no top.
std::optional<double> top_deg(Plane plane) {
  if (plane == Plane::YZ) return 90.0;  // y -> z: +Z is the second axis
  if (plane == Plane::ZX) return 0.0;   // z -> x: +Z is the first axis
  return std::nullopt;
}
}  // namespace

double default_start_deg(Plane plane, double arc_deg) {
  const auto top = top_deg(plane);
  if (!top || arc_deg >= 360.0) return 0.0;
  return normalize_deg(*top - arc_deg / 2.0);
}

std::vector<std::string> program_warnings(const CircleTestSpec& spec, SpecWords words) {
  std::vector<std::string> warnings;
  const auto top = top_deg(spec.plane);
  if (!top) return warnings;
  // A full circle in a vertical plane goes below the centre by definition; only say so when
  // the user chose a partial arc, or a ballbar whose pivot usually sits on the table.
  if (spec.arc_deg >= 360.0 && spec.instrument != Instrument::ballbar) return warnings;
  const auto [from, to] = swept_range_deg(spec);
  const double bottom = *top + 180.0;
  const double rel = normalize_deg(bottom - from);
  if (to - from >= 360.0 || rel <= to - from) {
    warnings.push_back(fmt::format(
        "the {} deg arc [{} to {} deg with the leads] passes below the centre in {}, towards the "
        "table; check the set-up clears it, or drop {} to keep the arc on top",
        header_number(spec.arc_deg), header_number(from), header_number(to), plane_name(spec.plane),
        words(SpecSetting::start)));
  }
  return warnings;
}

const char* length_unit_name(LengthUnit units) noexcept {
  return units == LengthUnit::mm ? "mm" : "inch";
}

std::string_view library_spec_words(SpecSetting setting) noexcept {
  switch (setting) {
    case SpecSetting::radius:
      return "radius_mm";
    case SpecSetting::any_feed:
    case SpecSetting::feeds:
      return "feeds_mm_per_min";
    case SpecSetting::directions:
      return "directions";
    case SpecSetting::arc:
      return "arc_deg";
    case SpecSetting::start:
      return "start_deg";
    case SpecSetting::lead:
      return "lead_deg";
    case SpecSetting::centre:
      return "centre_mm";
    case SpecSetting::safe:
      return "safe_mm";
    case SpecSetting::dwell:
      return "dwell_s";
    case SpecSetting::marker:
      return "marker_output";
    case SpecSetting::segment_out:
      return "segment_output";
    case SpecSetting::approach_feed:
      return "approach_feed_mm_per_min";
    case SpecSetting::work_offset:
      return "work_offset_code";
    case SpecSetting::tool:
      return "tool_length_offset";
    case SpecSetting::feed_in:
      return "feed_in_mm";
    case SpecSetting::ballbar:
      return "instrument ballbar";
    case SpecSetting::ballbar_lengths:
      return "ballbar_lengths_mm";
    case SpecSetting::floor:
      return "floor_mm";
    case SpecSetting::planes:
      return "planes";
    case SpecSetting::test_diameter:
      return "test_diameter";
    case SpecSetting::reference_diameter:
      return "reference_diameter";
    case SpecSetting::reference_feed:
      return "reference_feed";
    case SpecSetting::work_offset_values:
      return "work_offset_mm";
  }
  return "a setting";
}

std::string generator_version() {
  return version_line("circgen");
}

namespace {
// Where the lead-out ends and the next lead-in starts: the same point when both directions
// run back to back or the leads close the circle, else a gap that a single-direction sweep
// runs back over. A gap under kMinArcStepDeg (or that short of a full turn) cannot be
// written as the arc it is: its end point lands on or behind its start.
void check_lead_gap(const CircleTestSpec& spec, SpecWords words) {
  const double gap_deg = normalize_deg(spec.arc_deg + 2.0 * spec.lead_deg);
  const double step = plausible::kMinArcStepDeg;
  if (gap_deg < kAngleEpsilonDeg || (gap_deg >= step && gap_deg <= 360.0 - step)) return;
  const bool full = spec.arc_deg >= 360.0;
  // The two leads that keep the gap at 0 or at least one step: the largest below, and the
  // one that closes it.
  const double closing_deg = full ? 180.0 : (360.0 - spec.arc_deg) / 2.0;
  const double below_deg = std::floor((closing_deg - step / 2.0) * 1000.0) / 1000.0;
  const std::string lead = std::string(words(SpecSetting::lead));
  throw UsageError(fmt::format(
      "{}: {} deg leads around a {} deg arc leave {} deg of the circle between the lead-out end "
      "and the lead-in start, less than {} deg: that arc cannot be written; use {}{} {} to close "
      "the circle",
      lead, header_number(spec.lead_deg), header_number(spec.arc_deg),
      header_number(360.0 - gap_deg), header_number(step),
      below_deg >= step ? fmt::format("{} {} or less, or ", lead, header_number(below_deg)) : "",
      lead, header_number(closing_deg)));
}

// What fits around a partial arc that the leads overlap: a shorter lead when one of at least
// kMinArcStepDeg fits, else a shorter (or the full) arc.
std::string overlap_advice(const CircleTestSpec& spec, SpecWords words) {
  const double step = plausible::kMinArcStepDeg;
  const double max_lead_deg = std::floor((360.0 - spec.arc_deg) / 2.0 * 1000.0) / 1000.0;
  if (max_lead_deg >= step) {
    return fmt::format("{} {} or less", words(SpecSetting::lead), header_number(max_lead_deg));
  }
  const double lead_deg = std::max(spec.lead_deg, step);
  return fmt::format("{} {} or less, or {} 360", words(SpecSetting::arc),
                     header_number(std::floor((360.0 - 2.0 * lead_deg) * 1000.0) / 1000.0),
                     words(SpecSetting::arc));
}

// A ballbar measures at the lengths it can be set to: a radius between them is no test.
void check_ballbar_length(const CircleTestSpec& spec, SpecWords words) {
  for (double length : spec.ballbar_lengths_mm) {
    if (!std::isfinite(length) || length < kBallbarMinRadiusMm || length > kBallbarMaxRadiusMm) {
      throw UsageError(fmt::format("{}: a bar length of {} mm is outside {}..{} mm",
                                   words(SpecSetting::ballbar_lengths), header_number(length),
                                   header_number(kBallbarMinRadiusMm),
                                   header_number(kBallbarMaxRadiusMm)));
    }
  }
  for (double length : spec.ballbar_lengths_mm) {
    if (std::abs(spec.radius_mm - length) <= kBallbarLengthToleranceMm) return;
  }
  std::vector<double> lengths = spec.ballbar_lengths_mm;
  std::sort(lengths.begin(), lengths.end());
  throw UsageError(fmt::format(
      "{}: radius {} is not a length of the ballbar profile ({} mm); test at one of them, or "
      "give the bar's lengths with {}",
      words(SpecSetting::ballbar), exact_length_text(spec, spec.radius_mm), header_list(lengths),
      words(SpecSetting::ballbar_lengths)));
}

// The clearance keeps the tool out of the circle's plane, where the instrument is: above an
// XY circle it is a height (one at or below the circle would lower the tool at rapid onto the
// set-up); beside a YZ or ZX circle, a position off its plane on either side (one in the
// plane would move the tool at rapid through the circle).
void check_clearance_and_floor(const CircleTestSpec& spec, SpecWords words) {
  auto w = [words](SpecSetting setting) { return words(setting); };
  const char normal = plane_axes(spec.plane).normal;
  const double centre = spec.centre_mm[axis_index(normal)];
  if (spec.safe_mm && spec.plane == Plane::XY &&
      (!(*spec.safe_mm > centre) || written_equal(spec, *spec.safe_mm, centre))) {
    throw UsageError(fmt::format(
        "{}: Z {} is not above the circle's height Z {}: the clearance in XY must be above it",
        w(SpecSetting::safe), length_text(spec, *spec.safe_mm), length_text(spec, centre)));
  }
  if (spec.safe_mm && spec.plane != Plane::XY && written_equal(spec, *spec.safe_mm, centre)) {
    throw UsageError(fmt::format(
        "{}: {} {} is the {} circle's own plane ({} {}): the clearance in {} must be beside it, "
        "on either side",
        w(SpecSetting::safe), upper(normal), length_text(spec, *spec.safe_mm),
        plane_name(spec.plane), upper(normal), length_text(spec, centre), plane_name(spec.plane)));
  }
  if (spec.floor_mm && !std::isfinite(*spec.floor_mm))
    throw UsageError(fmt::format("{}: not a finite height", w(SpecSetting::floor)));
}
}  // namespace

void validate(const CircleTestSpec& spec, SpecWords words) {
  auto w = [words](SpecSetting setting) { return words(setting); };
  auto finite = [](double v) { return std::isfinite(v); };
  if (!finite(spec.radius_mm) || spec.radius_mm <= 0.0) {
    throw UsageError(fmt::format("{}: the circle must have a positive size, got radius {}",
                                 w(SpecSetting::radius), header_number(spec.radius_mm)));
  }
  if (spec.feeds_mm_per_min.empty())
    throw UsageError(fmt::format("no feed: give {}", w(SpecSetting::any_feed)));
  for (double f : spec.feeds_mm_per_min) {
    if (!finite(f) || f <= 0.0) {
      throw UsageError(fmt::format("{}: a feed must be positive, got {}", w(SpecSetting::feeds),
                                   units_value(spec, f)));
    }
  }
  if (spec.directions.empty())
    throw UsageError(fmt::format("{}: no direction", w(SpecSetting::directions)));
  if (spec.directions.size() == 2 && spec.directions[0] == spec.directions[1]) {
    throw UsageError(fmt::format("{}: a direction is given twice", w(SpecSetting::directions)));
  }
  if (!finite(spec.arc_deg) || spec.arc_deg < 90.0 || spec.arc_deg > 360.0) {
    throw UsageError(
        fmt::format("{}: the measured arc must be 90..360 deg (ISO 230-4 clause 3.1), got {}",
                    w(SpecSetting::arc), header_number(spec.arc_deg)));
  }
  if (!finite(spec.start_deg))
    throw UsageError(fmt::format("{}: not a finite angle", w(SpecSetting::start)));
  if (!finite(spec.lead_deg) || spec.lead_deg < plausible::kMinArcStepDeg) {
    throw UsageError(
        fmt::format("{}: the lead arcs must be at least {} deg, got {}: the measured arc needs a "
                    "run-up to reach the feed, M63 only takes effect with the next move, and a "
                    "shorter arc can be written as a full circle",
                    w(SpecSetting::lead), header_number(plausible::kMinArcStepDeg), spec.lead_deg));
  }
  const bool full = spec.arc_deg >= 360.0;
  if (full && spec.lead_deg > 180.0) {
    throw UsageError(fmt::format(
        "{}: {} deg lead-in and lead-out arcs would overlap each other on a full circle "
        "(at most 180 deg)",
        w(SpecSetting::lead), header_number(spec.lead_deg)));
  }
  if (!full && spec.arc_deg + 2.0 * spec.lead_deg > 360.0 + kAngleEpsilonDeg) {
    throw UsageError(fmt::format(
        "{}: {} deg lead arcs around a {} deg arc would overlap each other "
        "(arc + 2 * lead = {} > 360 deg); use {}",
        w(SpecSetting::lead), header_number(spec.lead_deg), header_number(spec.arc_deg),
        header_number(spec.arc_deg + 2.0 * spec.lead_deg), overlap_advice(spec, words)));
  }
  check_lead_gap(spec, words);
  for (double c : spec.centre_mm) {
    if (!finite(c))
      throw UsageError(fmt::format("{}: not a finite position", w(SpecSetting::centre)));
  }
  if (spec.safe_mm && !finite(*spec.safe_mm))
    throw UsageError(fmt::format("{}: not a finite position", w(SpecSetting::safe)));
  check_clearance_and_floor(spec, words);
  if (!finite(spec.dwell_s) || spec.dwell_s < 0.0 || spec.dwell_s > kMaxDwellS) {
    throw UsageError(fmt::format("{}: must be 0..{} s, got {}", w(SpecSetting::dwell),
                                 header_number(kMaxDwellS), header_number(spec.dwell_s)));
  }
  if (spec.marker_output < 0 || spec.marker_output > kMaxOutputIndex) {
    throw UsageError(fmt::format("{}: digital output must be 0..{}, got {}", w(SpecSetting::marker),
                                 kMaxOutputIndex, spec.marker_output));
  }
  if (spec.segment_output < 0 || spec.segment_output > kMaxOutputIndex) {
    throw UsageError(fmt::format("{}: analog output must be 0..{}, got {}",
                                 w(SpecSetting::segment_out), kMaxOutputIndex,
                                 spec.segment_output));
  }
  if (spec.approach_feed_mm_per_min) {
    const double a = *spec.approach_feed_mm_per_min;
    const double lowest =
        *std::min_element(spec.feeds_mm_per_min.begin(), spec.feeds_mm_per_min.end());
    if (!finite(a) || a <= 0.0) {
      throw UsageError(fmt::format("{}: must be positive, got {}", w(SpecSetting::approach_feed),
                                   units_value(spec, a)));
    }
    if (a > lowest) {
      throw UsageError(fmt::format("{}: {} is above the test feed {}; the approach must be slower",
                                   w(SpecSetting::approach_feed), feed_text(spec, a),
                                   feed_text(spec, lowest)));
    }
  }
  if (spec.work_offset_code) {
    static const char* const kCodes[] = {"G54", "G55",   "G56",   "G57",  "G58",
                                         "G59", "G59.1", "G59.2", "G59.3"};
    if (std::find(std::begin(kCodes), std::end(kCodes), *spec.work_offset_code) ==
        std::end(kCodes)) {
      throw UsageError(fmt::format("{}: '{}' is not G54..G59, G59.1, G59.2 or G59.3",
                                   w(SpecSetting::work_offset), *spec.work_offset_code));
    }
  }
  if (spec.tool_length_offset && *spec.tool_length_offset <= 0) {
    throw UsageError(
        fmt::format("{}: the tool number for G43 H must be 1 or more", w(SpecSetting::tool)));
  }
  if (spec.instrument == Instrument::ballbar) {
    if (!finite(spec.feed_in_mm) || spec.feed_in_mm < kBallbarMinFeedInMm ||
        spec.feed_in_mm > kBallbarMaxFeedInMm) {
      throw UsageError(
          fmt::format("{}: the ballbar feed-in must be {}, got {}", w(SpecSetting::feed_in),
                      mm_range_text(spec, kBallbarMinFeedInMm, kBallbarMaxFeedInMm),
                      spec.units == LengthUnit::inch ? exact_length_text(spec, spec.feed_in_mm)
                                                     : header_number(spec.feed_in_mm)));
    }
    if (spec.radius_mm < kBallbarMinRadiusMm || spec.radius_mm > kBallbarMaxRadiusMm) {
      throw UsageError(
          fmt::format("{}: radius {} is outside the {} a telescoping ball bar "
                      "with its extensions spans",
                      w(SpecSetting::ballbar), exact_length_text(spec, spec.radius_mm),
                      mm_range_text(spec, kBallbarMinRadiusMm, kBallbarMaxRadiusMm)));
    }
    check_ballbar_length(spec, words);
    for (double f : spec.feeds_mm_per_min) {
      if (f > kBallbarMaxFeedMmPerMin) {
        throw UsageError(fmt::format(
            "{}: feed {} is above the {} circgen allows a ball bar [see docs/circgen.md]",
            w(SpecSetting::ballbar), feed_text(spec, f), feed_text(spec, kBallbarMaxFeedMmPerMin)));
      }
    }
  }
  for (const auto& [key, value] : spec.extra_header) {
    if (key.find_first_of("():\n") != std::string::npos ||
        value.find_first_of("()\n") != std::string::npos) {
      throw UsageError(fmt::format("header entry '{}' cannot go into a G-code comment", key));
    }
  }
  if (spec.date.find_first_of("()\n") != std::string::npos) {
    throw UsageError("the date cannot go into a G-code comment");
  }
  check_plausible(spec, words);
}

namespace {
// The runs of one plane, their ids from `first_id` on.
void append_runs(const CircleTestSpec& spec, int first_id, std::vector<MeasuredRun>& runs) {
  int id = first_id;
  for (double feed : spec.feeds_mm_per_min) {
    for (Direction direction : spec.directions) {
      MeasuredRun run;
      run.segment_id = id++;
      run.plane = spec.plane;
      run.direction = direction;
      run.feed_mm_per_min = feed;
      run.start_deg = normalize_deg(direction == Direction::CCW ? spec.start_deg
                                                                : spec.start_deg + spec.arc_deg);
      run.sweep_deg = spec.arc_deg;
      runs.push_back(run);
    }
  }
}
}  // namespace

std::vector<MeasuredRun> plan_runs(const CircleTestSpec& spec) {
  std::vector<MeasuredRun> runs;
  append_runs(spec, 1, runs);
  return runs;
}

std::pair<double, double> swept_range_deg(const CircleTestSpec& spec) {
  return {spec.start_deg - spec.lead_deg, spec.start_deg + spec.arc_deg + spec.lead_deg};
}

double lowest_z_mm(const CircleTestSpec& spec) {
  const double cz = spec.centre_mm[2];
  const auto top = top_deg(spec.plane);
  if (!top) return spec.safe_mm ? std::min(cz, *spec.safe_mm) : cz;
  const auto [from, to] = swept_range_deg(spec);
  const bool bottom_inside = to - from >= 360.0 || normalize_deg(*top + 180.0 - from) <= to - from;
  const double fi = spec.instrument == Instrument::ballbar ? spec.feed_in_mm : 0.0;
  double lowest = std::numeric_limits<double>::infinity();
  // Height above the centre: r cos(angle - top). The arcs at the ballbar's feed-in radius
  // reach lower below the centre, the ones on the circle lower above it.
  for (double r : {spec.radius_mm, spec.radius_mm + fi}) {
    if (bottom_inside) {
      lowest = std::min(lowest, cz - r);
    } else {
      lowest = std::min({lowest, cz + r * std::cos(deg_to_rad(from - *top)),
                         cz + r * std::cos(deg_to_rad(to - *top))});
    }
  }
  return lowest;
}

void check_floor(const CircleTestSpec& spec, SpecWords words) {
  if (!spec.floor_mm) return;
  const double low = lowest_z_mm(spec);
  // A micrometre of slack: a path that touches the floor exactly is not refused.
  if (low >= *spec.floor_mm - 1e-6) return;
  throw LimitError(fmt::format(
      "{} {}: the path in {} reaches Z {} (work offset), {} below that floor; raise the "
      "centre, travel a shorter arc over the top or test a smaller circle",
      words(SpecSetting::floor), units_value(spec, *spec.floor_mm), plane_name(spec.plane),
      exact_length_text(spec, low), exact_length_text(spec, *spec.floor_mm - low)));
}

double ballbar_default_clearance_mm(const CircleTestSpec& spec) {
  return spec.centre_mm[axis_index(plane_axes(spec.plane).normal)] + kBallbarDefaultClearanceMm;
}

namespace {
// Where a plane's part of the program leaves the tool: at the last lead-out's end (outside
// the circle after a ballbar's feed-out), raised to the clearance on the normal axis.
std::array<double, 3> end_position_mm(const CircleTestSpec& spec) {
  const PlaneAxes axes = plane_axes(spec.plane);
  const bool ccw = spec.directions.back() == Direction::CCW;
  const double end_deg =
      ccw ? spec.start_deg + spec.arc_deg + spec.lead_deg : spec.start_deg - spec.lead_deg;
  const double reach_mm =
      spec.radius_mm + (spec.instrument == Instrument::ballbar ? spec.feed_in_mm : 0.0);
  std::array<double, 3> p = spec.centre_mm;
  p[axis_index(axes.first)] += reach_mm * std::cos(deg_to_rad(end_deg));
  p[axis_index(axes.second)] += reach_mm * std::sin(deg_to_rad(end_deg));
  if (spec.safe_mm) p[axis_index(axes.normal)] = *spec.safe_mm;
  return p;
}

// Between two planes the next one's instrument is set up at its pause, and its first move is
// a rapid of its normal axis alone, from where the plane before left the tool to its own
// clearance. That rapid must not pass through the new plane where the set-up is (nor start
// in the plane there).
void check_move_between(const CircleTestSpec& from, const CircleTestSpec& to, SpecWords words) {
  const std::string_view safe = words(SpecSetting::safe);
  if (!to.safe_mm) {
    throw UsageError(
        fmt::format("{}: a test set moves from plane to plane between its pauses; give {} for {}",
                    words(SpecSetting::planes), safe, plane_name(to.plane)));
  }
  const PlaneAxes axes = plane_axes(to.plane);
  const int n = axis_index(axes.normal), a = axis_index(axes.first), b = axis_index(axes.second);
  const std::array<double, 3> p = end_position_mm(from);
  const double before = p[n] - to.centre_mm[n];
  const double after = *to.safe_mm - to.centre_mm[n];
  const bool in_plane = written_equal(to, p[n], to.centre_mm[n]);
  if (!in_plane && (before > 0.0) == (after > 0.0)) return;  // stays on one side
  const double distance_mm = std::hypot(p[a] - to.centre_mm[a], p[b] - to.centre_mm[b]);
  // What is set up in the plane by then: a grid plate over the circle (and whatever an encoder
  // test leaves there); for a ballbar, whose bar is mounted after the approach, its pivot and
  // base at the centre, kept as far clear as the default clearance keeps them.
  const bool ballbar = to.instrument == Instrument::ballbar;
  const double keep_out_mm = ballbar ? kBallbarDefaultClearanceMm : to.radius_mm;
  if (distance_mm > keep_out_mm) return;
  throw UsageError(fmt::format(
      "{}: {} leaves the tool at X{} Y{} Z{}; the rapid on {} from there to the {} clearance "
      "{} {} {} the {} circle's plane {} from its centre, {} {}: give clearances "
      "that keep the tool on one side of the {} circle, or another plane order",
      safe, plane_name(from.plane), units_number(to, p[0]), units_number(to, p[1]),
      length_text(to, p[2]), upper(axes.normal), plane_name(to.plane), upper(axes.normal),
      length_text(to, *to.safe_mm), in_plane ? "starts in" : "passes through", plane_name(to.plane),
      length_text(to, distance_mm), ballbar ? "within the ballbar pivot's" : "inside its radius",
      length_text(to, keep_out_mm), plane_name(to.plane)));
}
}  // namespace

void validate_set(const std::vector<CircleTestSpec>& planes, SpecWords words) {
  const std::string_view what = words(SpecSetting::planes);
  if (planes.empty()) throw UsageError(fmt::format("{}: no plane", what));
  for (const CircleTestSpec& p : planes) validate(p, words);
  for (std::size_t i = 0; i < planes.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (planes[i].plane == planes[j].plane) {
        throw UsageError(fmt::format("{}: {} is given twice", what, plane_name(planes[i].plane)));
      }
    }
  }
  // One header states them for the whole set, so they must be the same in every plane.
  const CircleTestSpec& a = planes.front();
  for (const CircleTestSpec& b : planes) {
    const char* differs = nullptr;
    if (b.radius_mm != a.radius_mm) differs = "the radius";
    if (b.feeds_mm_per_min != a.feeds_mm_per_min) differs = "the feeds";
    if (b.directions != a.directions) differs = "the directions";
    if (b.centre_mm != a.centre_mm) differs = "the centre";
    if (b.lead_deg != a.lead_deg) differs = "the lead";
    if (b.instrument != a.instrument || b.feed_in_mm != a.feed_in_mm) differs = "the instrument";
    if (b.approach_feed_mm_per_min != a.approach_feed_mm_per_min) differs = "the approach feed";
    if (b.work_offset_mm != a.work_offset_mm || b.work_offset_code != a.work_offset_code ||
        b.tool_length_offset != a.tool_length_offset)
      differs = "the offsets";
    if (b.dwell_s != a.dwell_s || b.units != a.units || b.floor_mm != a.floor_mm)
      differs = "the dwell, units or floor";
    if (b.marker_output != a.marker_output || b.segment_output != a.segment_output)
      differs = "the outputs";
    if (differs) {
      throw UsageError(fmt::format(
          "{}: the planes of a set share everything but the plane, arc, start and clearance; "
          "{} differs in {}",
          what, differs, plane_name(b.plane)));
    }
  }
  for (std::size_t k = 1; k < planes.size(); ++k)
    check_move_between(planes[k - 1], planes[k], words);
}

namespace {

// The key of a value that may differ between the planes: `key` alone for one plane, else
// `key_PLANE` (e.g. arc_deg_YZ).
std::string plane_key(const std::string& key, const CircleTestSpec& spec, bool set) {
  return set ? fmt::format("{}_{}", key, plane_name(spec.plane)) : key;
}

// The header lines of the values that may differ between the planes of a set.
void add_plane_values(const std::vector<CircleTestSpec>& planes,
                      std::vector<std::pair<std::string, std::string>>& h) {
  const bool set = planes.size() > 1;
  auto add = [&h](std::string key, std::string value) {
    h.emplace_back(std::move(key), std::move(value));
  };
  auto all_equal = [&planes](auto value) {
    return std::all_of(planes.begin(), planes.end(),
                       [&](const CircleTestSpec& p) { return value(p) == value(planes[0]); });
  };
  auto start = [](const CircleTestSpec& p) { return normalize_deg(p.start_deg); };
  auto arc = [](const CircleTestSpec& p) { return p.arc_deg; };
  auto total = [](const CircleTestSpec& p) { return p.arc_deg + 2.0 * p.lead_deg; };
  // A set whose planes agree on a number states it unsuffixed too, as one plane does.
  if (!set || all_equal(arc)) add(meta_key::arc_deg, header_number(arc(planes[0])));
  if (!set || all_equal(total)) add("arc_total_deg", header_number(total(planes[0])));
  if (!set || all_equal(start)) add(meta_key::start_deg, header_number(start(planes[0])));
  add(meta_key::lead_deg, header_number(planes[0].lead_deg));
  for (const CircleTestSpec& p : planes) {
    const PlaneAxes axes = plane_axes(p.plane);
    const bool inch = p.units == LengthUnit::inch;
    if (set) {
      add(plane_key(meta_key::axes, p, set),
          fmt::format("{},{}", upper(axes.first), upper(axes.second)));
      std::vector<std::string> labels;
      for (Direction d : p.directions) labels.push_back(direction_label(p.plane, d));
      add(plane_key(meta_key::direction_labels, p, set), join(labels));
      add(plane_key(meta_key::arc_deg, p, set), header_number(arc(p)));
      add(plane_key("arc_total_deg", p, set), header_number(total(p)));
      add(plane_key(meta_key::start_deg, p, set), header_number(start(p)));
    }
    add(plane_key("lowest_z_mm", p, set), header_number(lowest_z_mm(p)));
    if (p.work_offset_mm) {
      add(plane_key("lowest_z_machine_mm", p, set),
          header_number(lowest_z_mm(p) + (*p.work_offset_mm)[2]));
    }
    if (p.safe_mm) {
      add(plane_key("safe_axis", p, set), std::string(1, axes.normal));
      add(plane_key("safe_mm", p, set), header_number(*p.safe_mm));
      if (inch) add(plane_key("safe_in", p, set), header_number(*p.safe_mm / kMmPerInch));
    }
  }
}

// The header's key: value lines (the recorder copies them into the trace's metadata).
std::vector<std::pair<std::string, std::string>> program_header(
    const std::vector<CircleTestSpec>& planes, const std::vector<MeasuredRun>& runs,
    const ProgramWriter& w) {
  const CircleTestSpec& spec = planes.front();
  std::vector<std::pair<std::string, std::string>> h;
  const bool set = planes.size() > 1;
  const bool inch = spec.units == LengthUnit::inch;
  const double to_units = inch ? 1.0 / kMmPerInch : 1.0;
  auto add = [&h](std::string key, std::string value) {
    h.emplace_back(std::move(key), std::move(value));
  };
  std::vector<double> centre_units;
  for (double c : spec.centre_mm) centre_units.push_back(c * to_units);
  std::vector<double> feeds_units;
  for (double f : spec.feeds_mm_per_min) feeds_units.push_back(f * to_units);

  add(meta_key::generator, generator_version());
  if (!spec.date.empty()) add(meta_key::date, spec.date);
  add(meta_key::test, "ISO 230-4 circular test");
  std::vector<std::string_view> names;
  for (const CircleTestSpec& p : planes) names.push_back(plane_name(p.plane));
  add(meta_key::plane, join(names));
  if (!set) {
    const PlaneAxes axes = plane_axes(spec.plane);
    add(meta_key::axes, fmt::format("{},{}", upper(axes.first), upper(axes.second)));
  }
  add(meta_key::units, length_unit_name(spec.units));
  add(meta_key::diameter_mm, header_number(2.0 * spec.radius_mm));
  add(meta_key::radius_mm, header_number(spec.radius_mm));
  add(meta_key::centre_mm, header_list({spec.centre_mm.begin(), spec.centre_mm.end()}));
  if (spec.feeds_mm_per_min.size() == 1) {
    add(meta_key::feed_mm_per_min, header_number(spec.feeds_mm_per_min.front()));
  }
  add(meta_key::feeds_mm_per_min, header_list(spec.feeds_mm_per_min));
  if (inch) {
    add(meta_key::diameter_in, header_number(2.0 * spec.radius_mm * to_units));
    add(meta_key::radius_in, header_number(spec.radius_mm * to_units));
    add(meta_key::centre_in, header_list(centre_units));
    if (feeds_units.size() == 1) add(meta_key::feed_in_per_min, header_number(feeds_units.front()));
    add(meta_key::feeds_in_per_min, header_list(feeds_units));
  }
  {
    std::vector<std::string_view> dirs;
    std::vector<std::string> labels;
    for (Direction d : spec.directions) {
      dirs.push_back(direction_name(d));
      labels.push_back(direction_label(spec.plane, d));
    }
    add(meta_key::directions, join(dirs));
    if (!set) add(meta_key::direction_labels, join(labels));
  }
  add_plane_values(planes, h);
  add(meta_key::dwell_s, header_number(spec.dwell_s));
  if (spec.floor_mm) add("floor_z_mm", header_number(*spec.floor_mm));
  add("motion_mode", "G61");
  add("motion_mode_after", "G64");
  add("feed_override", "off during the runs by M50 P0, back on after by M50 P1");
  // Not `instrument`: that key is the clause 6 description of the instrument (circlog-record
  // --instrument), which the recorder would mix up with this copied header line.
  add("instrument_profile", instrument_name(spec.instrument));
  // The approach feed as written (an inch feed has three decimals).
  const std::string approach_word = w.feed(approach_feed_mm_per_min(spec));
  add("approach_feed_mm_per_min", header_number(approach_feed_mm_per_min(spec)));
  if (inch) add("approach_feed_in_per_min", approach_word);
  if (spec.instrument == Instrument::ballbar) {
    add("feed_in_mm", header_number(spec.feed_in_mm));
    if (inch) add("feed_in_in", header_number(spec.feed_in_mm * to_units));
  }
  // Unless asked to, circgen never sets G54..G59.3 or G43/G49: the program runs in whatever
  // the operator set, and the header says so.
  add("work_offset", spec.work_offset_code
                         ? fmt::format("{}, set by the program", *spec.work_offset_code)
                         : std::string("inherited, not set by the program"));
  add("tool_length_offset",
      spec.tool_length_offset ? fmt::format("G43 H{}, set by the program", *spec.tool_length_offset)
                              : std::string("inherited, not set by the program"));
  if (spec.work_offset_mm) {
    std::vector<double> machine;
    for (int i = 0; i < 3; ++i) machine.push_back(spec.centre_mm[i] + (*spec.work_offset_mm)[i]);
    add("work_offset_origin_machine_mm",
        header_list({spec.work_offset_mm->begin(), spec.work_offset_mm->end()}));
    add("centre_machine_mm", header_list(machine));
  }
  add(meta_key::marker_output, std::to_string(spec.marker_output));
  add(meta_key::segment_output, std::to_string(spec.segment_output));
  add(meta_key::segments, segments_value(runs, w));
  if (spec.annex_c) {
    const AnnexCNote& a = *spec.annex_c;
    const char* u = inch ? "in" : "mm";
    add(fmt::format("annex_c_reference_diameter_{}", u), header_number(a.reference_diameter));
    add(fmt::format("annex_c_reference_feed_{}_per_min", u), header_number(a.reference_feed));
    add("annex_c", fmt::format("V1 = V2 * sqrt[D1/D2] = {} * sqrt[{}/{}] = {:.3f} -> F{}",
                               header_number(a.reference_feed), header_number(a.test_diameter),
                               header_number(a.reference_diameter), a.scaled_feed_exact,
                               header_number(a.scaled_feed)));
  }
  for (const auto& entry : spec.extra_header) h.push_back(entry);
  return h;
}

// What a plane's sections share: the plane's axes, the words, the first point, and where
// the plane stands in the set.
struct Layout {
  PlaneAxes axes;
  bool inch = false;
  double to_units = 1.0;
  bool ballbar = false;
  bool vertical = false;         // YZ or ZX: Z lies in the plane
  char N = 'Z';                  // the normal axis, upper case
  char H = 'X';                  // a vertical plane's horizontal axis, upper case
  std::string normal, in_plane;  // the axes a move may write
  std::string plane_word, marker, segment;
  std::string approach_f, centre_normal, feed_in_text;
  double outside = 0.0;  // the ballbar's radial moves end this far outside the circle
  double first_lead_deg = 0.0;
  std::array<double, 3> start{};     // where the first lead-in starts
  std::size_t index = 0, count = 1;  // this plane's place in the set
  bool last() const { return index + 1 == count; }
};

Layout program_layout(const CircleTestSpec& spec, const ProgramWriter& w, std::size_t index,
                      std::size_t count) {
  Layout l;
  l.axes = plane_axes(spec.plane);
  l.inch = spec.units == LengthUnit::inch;
  l.to_units = l.inch ? 1.0 / kMmPerInch : 1.0;
  l.ballbar = spec.instrument == Instrument::ballbar;
  l.vertical = spec.plane != Plane::XY;
  l.N = upper(l.axes.normal);
  l.H = upper(spec.plane == Plane::YZ ? 'y' : 'x');
  l.normal = std::string(1, l.axes.normal);
  l.in_plane = std::string{l.axes.first, l.axes.second};
  l.plane_word = fmt::format("G{}", plane_gcode(spec.plane));
  l.marker = fmt::format("P{}", spec.marker_output);
  l.segment = fmt::format("E{}", spec.segment_output);
  l.approach_f = w.feed(approach_feed_mm_per_min(spec));
  l.centre_normal = w.number(w.centre()[axis_index(l.axes.normal)]);
  l.outside = l.ballbar ? w.to_units(spec.feed_in_mm) : 0.0;
  l.feed_in_text = w.number(l.outside);
  l.first_lead_deg = lead_in_start_deg(spec, spec.directions.front());
  l.start = w.point_at(l.first_lead_deg, l.outside);
  l.index = index;
  l.count = count;
  return l;
}

// Modes and outputs, once for the whole program: none of them moves the machine.
void write_modes(const CircleTestSpec& spec, const Layout& l, ProgramWriter& w) {
  w.line("M5 M9 (spindle and coolant off)");
  w.line(fmt::format("{} {} G90 G91.1 G94 G40 G80", l.inch ? "G20" : "G21", l.plane_word));
  // G61 (exact path): no blend arcs or parabolic blends, so no join can round off the
  // circle, while tangent joins (lead arc to measured arc) still pass at the feed.
  w.line("G61");
  // Neither causes motion: axes not written in a later move stay where they are.
  if (spec.work_offset_code) w.line(fmt::format("{} (work offset)", *spec.work_offset_code));
  if (spec.tool_length_offset) {
    w.line(fmt::format("G43 H{} (tool length offset)", *spec.tool_length_offset));
  }
  w.line(fmt::format("M65 {}", l.marker));
  w.line(fmt::format("M68 {} Q0", l.segment));
}

// The approach in the plane's own axis names, as write_approach moves.
std::string approach_text(const CircleTestSpec& spec, const Layout& l, const ProgramWriter& w) {
  const std::string start_z = w.number(l.start[2]);
  const std::string start_h = w.number(l.start[axis_index(static_cast<char>(l.H - 'A' + 'a'))]);
  if (!l.vertical) {
    if (spec.safe_mm) {
      return fmt::format(
          "Next: Z rapid alone to {}, X Y rapid to above {}, Z down alone to {} at F{}",
          w.number(*spec.safe_mm * l.to_units), w.plane_point_text(l.start), l.centre_normal,
          l.approach_f);
    }
    return fmt::format(
        "Raise Z clear of the set-up now. Next: X Y rapid at this Z height to above {}, then Z "
        "down alone to {} at F{}",
        w.plane_point_text(l.start), l.centre_normal, l.approach_f);
  }
  const std::string tail = fmt::format(
      "{} rapid alone to the start {}{}, Z alone to the start Z{} at F{}, then {} "
      "alone into the plane to {} at F{}",
      l.H, l.H, start_h, start_z, l.approach_f, l.N, l.centre_normal, l.approach_f);
  if (spec.safe_mm) {
    return fmt::format("Next: {} rapid alone to {} beside the plane, {}", l.N,
                       w.number(*spec.safe_mm * l.to_units), tail);
  }
  return fmt::format("Move {} clear of the set-up now, beside the plane. Next: {}", l.N, tail);
}

// What the operator does at a plane's pause: the first checks the set-up, a later one sets
// the instrument up for its plane.
std::string set_up_text(const CircleTestSpec& spec, const Layout& l) {
  const std::string_view plane = plane_name(spec.plane);
  if (l.index == 0) {
    const std::string offsets =
        spec.work_offset_code || spec.tool_length_offset
            ? fmt::format("work offset {} and tool length {} as measured for this set-up",
                          spec.work_offset_code.value_or("in use"),
                          spec.tool_length_offset ? fmt::format("G43 H{}", *spec.tool_length_offset)
                                                  : std::string("in use"))
            : std::string("work offset and tool length as intended");
    const std::string instrument = l.ballbar
                                       ? ", ballbar NOT mounted yet"
                                       : (spec.instrument == Instrument::grid
                                              ? fmt::format(", grid head mounted for {}", plane)
                                              : std::string());
    return fmt::format("Check: {}, the path clear{}, then cycle start", offsets, instrument);
  }
  switch (spec.instrument) {
    case Instrument::ballbar:
      return fmt::format(
          "Set up {}: set the centre pivot and the tool cup for {}, ballbar NOT mounted yet, "
          "the path clear, then cycle start",
          plane, plane);
    case Instrument::grid:
      return fmt::format(
          "Set up {}: re-orient the grid head and its plate into {}, the path clear, then "
          "cycle start",
          plane, plane);
    case Instrument::encoder:
      break;
  }
  return fmt::format("Set up {}: nothing to mount, the path clear, then cycle start", plane);
}

// A plane's operator pause: what comes, what to check or set up, M0. Nothing moves before
// the operator has read it and said go.
void write_plane_pause(const CircleTestSpec& spec, const Layout& l, ProgramWriter& w) {
  std::string feeds_text;
  for (double f : spec.feeds_mm_per_min)
    feeds_text += (feeds_text.empty() ? "F" : ",F") + w.feed(f);
  std::string dirs_text;
  for (Direction d : spec.directions)
    dirs_text += (dirs_text.empty() ? "" : " then ") + std::string(direction_name(d));
  if (l.index > 0) w.line(fmt::format("{} (plane {})", l.plane_word, plane_name(spec.plane)));
  const char* u = length_unit_name(spec.units);
  const std::string where = l.count > 1 ? fmt::format("test set, plane {} of {}: {}", l.index + 1,
                                                      l.count, plane_name(spec.plane))
                                        : fmt::format("test in {}", plane_name(spec.plane));
  w.line(fmt::format("(MSG, circtest: {} {} {}, R{} {}, {} at {} {}/min, centre {})",
                     instrument_name(spec.instrument), where, l.plane_word,
                     w.number(w.to_units(spec.radius_mm)), u, dirs_text, feeds_text, u,
                     w.point_text(w.centre())));
  w.line(fmt::format("(MSG, {})", approach_text(spec, l, w)));
  w.line(fmt::format("(MSG, {})", set_up_text(spec, l)));
  w.line(l.index == 0 ? std::string("M0 (operator check before any motion)")
                      : fmt::format("M0 (set up plane {})", plane_name(spec.plane)));
}

// The approach (docs/circgen.md "Approach"): clear on the normal axis first, then in the
// plane at rapid only where that does not lower the tool, then down to the circle's height
// at the approach feed; in YZ and ZX then the normal axis into the plane at the approach
// feed. No move writes the normal axis and an in-plane axis together, and no rapid lowers Z
// together with another axis.
void write_approach(const CircleTestSpec& spec, const Layout& l, ProgramWriter& w) {
  const char* u = length_unit_name(spec.units);
  if (spec.safe_mm) {
    std::array<double, 3> safe = l.start;
    safe[axis_index(l.axes.normal)] = *spec.safe_mm * l.to_units;
    w.move("G0", safe, l.normal, fmt::format(" (clear on {})", l.N));
  }
  if (!l.vertical) {
    w.move(
        "G0", l.start, l.in_plane,
        spec.safe_mm ? " (above the start)" : " (in the plane, at the height the operator left)");
    w.move("G1", l.start, l.normal, fmt::format(" F{} (approach)", l.approach_f));
  } else {
    const std::string h(1, static_cast<char>(l.H - 'A' + 'a'));
    w.move("G0", l.start, h, fmt::format(" ({} to the start)", l.H));
    w.move("G1", l.start, "z", fmt::format(" F{} (Z to the start height)", l.approach_f));
    w.move("G1", l.start, l.normal, fmt::format(" F{} (approach, into the plane)", l.approach_f));
  }
  if (l.ballbar) {
    w.line(
        fmt::format("(MSG, Mount the ballbar for {} now: centre pivot at {}, tool cup here, {} {} "
                    "outside the circle; next a radial feed-in of {} {} at F{})",
                    plane_name(spec.plane), w.point_text(w.centre()), l.feed_in_text, u,
                    l.feed_in_text, u, l.approach_f));
    w.line(fmt::format("M0 (mount the ballbar for {})", plane_name(spec.plane)));
  }
  // The feed override would change the feed of the measured arcs.
  w.line("M50 P0 (feed override off for the runs)");
}

// The runs, each with its lead arcs, markers and segment id, joined as the instrument needs.
void write_runs(const CircleTestSpec& spec, const Layout& l, const std::vector<MeasuredRun>& runs,
                ProgramWriter& w) {
  double angle_deg = l.first_lead_deg;
  std::optional<Direction> previous;
  for (const MeasuredRun& run : runs) {
    const std::string f = w.feed(run.feed_mm_per_min);
    const double lead_start = lead_in_start_deg(spec, run.direction);
    if (previous) {
      // A single-direction sweep must get back to the lead-in start; going back through the
      // tested range keeps a partial arc clear of whatever made it partial. A ballbar goes
      // back outside the circle, after its feed-out.
      const double gap = *previous == Direction::CCW ? normalize_deg(angle_deg - lead_start)
                                                     : normalize_deg(lead_start - angle_deg);
      if (gap > kAngleEpsilonDeg) {
        const Direction back = *previous == Direction::CCW ? Direction::CW : Direction::CCW;
        w.arc(back, angle_deg, gap, fmt::format(" F{} (back to the lead-in start)", f), l.outside);
      } else if (*previous != run.direction && spec.dwell_s > 0.0) {
        w.line(fmt::format("G4 P{}", header_number(spec.dwell_s)));
      }
    }
    angle_deg = lead_start;
    const bool ccw = run.direction == Direction::CCW;
    const double sign = ccw ? 1.0 : -1.0;
    w.line(fmt::format("(run {}: {} {} {} F{})", run.segment_id, plane_name(run.plane),
                       direction_name(run.direction), direction_label(spec.plane, run.direction),
                       f));
    if (l.ballbar) {
      w.move("G1", w.point_at(angle_deg), l.in_plane,
             fmt::format(" F{} (feed-in {})", l.approach_f, l.feed_in_text));
    }
    w.arc(run.direction, angle_deg, spec.lead_deg,
          fmt::format(" F{} ({})", f, l.ballbar ? "overshoot" : "lead-in"));
    angle_deg += sign * spec.lead_deg;
    w.line(fmt::format("M67 {} Q{}", l.segment, run.segment_id));
    w.line(fmt::format("M62 {}", l.marker));
    w.arc(run.direction, angle_deg, spec.arc_deg, " (measured)");
    angle_deg += sign * spec.arc_deg;
    // Synchronized outputs take effect with the next move, so the lead-out carries them:
    // the marker and the id drop exactly where the measured arc ends.
    w.line(fmt::format("M63 {}", l.marker));
    w.line(fmt::format("M67 {} Q0", l.segment));
    w.arc(run.direction, angle_deg, spec.lead_deg, l.ballbar ? " (overshoot)" : " (lead-out)");
    angle_deg += sign * spec.lead_deg;
    if (l.ballbar) {
      w.move("G1", w.point_at(angle_deg, l.outside), l.in_plane,
             fmt::format(" F{} (feed-out {})", l.approach_f, l.feed_in_text));
    }
    previous = run.direction;
  }
}

// Overrides back on, blending back on after the last plane, the ballbar off, the retract.
void write_plane_ending(const CircleTestSpec& spec, const Layout& l, ProgramWriter& w) {
  w.line("M50 P1 (feed override back on)");
  if (l.last()) w.line("G64 (path blending back on)");
  if (l.ballbar) {
    w.line(
        spec.safe_mm
            ? fmt::format("(MSG, Remove the ballbar now: next {} rapids alone to {})", l.N,
                          w.number(*spec.safe_mm * l.to_units))
            : std::string("(MSG, Remove the ballbar now: the program then ends without moving)"));
    w.line("M0 (remove the ballbar before any retract)");
  }
  if (spec.safe_mm) {
    std::array<double, 3> safe = w.position();
    safe[axis_index(l.axes.normal)] = *spec.safe_mm * l.to_units;
    w.move("G0", safe, l.normal, fmt::format(" (clear on {})", l.N));
  }
}

}  // namespace

TestProgram generate_test_set(const std::vector<CircleTestSpec>& planes) {
  validate_set(planes);
  for (const CircleTestSpec& p : planes) check_floor(p);
  TestProgram program;
  std::vector<std::vector<MeasuredRun>> plane_runs;
  for (const CircleTestSpec& p : planes) {
    std::vector<MeasuredRun> runs;
    append_runs(p, static_cast<int>(program.runs.size()) + 1, runs);
    program.runs.insert(program.runs.end(), runs.begin(), runs.end());
    plane_runs.push_back(std::move(runs));
  }
  ProgramWriter head(planes.front());
  program.header = program_header(planes, program.runs, head);
  for (const auto& [key, value] : program.header) {
    head.line(fmt::format("(circtest: {}: {})", key, value));
  }
  write_modes(planes.front(), program_layout(planes.front(), head, 0, planes.size()), head);
  program.text = head.take();
  for (std::size_t k = 0; k < planes.size(); ++k) {
    // Each plane's moves write every axis its arcs start from, so a writer per plane needs
    // no position from the one before.
    ProgramWriter w(planes[k]);
    const Layout l = program_layout(planes[k], w, k, planes.size());
    write_plane_pause(planes[k], l, w);
    write_approach(planes[k], l, w);
    write_runs(planes[k], l, plane_runs[k], w);
    write_plane_ending(planes[k], l, w);
    program.text += w.take();
  }
  program.text += "M2\n";
  return program;
}

TestProgram generate_test_program(const CircleTestSpec& spec) {
  return generate_test_set({spec});
}

}  // namespace circtest
