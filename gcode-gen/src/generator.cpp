#include "circtest/gcode/generator.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "circtest/core/version.hpp"
#include "program_text.hpp"

// The spec's basic words and defaults; validation.cpp, program_header.cpp and motion.cpp
// hold the rest of generator.hpp.
namespace circtest {

using namespace gcode_detail;

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

double default_start_deg(Plane plane, double arc_deg) {
  const auto top = top_deg(plane);
  if (!top || arc_deg >= 360.0) return 0.0;
  return normalize_deg(*top - arc_deg / 2.0);
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

std::pair<double, double> swept_range_deg(const CircleTestSpec& spec) {
  return {spec.start_deg - spec.lead_deg, spec.start_deg + spec.arc_deg + spec.lead_deg};
}

double ballbar_default_clearance_mm(const CircleTestSpec& spec) {
  return spec.centre_mm[axis_index(plane_axes(spec.plane).normal)] + kBallbarDefaultClearanceMm;
}

}  // namespace circtest
