// Every circgen variant through LinuxCNC's real interpreter (rs274 -g): the canonical calls
// it prints are checked against geometry computed here from the variant's own numbers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iostream>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/plane.hpp"
#include "circtest/gcode/generator.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

struct Variant {
  std::string name;
  std::vector<std::string> args;
  Plane plane;
  double radius;                 // program units
  std::array<double, 3> centre;  // program units
  std::vector<double> feeds;     // program units per minute
  std::vector<Direction> directions;
  double arc_deg = 360.0;
  double start_deg = 0.0;
  double lead_deg = 10.0;
  std::string units = "mm";
  int marker = 0;
  int segment = 0;
};

const Direction CCW = Direction::CCW;
const Direction CW = Direction::CW;

// The encoder programs: planes, directions, partial arcs, sweeps, inch, Annex C.
std::vector<Variant> encoder_variants() {
  return {
      {"default_xy", {"--d", "150", "--f", "300"}, Plane::XY, 75, {0, 0, 0}, {300}, {CCW, CW}},
      {"xy_ccw_centre_start_safe",
       {"--d", "80", "--f", "1000", "--dir", "ccw", "--centre", "10,-20,5", "--start", "30",
        "--safe-z", "50"},
       Plane::XY,
       40,
       {10, -20, 5},
       {1000},
       {CCW},
       360,
       30},
      {"xy_cw", {"--f", "600", "--dir", "cw", "--r", "50"}, Plane::XY, 50, {0, 0, 0}, {600}, {CW}},
      {"yz_both",
       {"--plane", "YZ", "--d", "100", "--f", "500", "--centre", "0,50,-30"},
       Plane::YZ,
       50,
       {0, 50, -30},
       {500},
       {CCW, CW}},
      {"zx_both_safe",
       {"--plane", "ZX", "--d", "100", "--f", "500", "--centre", "5,0,-40", "--safe-z", "20"},
       Plane::ZX,
       50,
       {5, 0, -40},
       {500},
       {CCW, CW}},
      {"zx_partial_180",
       {"--plane", "zx", "--d", "120", "--f", "400", "--arc", "220", "--lead", "20"},
       Plane::ZX,
       60,
       {0, 0, 0},
       {400},
       {CCW, CW},
       180,
       270,  // a partial arc in ZX is centred on top (+Z) by default
       20},
      {"yz_partial_90_cw_sweep",
       {"--plane", "YZ", "--d", "100", "--arc", "110", "--start", "45", "--dir", "cw", "--feeds",
        "100,200"},
       Plane::YZ,
       50,
       {0, 0, 0},
       {100, 200},
       {CW},
       90,
       45},
      {"xy_sweep_dwell",
       {"--d", "50", "--feeds", "200,500,1000", "--lead", "30", "--dwell", "0.2"},
       Plane::XY,
       25,
       {0, 0, 0},
       {200, 500, 1000},
       {CCW, CW},
       360,
       0,
       30},
      {"xy_partial_270_ccw_sweep_outputs",
       {"--d", "60", "--arc", "290", "--start", "90", "--dir", "ccw", "--feeds", "300,600",
        "--marker", "2", "--segment-out", "3"},
       Plane::XY,
       30,
       {0, 0, 0},
       {300, 600},
       {CCW},
       270,
       90,
       10,
       "mm",
       2,
       3},
      {"inch",
       {"--inch", "--d", "4", "--f", "20", "--centre", "1,2,0.5", "--safe-z", "1.5"},
       Plane::XY,
       2,
       {1, 2, 0.5},
       {20},
       {CCW, CW},
       360,
       0,
       10,
       "inch"},
      {"inch_zx_partial",
       {"--inch", "--plane", "ZX", "--d", "3", "--f", "15", "--arc", "140", "--start", "-30"},
       Plane::ZX,
       1.5,
       {0, 0, 0},
       {15},
       {CCW, CW},
       120,
       330,
       10,
       "inch"},
      {"annex_c",
       {"--d", "125", "--ref-d", "100", "--ref-f", "500"},
       Plane::XY,
       62.5,
       {0, 0, 0},
       {559},
       {CCW, CW}},
  };
}

// The ballbar's and the grid's programs, and the offsets a program may set.
std::vector<Variant> instrument_variants() {
  return {
      {"ballbar_xy_safe",
       {"--instrument", "ballbar", "--d", "200", "--f", "1000", "--centre", "10,20,-50", "--safe-z",
        "30"},
       Plane::XY,
       100,
       {10, 20, -50},
       {1000},
       {CCW, CW},
       360,
       0,
       20},
      {"ballbar_xy_ccw_sweep_feed_in_approach",
       {"--instrument", "ballbar", "--d", "150", "--feeds", "500,1000", "--dir", "ccw", "--feed-in",
        "2", "--approach-feed", "120", "--start", "45", "--ballbar-lengths", "75,150"},
       Plane::XY,
       75,
       {0, 0, 0},
       {500, 1000},
       {CCW},
       360,
       45,
       20},
      {"ballbar_yz_default_top",
       {"--instrument", "ballbar", "--plane", "YZ", "--d", "300", "--f", "800", "--centre",
        "0,0,100", "--safe-z", "50"},
       Plane::YZ,
       150,
       {0, 0, 100},
       {800},
       {CCW, CW},
       180,
       0,
       20},
      {"ballbar_zx_partial_cw_sweep",
       {"--instrument", "ballbar", "--plane", "ZX", "--d", "200", "--feeds", "300,600", "--dir",
        "cw"},
       Plane::ZX,
       100,
       {0, 0, 0},
       {300, 600},
       {CW},
       180,
       270,
       20},
      {"ballbar_inch_xy",
       {"--instrument", "ballbar", "--inch", "--d", "7.874", "--f", "40", "--safe-z", "2"},
       Plane::XY,
       3.937,
       {0, 0, 0},
       {40},
       {CCW, CW},
       360,
       0,
       20,
       "inch"},
      {"grid_xy_safe",
       {"--instrument", "grid", "--d", "140", "--f", "2000", "--safe-z", "5", "--approach-feed",
        "300"},
       Plane::XY,
       70,
       {0, 0, 0},
       {2000},
       {CCW, CW}},
      {"grid_yz_partial",
       {"--instrument", "grid", "--plane", "YZ", "--d", "100", "--f", "1000", "--arc", "220"},
       Plane::YZ,
       50,
       {0, 0, 0},
       {1000},
       {CCW, CW},
       200,
       350},
      {"xy_work_offset_and_tool",
       {"--d", "100", "--f", "600", "--work-offset", "G55", "--tool", "3"},
       Plane::XY,
       50,
       {0, 0, 0},
       {600},
       {CCW, CW}},
      {"ballbar_zx_safe_tool",
       {"--instrument", "ballbar", "--plane", "ZX", "--d", "200", "--f", "800", "--safe-z", "40",
        "--tool", "3", "--work-offset", "G59.1"},
       Plane::ZX,
       100,
       {0, 0, 0},
       {800},
       {CCW, CW},
       180,
       270,
       20},
      {"encoder_zx_partial_safe",
       {"--plane", "ZX", "--d", "100", "--f", "500", "--arc", "140", "--clearance", "-10"},
       Plane::ZX,
       50,
       {0, 0, 0},
       {500},
       {CCW, CW},
       120,
       300},
  };
}

