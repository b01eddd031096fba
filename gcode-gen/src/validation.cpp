#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "circtest/core/angles.hpp"
#include "circtest/core/error.hpp"
#include "circtest/gcode/generator.hpp"
#include "circtest/gcode/plausible_ranges.hpp"
#include "program_text.hpp"

// What a test specification must be before circgen writes a program for it.
namespace circtest {

using namespace gcode_detail;

namespace {

// LinuxCNC 2.9 builds with 64 motion digital and analog outputs at most (num_dio, num_aio).
constexpr int kMaxOutputIndex = 63;
// "Short dwell at most" between the directions: clause 5 wants the runs back to back.
constexpr double kMaxDwellS = 2.0;

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

// The measured arc, its start and the leads around it.
void check_arcs(const CircleTestSpec& spec, SpecWords words) {
  auto w = [words](SpecSetting setting) { return words(setting); };
  auto finite = [](double v) { return std::isfinite(v); };
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
}

// Where the circle and the clearance are, the pause, the outputs.
void check_positions_and_outputs(const CircleTestSpec& spec, SpecWords words) {
  auto w = [words](SpecSetting setting) { return words(setting); };
  auto finite = [](double v) { return std::isfinite(v); };
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
}

// The approach feed, and the work and tool offsets the program selects.
void check_approach_and_offsets(const CircleTestSpec& spec, SpecWords words) {
  auto w = [words](SpecSetting setting) { return words(setting); };
  auto finite = [](double v) { return std::isfinite(v); };
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
}

// A ballbar: its feed-in, radius, lengths and feeds.
void check_ballbar(const CircleTestSpec& spec, SpecWords words) {
  auto w = [words](SpecSetting setting) { return words(setting); };
  auto finite = [](double v) { return std::isfinite(v); };
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
}

// What goes into the header's G-code comments.
void check_header_text(const CircleTestSpec& spec) {
  for (const auto& [key, value] : spec.extra_header) {
    if (key.find_first_of("():\n") != std::string::npos ||
        value.find_first_of("()\n") != std::string::npos) {
      throw UsageError(fmt::format("header entry '{}' cannot go into a G-code comment", key));
    }
  }
  if (spec.date.find_first_of("()\n") != std::string::npos) {
    throw UsageError("the date cannot go into a G-code comment");
  }
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
  check_arcs(spec, words);
  check_positions_and_outputs(spec, words);
  check_approach_and_offsets(spec, words);
  check_ballbar(spec, words);
  check_header_text(spec);
  check_plausible(spec, words);
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

}  // namespace circtest
