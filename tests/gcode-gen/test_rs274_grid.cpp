// A grid of leads, arcs, diameters, planes, directions, units and instruments through
// circgen's library and LinuxCNC's real interpreter (rs274 -g): whatever circgen accepts, the
// interpreter runs as intended.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/plane.hpp"
#include "circtest/gcode/generator.hpp"
#include "rs274_variants.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

std::string fmt_case(const CircleTestSpec& s) {
  std::ostringstream out;
  out << plane_name(s.plane) << " d " << 2.0 * s.radius_mm << " arc " << s.arc_deg << " lead "
      << s.lead_deg << " start " << s.start_deg << " " << instrument_name(s.instrument) << " "
      << s.directions.size() << " dir(s) " << s.feeds_mm_per_min.size() << " feed(s) "
      << length_unit_name(s.units);
  return out.str();
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
// depend on the directions); the variants (test_rs274.cpp) run both back to back.
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