std::vector<Variant> variants() {
  std::vector<Variant> all = encoder_variants();
  for (Variant& v : instrument_variants()) all.push_back(std::move(v));
  return all;
}

// The value of an option in the variant's arguments, if given.
std::optional<std::string> arg(const Variant& v, const std::string& name) {
  for (std::size_t i = 0; i + 1 < v.args.size(); ++i)
    if (v.args[i] == name) return v.args[i + 1];
  return std::nullopt;
}

bool is_ballbar(const Variant& v) {
  return arg(v, "--instrument") == "ballbar";
}

// The ballbar's feed-in in program units: 1.5 mm unless --feed-in says otherwise.
double feed_in(const Variant& v) {
  if (!is_ballbar(v)) return 0.0;
  if (const auto f = arg(v, "--feed-in")) return std::stod(*f);
  return v.units == "mm" ? 1.5 : 1.5 / 25.4;
}

// --approach-feed, or min(200 mm/min, half the lowest feed), in program units.
double approach_feed(const Variant& v) {
  if (const auto f = arg(v, "--approach-feed")) return std::stod(*f);
  const double per_mm = v.units == "mm" ? 1.0 : 1.0 / 25.4;
  return std::min(200.0 * per_mm, *std::min_element(v.feeds.begin(), v.feeds.end()) / 2.0);
}

// --clearance (or --safe-z) in program units; a ballbar's default 50 mm beyond the centre.
std::optional<double> clearance(const Variant& v) {
  for (const char* name : {"--clearance", "--safe-z"})
    if (const auto c = arg(v, name)) return std::stod(*c);
  if (!is_ballbar(v)) return std::nullopt;
  const int n = plane_axes(v.plane).normal - 'x';
  return v.centre[n] + (v.units == "mm" ? 50.0 : 50.0 / 25.4);
}

double wrap360(double deg) {
  double r = std::fmod(deg, 360.0);
  if (r < 0) r += 360.0;
  return r;
}

double angle_diff(double a, double b) {
  const double d = wrap360(a - b);
  return std::min(d, 360.0 - d);
}

std::string fmt_case(const CircleTestSpec& s) {
  std::ostringstream out;
  out << plane_name(s.plane) << " d " << 2.0 * s.radius_mm << " arc " << s.arc_deg << " lead "
      << s.lead_deg << " start " << s.start_deg << " " << instrument_name(s.instrument) << " "
      << s.directions.size() << " dir(s) " << s.feeds_mm_per_min.size() << " feed(s) "
      << length_unit_name(s.units);
  return out.str();
}

class Rs274Variant : public ::testing::TestWithParam<Variant> {};

