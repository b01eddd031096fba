#pragma once
// The G-code lines of circgen's program (internal to the gcode library).
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <string>
#include <string_view>

#include "circtest/core/angles.hpp"
#include "circtest/core/error.hpp"
#include "circtest/gcode/generator.hpp"
#include "circtest/gcode/plausible_ranges.hpp"
#include "program_text.hpp"

namespace circtest::gcode_detail {

// Arc centre offset words, by axis: I for X, J for Y, K for Z.
inline char offset_word(char axis) {
  return static_cast<char>('I' + axis_index(axis));
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

}  // namespace circtest::gcode_detail
