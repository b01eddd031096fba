#include "program_text.hpp"

#include <fmt/format.h>

#include <cmath>

#include "circtest/core/strings.hpp"

namespace circtest::gcode_detail {

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

std::string units_number(const CircleTestSpec& spec, double mm) {
  const double value = spec.units == LengthUnit::inch ? mm / kMmPerInch : mm;
  const double digits = spec.units == LengthUnit::inch ? 1e5 : 1e4;  // as the program writes
  return header_number(std::abs(value) < 1e9 ? std::round(value * digits) / digits : value);
}
std::string length_text(const CircleTestSpec& spec, double mm) {
  return units_number(spec, mm) + (spec.units == LengthUnit::inch ? " in" : " mm");
}

std::string units_value(const CircleTestSpec& spec, double mm) {
  return header_number(spec.units == LengthUnit::inch ? mm / kMmPerInch : mm);
}
std::string exact_length_text(const CircleTestSpec& spec, double mm) {
  return units_value(spec, mm) + (spec.units == LengthUnit::inch ? " in" : " mm");
}
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

std::optional<double> top_deg(Plane plane) {
  if (plane == Plane::YZ) return 90.0;  // y -> z: +Z is the second axis
  if (plane == Plane::ZX) return 0.0;   // z -> x: +Z is the first axis
  return std::nullopt;
}

double lead_in_start_deg(const CircleTestSpec& spec, Direction direction) {
  return direction == Direction::CCW ? spec.start_deg - spec.lead_deg
                                     : spec.start_deg + spec.arc_deg + spec.lead_deg;
}

}  // namespace circtest::gcode_detail