TEST_P(Rs274Variant, InterpreterAcceptsAndArcsMatchTheTest) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  const Variant& v = GetParam();
  const CommandResult gen = run_circgen(v.args);
  ASSERT_EQ(gen.exit_code, 0) << gen.err;
  ASSERT_TRUE(gen.err.empty()) << gen.err;
  const Rs274Result rs = run_rs274(gen.out);
  ASSERT_EQ(rs.exit_code, 0) << rs.output << "\n" << gen.out;
  const CanonProgram& canon = rs.canon;
  ASSERT_TRUE(canon.ended);
  EXPECT_EQ(canon.units, v.units);

  const double tol = v.units == "mm" ? 2e-3 : 1e-4;  // a few units of the last written digit
  const PlaneAxes axes = plane_axes(v.plane);

  // The runs the test asks for, in order: for each feed, the directions as given.
  struct Expected {
    Direction direction;
    double feed;
  };
  std::vector<Expected> expected;
  for (double f : v.feeds)
    for (Direction d : v.directions) expected.push_back({d, f});

  std::vector<std::size_t> measured;
  for (std::size_t i = 0; i < canon.motions.size(); ++i) {
    const auto it = canon.motions[i].bits.find(v.marker);
    if (it != canon.motions[i].bits.end() && it->second) measured.push_back(i);
  }
  ASSERT_EQ(measured.size(), expected.size());
  const auto count = [&](const std::string& call) {
    return std::count(canon.calls.begin(), canon.calls.end(), call);
  };
  EXPECT_EQ(count("SET_MOTION_OUTPUT_BIT"), static_cast<long>(expected.size()));
  EXPECT_EQ(count("CLEAR_MOTION_OUTPUT_BIT"), static_cast<long>(expected.size()));

  for (std::size_t k = 0; k < measured.size(); ++k) {
    SCOPED_TRACE("measured run " + std::to_string(k + 1));
    const std::size_t i = measured[k];
    const CanonMotion& m = canon.motions[i];
    ASSERT_EQ(m.kind, CanonMotion::arc) << "canon line " << m.source_line;
    // The interpreter's rotation sense is about (first, second); core's CCW goes from the
    // plane's first axis toward its second, so they must be the same pair.
    EXPECT_EQ(m.first, axes.first);
    EXPECT_EQ(m.second, axes.second);
    EXPECT_NEAR(m.radius_start(), v.radius, tol);
    EXPECT_NEAR(m.radius_end(), v.radius, tol);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(m.centre[a], v.centre[a], tol);
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(m.start[axes.normal - 'x'], v.centre[axes.normal - 'x'], tol);
    EXPECT_NEAR(m.feed, expected[k].feed, 1e-9);
    const double sign = expected[k].direction == Direction::CCW ? 1.0 : -1.0;
    EXPECT_NEAR(m.sweep_deg(), sign * v.arc_deg, 0.01);
    const double start =
        expected[k].direction == Direction::CCW ? v.start_deg : v.start_deg + v.arc_deg;
    EXPECT_LT(angle_diff(m.start_angle_deg(), start), 0.01);
    EXPECT_NEAR(m.values.at(v.segment), static_cast<double>(k + 1), 1e-9);

    // The marker is set exactly around this arc: off on the moves before and after, and
    // those are the lead arcs, tangent and in the same sense, so the feed is reached.
    ASSERT_GT(i, 0u);
    ASSERT_LT(i + 1, canon.motions.size());
    for (const CanonMotion* lead : {&canon.motions[i - 1], &canon.motions[i + 1]}) {
      EXPECT_FALSE(lead->bits.at(v.marker)) << "canon line " << lead->source_line;
      EXPECT_NEAR(lead->values.at(v.segment), 0.0, 1e-9);
      ASSERT_EQ(lead->kind, CanonMotion::arc);
      EXPECT_NEAR(lead->sweep_deg(), sign * v.lead_deg, 0.01);
      EXPECT_NEAR(lead->radius_start(), v.radius, tol);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(lead->centre[a], v.centre[a], tol);
    }
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(canon.motions[i - 1].end[a], m.start[a], 1e-9);
      EXPECT_NEAR(canon.motions[i + 1].start[a], m.end[a], 1e-9);
    }
  }

  // Outside the measured arcs the id is 0 and the marker off; every arc stays on the test
  // circle and, for a partial arc, inside the lead-extended range (away from what made the
  // arc partial).
  const double range_low = v.start_deg - v.lead_deg;
  const double range_high = v.start_deg + v.arc_deg + v.lead_deg;
  for (std::size_t i = 0; i < canon.motions.size(); ++i) {
    const CanonMotion& m = canon.motions[i];
    if (std::find(measured.begin(), measured.end(), i) == measured.end()) {
      EXPECT_FALSE(m.bits.count(v.marker) && m.bits.at(v.marker)) << m.source_line;
      EXPECT_TRUE(!m.values.count(v.segment) || m.values.at(v.segment) == 0.0) << m.source_line;
    }
    if (m.kind != CanonMotion::arc) continue;
    // A ballbar goes back to the lead-in start of a sweep outside the circle, after its
    // feed-out; every other arc is on the test circle.
    const double r = std::abs(m.radius_start() - v.radius) > tol && is_ballbar(v)
                         ? v.radius + feed_in(v)
                         : v.radius;
    EXPECT_NEAR(m.radius_start(), r, tol) << m.source_line;
    EXPECT_NEAR(m.radius_end(), r, tol) << m.source_line;
    if (v.arc_deg < 360.0) {
      const double s = m.start_angle_deg();
      const double e = s + m.sweep_deg();
      for (double a : {s, e, (s + e) / 2}) {
        const double rel = wrap360(a - range_low + 0.005) - 0.005;
        EXPECT_LE(rel, range_high - range_low + 0.01) << "canon line " << m.source_line;
      }
      EXPECT_LE(std::abs(m.sweep_deg()), range_high - range_low + 0.01);
    }
  }
}

// The safe program structure (docs/circgen.md "Program layout"), from the interpreter's
// canonical calls: no motion before the first M0, no move that changes an in-plane and the
// normal axis together, the approach and the radial moves at the approach feed, M50 P0/P1
// around the measured arcs, G64 back before the end, and for a ballbar the mount pause, the
// radial feed-in/out of the right length and direction, and the remove pause before any retract.
// One generated program as rs274 ran it, and what the checks of its structure share.
struct Structure {
  const Variant& v;
  const std::string& text;  // the program
  const CanonProgram& canon;
  const std::vector<CanonMotion>& motions;
  double tol, feed_tol;
  PlaneAxes axes;
  int a, b, n;  // the plane's first, second and normal axis
  bool ballbar;
  std::optional<double> safe;        // the clearance on the normal axis, program units
  double fi;                         // the ballbar's feed-in
  std::vector<std::size_t> stops{};  // motions before each PROGRAM_STOP
  std::vector<std::string> all_messages{};
  std::vector<std::size_t> message_positions{};
  std::string first_text{};  // the messages before the first pause
  std::vector<std::size_t> measured{};
  std::size_t first_run = 0;  // the first motion of the first run (feed-in or lead-in)
};

bool moved(double from, double to) {
  return std::abs(to - from) > 1e-9;
}

// Spindle and coolant off before the first pause, in the program text itself (rs274 also
// reports them for its own reset); a work or tool offset the program sets, too.
void check_set_up_before_the_first_pause(const Structure& s) {
  const Variant& v = s.v;
  const std::string& text = s.text;
  const CanonProgram& canon = s.canon;
  const auto first_m0 = text.find("\nM0");
  ASSERT_NE(first_m0, std::string::npos);
  EXPECT_LT(text.find("\nM5 M9"), first_m0);
  if (const auto wo = arg(v, "--work-offset")) {
    EXPECT_LT(text.find("\n" + *wo + " "), first_m0);
  }
  if (const auto tool = arg(v, "--tool")) {
    EXPECT_LT(text.find("\nG43 H" + *tool + " "), first_m0);
    std::size_t uses = 0;
    for (const CanonCall& c : canon.call_log) {
      if (c.name == "USE_TOOL_LENGTH_OFFSET" && c.args.find("0.0000 0.0000 0.0000,") != 0) {
        ++uses;
        EXPECT_EQ(c.motions_before, 0u);
      }
    }
    EXPECT_EQ(uses, 1u) << "G43 reached the interpreter once, before any motion";
  }
  for (std::size_t pos = 0, end; pos < text.size(); pos = end + 1) {
    end = text.find('\n', pos);
    EXPECT_LE(end - pos, 200u) << "line too long for an operator message";
  }
}

