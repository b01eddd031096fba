#include <fmt/format.h>

#include <optional>

#include "circtest/core/error.hpp"
#include "circtest/gcode/generator.hpp"
#include "program_header.hpp"
#include "program_text.hpp"
#include "program_writer.hpp"

// The program's body: modes, each plane's pause, approach, runs and retract.
namespace circtest {

using namespace gcode_detail;

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

std::vector<MeasuredRun> plan_runs(const CircleTestSpec& spec) {
  std::vector<MeasuredRun> runs;
  append_runs(spec, 1, runs);
  return runs;
}

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
