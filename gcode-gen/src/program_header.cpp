#include "program_header.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest::gcode_detail {

namespace {

// id:DIRECTION:Ffeed:PLANE for each run, the feed as programmed (program units).
std::string segments_value(const std::vector<MeasuredRun>& runs, const ProgramWriter& writer) {
  std::vector<std::string> texts;
  for (const MeasuredRun& run : runs) {
    texts.push_back(fmt::format("{}:{}:F{}:{}", run.segment_id, direction_name(run.direction),
                                writer.feed(run.feed_mm_per_min), plane_name(run.plane)));
  }
  return join(texts);
}

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

}  // namespace

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

}  // namespace circtest::gcode_detail