// The pauses and messages; nothing moves before the first pause, which says what comes.
void check_first_pause(Structure& s) {
  const Variant& v = s.v;
  const CanonProgram& canon = s.canon;
  auto& stops = s.stops;
  auto& all_messages = s.all_messages;
  auto& message_positions = s.message_positions;
  std::vector<std::string> messages_before_first_stop;
  for (const CanonCall& c : canon.call_log) {
    if (c.name == "PROGRAM_STOP") stops.push_back(c.motions_before);
    if (c.name == "MESSAGE") {
      if (stops.empty()) messages_before_first_stop.push_back(c.args);
      all_messages.push_back(c.args);
      message_positions.push_back(c.motions_before);
    }
  }
  ASSERT_FALSE(stops.empty());
  EXPECT_EQ(stops.front(), 0u) << "motion before the first M0";
  ASSERT_FALSE(messages_before_first_stop.empty());
  for (const auto& m : messages_before_first_stop) s.first_text += m + "\n";
  EXPECT_NE(s.first_text.find(std::string(plane_name(v.plane))), std::string::npos) << s.first_text;
  EXPECT_NE(s.first_text.find("Check:"), std::string::npos) << s.first_text;
  for (double f : v.feeds) {
    std::ostringstream word;
    word << "F" << f;
    EXPECT_NE(s.first_text.find(word.str()), std::string::npos)
        << word.str() << " " << s.first_text;
  }
}

// No move changes an in-plane axis and the normal axis together; arcs keep the normal.
void check_no_mixed_moves(const Structure& s) {
  for (const CanonMotion& m : s.motions) {
    const bool plane_moves = moved(m.start[s.a], m.end[s.a]) || moved(m.start[s.b], m.end[s.b]);
    EXPECT_FALSE(plane_moves && moved(m.start[s.n], m.end[s.n]))
        << "mixed in-plane and normal move, canon line " << m.source_line;
  }
}

// The approach (docs/circgen.md "Approach"), move by move: the clearance on the normal axis
// alone (when there is one), then in XY the plane's axes at rapid and the normal axis down
// alone at the approach feed; in YZ and ZX the horizontal axis of the plane at rapid, Z alone
// at the approach feed and the normal axis alone into the plane at the approach feed. The
// start point the first pause announces is where the approach ends.
void check_approach(const Structure& s) {
  const Variant& v = s.v;
  const auto& motions = s.motions;
  const double tol = s.tol, feed_tol = s.feed_tol;
  const int a = s.a, b = s.b, n = s.n;
  const bool vertical = v.plane != Plane::XY;
  const int h = v.plane == Plane::YZ ? 1 : 0;  // a vertical plane's horizontal axis
  // Which axes a move changes, as a set of indices.
  auto only = [](const CanonMotion& m, std::vector<int> axes) {
    for (int i = 0; i < 3; ++i) {
      if (std::find(axes.begin(), axes.end(), i) == axes.end() && moved(m.start[i], m.end[i]))
        return false;
    }
    return true;
  };
  std::size_t i = 0;
  if (s.safe) {
    ASSERT_LT(i, s.first_run);
    EXPECT_EQ(motions[i].kind, CanonMotion::traverse) << "clearance first";
    EXPECT_TRUE(only(motions[i], {n})) << motions[i].source_line;
    EXPECT_NEAR(motions[i].end[n], *s.safe, tol);
    ++i;
  }
  ASSERT_EQ(s.first_run, i + (vertical ? 3 : 2)) << "the approach has its documented moves";
  const CanonMotion& rapid = motions[i];
  EXPECT_EQ(rapid.kind, CanonMotion::traverse) << rapid.source_line;
  EXPECT_TRUE(vertical ? only(rapid, {h}) : only(rapid, {a, b})) << rapid.source_line;
  std::vector<const CanonMotion*> feeds{&motions[i + 1]};
  if (vertical) {
    EXPECT_TRUE(only(motions[i + 1], {2})) << "Z alone " << motions[i + 1].source_line;
    feeds.push_back(&motions[i + 2]);
  }
  const CanonMotion& in = *feeds.back();
  EXPECT_TRUE(only(in, {n})) << in.source_line;
  EXPECT_NEAR(in.end[n], v.centre[n], tol) << in.source_line;
  for (const CanonMotion* m : feeds) {
    EXPECT_EQ(m->kind, CanonMotion::linear) << m->source_line;
    EXPECT_NEAR(m->feed, approach_feed(v), feed_tol) << m->source_line;
    EXPECT_TRUE(m->feed_override) << "the operator keeps the override on the approach";
  }
  if (s.safe) {
    // The last motion goes back to the clearance along the normal alone.
    EXPECT_EQ(motions.back().kind, CanonMotion::traverse);
    EXPECT_TRUE(only(motions.back(), {n}));
    EXPECT_NEAR(motions.back().end[n], *s.safe, tol);
  } else {
    EXPECT_NE(s.first_text.find(vertical ? "Move " : "Raise Z clear"), std::string::npos)
        << s.first_text;
  }
  // The start point the first pause announces: "above X.. Y.." in XY, "the start H.." and
  // "the start Z.." in YZ and ZX.
  auto announced = [&](const std::string& marker, int count) {
    const std::size_t at = s.first_text.find(marker);
    EXPECT_NE(at, std::string::npos) << marker << " in " << s.first_text;
    std::istringstream text(at == std::string::npos ? "" : s.first_text.substr(at + marker.size()));
    std::vector<std::pair<char, double>> words(count);
    for (auto& [letter, value] : words) text >> letter >> value;
    return words;
  };
  if (!vertical) {
    const auto words = announced("above ", 2);
    EXPECT_EQ(words[0].first, std::toupper(s.axes.first));
    EXPECT_EQ(words[1].first, std::toupper(s.axes.second));
    EXPECT_NEAR(words[0].second, in.end[a], tol);
    EXPECT_NEAR(words[1].second, in.end[b], tol);
  } else {
    const auto hw = announced("to the start ", 1);
    EXPECT_EQ(hw[0].first, "XY"[h]);
    EXPECT_NEAR(hw[0].second, in.end[h], tol);
    const std::size_t at = s.first_text.find("to the start Z");
    ASSERT_NE(at, std::string::npos);
    EXPECT_NEAR(std::stod(s.first_text.substr(at + 14)), in.end[2], tol);
  }
}

// Feed override off exactly over the runs; exact path during them, G64 before the end.
void check_run_modes(const Structure& s) {
  const auto& motions = s.motions;
  const auto& measured = s.measured;
  for (std::size_t i = s.first_run; i <= measured.back(); ++i) {
    EXPECT_FALSE(motions[i].feed_override) << "canon line " << motions[i].source_line;
    EXPECT_EQ(motions[i].control_mode, "CANON_EXACT_PATH") << motions[i].source_line;
  }
  std::optional<std::size_t> enable_at;
  std::string last_mode;
  for (const CanonCall& c : s.canon.call_log) {
    if (c.name == "ENABLE_FEED_OVERRIDE" && c.motions_before > measured.back()) {
      enable_at = c.motions_before;
    }
    if (c.name == "SET_MOTION_CONTROL_MODE") last_mode = c.args;
  }
  ASSERT_TRUE(enable_at) << "M50 P1 after the runs";
  EXPECT_TRUE(last_mode.starts_with("CANON_CONTINUOUS")) << last_mode;
}

// Every straight feed move from the first run on: a ballbar's radial move at the approach
// feed, feed-in right before each lead-in and feed-out right after each lead-out; a ballbar's
// mount and remove pauses where they belong.
void check_radial_moves_and_pauses(const Structure& s) {
  const Variant& v = s.v;
  const auto& motions = s.motions;
  const auto& measured = s.measured;
  const auto& stops = s.stops;
  const auto& all_messages = s.all_messages;
  const auto& message_positions = s.message_positions;
  const std::size_t first_run = s.first_run;
  const double tol = s.tol, feed_tol = s.feed_tol, fi = s.fi;
  const int a = s.a, b = s.b;
  const bool ballbar = s.ballbar;
  for (std::size_t i = first_run; i < motions.size(); ++i) {
    const CanonMotion& m = motions[i];
    if (m.kind != CanonMotion::linear) continue;
    ASSERT_TRUE(ballbar) << "a straight feed move in a run of a profile without radial moves, "
                         << "canon line " << m.source_line;
    EXPECT_NEAR(m.feed, approach_feed(v), feed_tol) << m.source_line;
  }
  if (ballbar) {
    for (std::size_t i : measured) {
      ASSERT_GE(i, 2u);
      ASSERT_LT(i + 2, motions.size());
      const CanonMotion& in = motions[i - 2];
      const CanonMotion& out = motions[i + 2];
      for (const CanonMotion* r : {&in, &out}) {
        ASSERT_EQ(r->kind, CanonMotion::linear) << r->source_line;
        const double r0 = std::hypot(r->start[a] - v.centre[a], r->start[b] - v.centre[b]);
        const double r1 = std::hypot(r->end[a] - v.centre[a], r->end[b] - v.centre[b]);
        const bool inward = r == &in;
        EXPECT_NEAR(r0, inward ? v.radius + fi : v.radius, tol) << r->source_line;
        EXPECT_NEAR(r1, inward ? v.radius : v.radius + fi, tol) << r->source_line;
        // Radial: start, end and centre on one line.
        const double cross = (r->start[a] - v.centre[a]) * (r->end[b] - v.centre[b]) -
                             (r->start[b] - v.centre[b]) * (r->end[a] - v.centre[a]);
        EXPECT_NEAR(cross / (r0 * r1), 0.0, 1e-4) << r->source_line;
      }
    }
    // Mount pause: after the descent, before the first feed-in, with its message.
    ASSERT_GE(stops.size(), 3u);
    EXPECT_EQ(stops[1], first_run);
    // Remove pause: after the last feed-out, before any motion that follows (the retract).
    EXPECT_EQ(stops.back(), measured.back() + 3);
    bool mount = false, remove = false;
    for (std::size_t k = 0; k < all_messages.size(); ++k) {
      if (all_messages[k].find("Mount the ballbar") != std::string::npos) {
        mount = true;
        EXPECT_EQ(message_positions[k], first_run);
      }
      if (all_messages[k].find("Remove the ballbar") != std::string::npos) {
        remove = true;
        EXPECT_EQ(message_positions[k], measured.back() + 3);
      }
    }
    EXPECT_TRUE(mount && remove);
  } else {
    EXPECT_EQ(stops.size(), 1u) << "only the start pause without a contact instrument";
  }
}

TEST_P(Rs274Variant, SafeProgramStructure) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  const Variant& v = GetParam();
  const CommandResult gen = run_circgen(v.args);
  ASSERT_EQ(gen.exit_code, 0) << gen.err;
  const Rs274Result rs = run_rs274(gen.out);
  ASSERT_EQ(rs.exit_code, 0) << rs.output;
  const PlaneAxes axes = plane_axes(v.plane);
  Structure s{v,
              gen.out,
              rs.canon,
              rs.canon.motions,
              v.units == "mm" ? 2e-3 : 1e-4,
              v.units == "mm" ? 1e-9 : 0.051,  // inch feeds have one decimal
              axes,
              axes.first - 'x',
              axes.second - 'x',
              axes.normal - 'x',
              is_ballbar(v),
              clearance(v),
              feed_in(v)};
  check_set_up_before_the_first_pause(s);
  ASSERT_NO_FATAL_FAILURE(check_first_pause(s));
  check_no_mixed_moves(s);
  // Measured arcs, marked by the output bit.
  for (std::size_t i = 0; i < s.motions.size(); ++i) {
    if (s.motions[i].bits.count(v.marker) && s.motions[i].bits.at(v.marker)) {
      s.measured.push_back(i);
    }
  }
  ASSERT_FALSE(s.measured.empty());
  s.first_run = s.measured.front() - (s.ballbar ? 2 : 1);  // feed-in or lead-in
  ASSERT_NO_FATAL_FAILURE(check_approach(s));
  ASSERT_NO_FATAL_FAILURE(check_run_modes(s));
  check_radial_moves_and_pauses(s);
}

INSTANTIATE_TEST_SUITE_P(Variants, Rs274Variant, ::testing::ValuesIn(variants()),
                         [](const ::testing::TestParamInfo<Variant>& p) { return p.param.name; });

// The acceptance case, spelled out.
TEST(Rs274Default, CcwThenCwFullCircleOfRadius75AtF300) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  const CommandResult gen = run_circgen({"--d", "150", "--f", "300"});
  ASSERT_EQ(gen.exit_code, 0);
  const Rs274Result rs = run_rs274(gen.out);
  ASSERT_EQ(rs.exit_code, 0) << rs.output;
  std::vector<CanonMotion> marked;
  for (const auto& m : rs.canon.motions)
    if (m.bits.count(0) && m.bits.at(0)) marked.push_back(m);
  ASSERT_EQ(marked.size(), 2u);
  EXPECT_EQ(marked[0].rotation, 1);
  EXPECT_EQ(marked[1].rotation, -1);
  for (const auto& m : marked) {
    EXPECT_NEAR(m.radius_start(), 75.0, 1e-9);
    EXPECT_NEAR(std::abs(m.sweep_deg()), 360.0, 1e-9);
    EXPECT_DOUBLE_EQ(m.feed, 300.0);
  }
}

// How a set's pause names its plane: "plane 2 of 3: YZ".
std::string fmt_plane_of(std::size_t k, std::size_t count, const std::string& name) {
  return "plane " + std::to_string(k + 1) + " of " + std::to_string(count) + ": " + name;
}

// A header value of a generated program, "" when absent.
std::string header_value(const std::string& text, const std::string& key) {
  const std::string tag = "(circtest: " + key + ": ";
  const std::size_t at = text.find(tag);
  if (at == std::string::npos) return "";
  return text.substr(at + tag.size(), text.find(")\n", at) - at - tag.size());
}

// Z along a motion: its end point, and for an arc 64 points on it.
std::vector<double> heights_along(const CanonMotion& m) {
  std::vector<double> z{m.end[2]};
  if (m.kind != CanonMotion::arc || (m.first != 'z' && m.second != 'z')) return z;
  const int f = m.first - 'x', sec = m.second - 'x';
  const double r = m.radius_start();
  for (int k = 0; k <= 64; ++k) {
    const double a = (m.start_angle_deg() + m.sweep_deg() * k / 64.0) * std::numbers::pi / 180.0;
    z.push_back(m.first == 'z' ? m.centre[f] + r * std::cos(a) : m.centre[sec] + r * std::sin(a));
  }
  return z;
}

struct SetCase {
  std::vector<Plane> planes;
  std::vector<std::string> args;  // besides --plane
  bool inch = false;
};

// One test set as rs274 runs it: the runs in segment order, each in its plane; a pause
// that names the plane before each plane's first motion; no move mixing a plane's axes with
// its normal, no rapid lowering Z together with another axis (none at all in YZ and ZX);
// each plane's lowest point as the header states it.
void check_set(const SetCase& c) {
  std::string plane_list;
  for (Plane p : c.planes)
    plane_list += (plane_list.empty() ? "" : ",") + std::string(plane_name(p));
  std::vector<std::string> args{"--plane", plane_list};
  args.insert(args.end(), c.args.begin(), c.args.end());
  SCOPED_TRACE(plane_list + " " + args.back());
  const CommandResult gen = run_circgen(args);
  ASSERT_EQ(gen.exit_code, 0) << gen.err;
  const Rs274Result rs = run_rs274(gen.out);
  ASSERT_EQ(rs.exit_code, 0) << rs.output;
  ASSERT_TRUE(rs.canon.ended);
  const auto& motions = rs.canon.motions;
  const bool set = c.planes.size() > 1;
  EXPECT_EQ(header_value(gen.out, "plane"), plane_list);
  const double per_mm = c.inch ? 1.0 / 25.4 : 1.0;
  const double tol = c.inch ? 1e-4 : 2e-3;

  // The segment table: id:DIR:Ffeed:PLANE, ids 1..N in program order.
  std::vector<std::pair<Plane, int>> segments;  // plane, rotation sign
  {
    std::istringstream list(header_value(gen.out, "segments"));
    std::string item;
    while (std::getline(list, item, ',')) {
      const auto colon = item.rfind(':');
      const auto plane = parse_plane(item.substr(colon + 1));
      ASSERT_TRUE(plane) << item;
      EXPECT_TRUE(item.starts_with(std::to_string(segments.size() + 1) + ":")) << item;
      segments.emplace_back(*plane, item.find(":CCW:") != std::string::npos ? 1 : -1);
    }
  }
  // The sections: from each plane's pause to the next one.
  std::vector<std::size_t> section;
  for (std::size_t k = 0; k < c.planes.size(); ++k) {
    const std::string name(plane_name(c.planes[k]));
    const std::string words = set ? fmt_plane_of(k, c.planes.size(), name) : "test in " + name;
    std::optional<std::size_t> said;
    bool paused = false;
    for (const CanonCall& call : rs.canon.call_log) {
      if (!said && call.name == "MESSAGE" && call.args.find(words) != std::string::npos) {
        said = call.motions_before;
      } else if (said && call.name == "PROGRAM_STOP") {
        EXPECT_EQ(call.motions_before, *said) << "no motion between the message and the M0";
        paused = true;
        break;
      }
    }
    ASSERT_TRUE(said && paused) << words;
    section.push_back(*said);
  }
  EXPECT_EQ(section.front(), 0u) << "motion before the first pause";
  section.push_back(motions.size());
  std::size_t run = 0;
  for (std::size_t k = 0; k < c.planes.size(); ++k) {
    const Plane plane = c.planes[k];
    const PlaneAxes axes = plane_axes(plane);
    const int a = axes.first - 'x', b = axes.second - 'x', n = axes.normal - 'x';
    ASSERT_LT(section[k], section[k + 1]);
    double lowest = std::numeric_limits<double>::infinity();
    for (std::size_t i = section[k]; i < section[k + 1]; ++i) {
      const CanonMotion& m = motions[i];
      const bool in_plane = moved(m.start[a], m.end[a]) || moved(m.start[b], m.end[b]);
      EXPECT_FALSE(in_plane && moved(m.start[n], m.end[n]))
          << "mixed, canon line " << m.source_line;
      if (m.kind == CanonMotion::traverse && m.end[2] < m.start[2] - 1e-9) {
        EXPECT_FALSE(moved(m.start[0], m.end[0]) || moved(m.start[1], m.end[1]))
            << "a rapid lowering Z with another axis, canon line " << m.source_line;
        EXPECT_EQ(plane, Plane::XY)
            << "a rapid lowering Z in a vertical plane, canon line " << m.source_line;
      }
      for (double z : heights_along(m)) lowest = std::min(lowest, z);
      if (m.bits.count(0) && m.bits.at(0)) {
        ASSERT_LT(run, segments.size());
        EXPECT_EQ(segments[run].first, plane) << "run " << run + 1 << " in its plane";
        EXPECT_EQ(m.kind, CanonMotion::arc);
        EXPECT_EQ(m.first, axes.first);
        EXPECT_EQ(m.second, axes.second);
        EXPECT_EQ(m.rotation > 0 ? 1 : -1, segments[run].second);
        EXPECT_NEAR(m.values.at(0), static_cast<double>(run + 1), 1e-9);
        ++run;
      }
    }
    const std::string key = set ? "lowest_z_mm_" + std::string(plane_name(plane)) : "lowest_z_mm";
    const std::string stated = header_value(gen.out, key);
    ASSERT_FALSE(stated.empty()) << key;
    EXPECT_NEAR(lowest, std::stod(stated) * per_mm, tol) << key << " as stated";
  }
  EXPECT_EQ(run, segments.size());
}

// Every ordered subset of the three planes.
std::vector<std::vector<Plane>> plane_orders() {
  const std::vector<Plane> all{Plane::XY, Plane::YZ, Plane::ZX};
  std::vector<std::vector<Plane>> out;
  for (Plane p : all) {
    out.push_back({p});
    for (Plane q : all) {
      if (q == p) continue;
      out.push_back({p, q});
      for (Plane r : all)
        if (r != p && r != q) out.push_back({p, q, r});
    }
  }
  return out;
}

TEST(Rs274Set, EveryOrderedSubsetOfPlanesWithEveryInstrument) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  const std::vector<std::vector<Plane>> orders = plane_orders();
  ASSERT_EQ(orders.size(), 15u);
  for (const auto& planes : orders) {
    const std::vector<std::string> common{"--d",      "200",      "--feeds",
                                          "500,1000", "--centre", "10,-20,30"};
    for (const char* instrument : {"encoder", "grid", "ballbar"}) {
      std::vector<std::string> args = common;
      if (std::string(instrument) != "ballbar") {
        args.insert(args.end(), {"--clearance", "90"});
      }
      args.insert(args.end(), {"--instrument", instrument});
      ASSERT_NO_FATAL_FAILURE(check_set({planes, args}));
    }
  }
  // Partial arcs, one direction, per-plane clearances, inch.
  ASSERT_NO_FATAL_FAILURE(check_set({{Plane::ZX, Plane::XY, Plane::YZ},
                                     {"--d", "100", "--f", "800", "--arc", "200", "--dir", "cw",
                                      "--clearance", "-60,70,55", "--instrument", "encoder"}}));
  ASSERT_NO_FATAL_FAILURE(check_set({{Plane::YZ, Plane::XY},
                                     {"--inch", "--d", "7.874", "--feeds", "20,40", "--centre",
                                      "0,0,1", "--instrument", "ballbar"},
                                     true}));
}

// The arcs a spec asks for, in program order: per run the way back to its lead-in start
// (a single-direction sweep), the lead-in, the measured arc and the lead-out, each with its
// signed turn (+ from the plane's first axis toward its second) and its radius.
struct IntendedArc {
  double sweep_deg;
  double radius;  // program units
};

std::vector<IntendedArc> intended_arcs(const CircleTestSpec& spec, double per_mm) {
  const double r = spec.radius_mm * per_mm;
  const double outside =
      r + (spec.instrument == Instrument::ballbar ? spec.feed_in_mm * per_mm : 0.0);
  std::vector<IntendedArc> arcs;
  double angle = 0.0;
  std::optional<Direction> previous;
  for (std::size_t f = 0; f < spec.feeds_mm_per_min.size(); ++f) {
    for (Direction d : spec.directions) {
      const double sign = d == Direction::CCW ? 1.0 : -1.0;
      const double lead_start = d == Direction::CCW ? spec.start_deg - spec.lead_deg
                                                    : spec.start_deg + spec.arc_deg + spec.lead_deg;
      if (previous) {
        const double gap =
            *previous == Direction::CCW ? wrap360(angle - lead_start) : wrap360(lead_start - angle);
        if (gap > 1e-9 && gap < 360.0 - 1e-9) {
          arcs.push_back({*previous == Direction::CCW ? -gap : gap, outside});
        }
      }
      arcs.push_back({sign * spec.lead_deg, r});
      arcs.push_back({sign * spec.arc_deg, r});
      arcs.push_back({sign * spec.lead_deg, r});
      angle = lead_start + sign * (2.0 * spec.lead_deg + spec.arc_deg);
      previous = d;
    }
  }
  return arcs;
}

// The height (Z) of a point at `angle_deg` on a circle of radius r around the centre, in a
// vertical plane: Z is YZ's second axis and ZX's first.
double height(Plane plane, double centre_z, double r, double angle_deg) {
  const double a = angle_deg * std::numbers::pi / 180.0;
  return centre_z + r * (plane == Plane::ZX ? std::cos(a) : std::sin(a));
}

struct GridOutcome {
  int accepted = 0;
  int refused = 0;
};

// One spec through circgen's library and, when accepted, LinuxCNC's rs274: every arc turns
// as intended (a lead of 1 deg is not a full circle), stays in the swept range of a partial
// arc, and in a vertical plane never goes below the lowest point of that range.
void check_through_rs274(const CircleTestSpec& spec, GridOutcome& outcome) {
  TestProgram program;
  try {
    program = generate_test_program(spec);
  } catch (const UsageError&) {
    ++outcome.refused;
    return;
  }
  ++outcome.accepted;
  const Rs274Result rs = run_rs274(program.text);
  ASSERT_EQ(rs.exit_code, 0) << rs.output;
  ASSERT_TRUE(rs.canon.ended);
  const bool inch = spec.units == LengthUnit::inch;
  const double per_mm = inch ? 1.0 / 25.4 : 1.0;
  const double tol = 2e-4;  // rs274 prints 4 decimals; circgen writes 4 (5 in inch)
  const std::vector<IntendedArc> intended = intended_arcs(spec, per_mm);
  std::vector<const CanonMotion*> arcs;
  for (const CanonMotion& m : rs.canon.motions)
    if (m.kind == CanonMotion::arc) arcs.push_back(&m);
  ASSERT_EQ(arcs.size(), intended.size()) << program.text;

  const double low = spec.start_deg - spec.lead_deg;
  const double span = spec.arc_deg + 2.0 * spec.lead_deg;
  const bool partial = span < 360.0;
  const double centre_z = spec.centre_mm[2] * per_mm;
  for (std::size_t i = 0; i < arcs.size(); ++i) {
    const CanonMotion& m = *arcs[i];
    const double r = intended[i].radius;
    SCOPED_TRACE("arc " + std::to_string(i + 1) + ", canon line " + std::to_string(m.source_line));
    const double tol_deg = 0.01 + 2.0 * tol / r * 180.0 / std::numbers::pi;
    EXPECT_NEAR(m.sweep_deg(), intended[i].sweep_deg, tol_deg);
    EXPECT_NEAR(m.radius_start(), r, tol);
    EXPECT_NEAR(m.radius_end(), r, tol);
    // The lowest point the test may reach: of the swept range on this arc's circle.
    double lowest = centre_z - r;
    if (partial) {
      lowest = std::min(height(spec.plane, centre_z, r, low),
                        height(spec.plane, centre_z, r, low + span));
      for (double a = low; a <= low + span; a += 0.01)
        lowest = std::min(lowest, height(spec.plane, centre_z, r, a));
    }
    // The first point of the arc outside the range, or below its lowest point.
    for (int k = 0; k <= 64; ++k) {
      const double a = m.start_angle_deg() + m.sweep_deg() * k / 64.0;
      const bool outside = partial && wrap360(a - low + tol_deg) - tol_deg > span + tol_deg;
      const bool below =
          spec.plane != Plane::XY && height(spec.plane, centre_z, r, a) < lowest - tol;
      if (outside || below) {
        ADD_FAILURE() << (outside ? "outside the swept range" : "below its lowest point") << " at "
                      << a << " deg";
        break;
      }
    }
  }
}

// The property over a grid of small and large leads, arcs, diameters, planes, directions,
// units and instruments: whatever circgen accepts, the interpreter runs as intended. Leads
// under 1 deg once passed and were written as full circles on a small circle.
// Each direction runs alone with two feeds: a CCW sweep has CCW lead and measured arcs and a
// CW way back, a CW one the reverse. Both directions back to back (one feed) would write
// nothing new: the CCW run's arcs are the CCW sweep's first run, the CW run's the CW sweep's
// (same start points, same words), the join between them no arc (and the acceptance does not
// depend on the directions); the variants above run both back to back.
TEST(Rs274Grid, EveryAcceptedLeadAndArcTurnsAsIntended) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  GridOutcome outcome;
  const std::vector<double> leads{0.0001, 0.01, 0.5,   0.999,    1,  45,
                                  89.5,   89.9, 179.5, 179.9999, 180};
  for (Plane plane : {Plane::XY, Plane::YZ, Plane::ZX}) {
    for (double diameter : {1.0, 100.0, 10000.0}) {
      // The largest circle once, in XY: its words are the longest, the turns the same.
      if (diameter > 100.0 && plane != Plane::XY) continue;
      for (double arc : {90.0, 180.0, 358.0, 360.0}) {
        for (double lead : leads) {
          for (int dirs = 1; dirs < 3; ++dirs) {
            // The longest words in one sense: both senses of arc are in that sweep.
            if (diameter > 100.0 && dirs == 2) continue;
            CircleTestSpec spec;
            spec.plane = plane;
            spec.radius_mm = diameter / 2.0;
            spec.arc_deg = arc;
            spec.lead_deg = lead;
            spec.start_deg = default_start_deg(plane, arc);
            spec.centre_mm = {3.0, -2.0, 1.0};
            // A single direction with two feeds runs back to the lead-in start between them.
            spec.directions = dirs == 1 ? std::vector<Direction>{Direction::CCW}
                                        : std::vector<Direction>{Direction::CW};
            spec.feeds_mm_per_min = {300.0, 600.0};
            // Inch on the smallest circle, where the written digits are coarsest.
            spec.units = diameter == 1.0 && dirs == 1 ? LengthUnit::inch : LengthUnit::mm;
            SCOPED_TRACE(fmt_case(spec));
            check_through_rs274(spec, outcome);
          }
        }
      }
    }
  }
  for (Plane plane : {Plane::XY, Plane::ZX}) {
    for (double diameter : {100.0, 1200.0}) {
      for (double arc : {180.0, 360.0}) {
        for (double lead : leads) {
          CircleTestSpec spec;
          spec.instrument = Instrument::ballbar;
          spec.plane = plane;
          spec.radius_mm = diameter / 2.0;
          spec.arc_deg = arc;
          spec.lead_deg = lead;
          spec.start_deg = default_start_deg(plane, arc);
          spec.directions = {Direction::CCW};
          spec.feeds_mm_per_min = {500.0, 1000.0};
          SCOPED_TRACE(fmt_case(spec));
          check_through_rs274(spec, outcome);
        }
      }
    }
  }
  // Start angles at and near the ends of their range, where angles wrap.
  for (Plane plane : {Plane::XY, Plane::ZX}) {
    for (double start : {-360.0, -0.0001, 123.456, 359.9999, 360.0}) {
      for (double arc : {90.0, 360.0}) {
        for (double lead : {1.0, 45.0}) {
          for (double diameter : {1.0, 100.0}) {
            CircleTestSpec spec;
            spec.plane = plane;
            spec.radius_mm = diameter / 2.0;
            spec.arc_deg = arc;
            spec.lead_deg = lead;
            spec.start_deg = start;
            spec.directions = {Direction::CW};
            spec.feeds_mm_per_min = {300.0, 600.0};
            SCOPED_TRACE(fmt_case(spec));
            check_through_rs274(spec, outcome);
          }
        }
      }
    }
  }
  // Both outcomes occur: the grid reaches past the limits on both sides.
  std::cout << outcome.accepted << " accepted, " << outcome.refused << " refused\n";
  EXPECT_GT(outcome.accepted, 200);
  EXPECT_GT(outcome.refused, 300);
}

}  // namespace
}  // namespace circtest::testing
