// A clearance keeps every rapid out of the circle whose instrument is set up: in each plane
// and on the way between the planes of a set, in every order. The truth is LinuxCNC's
// interpreter (rs274): where it leaves the tool after each plane, and the rapids it runs.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "circtest/core/plane.hpp"
#include "circtest/gcode/generator.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

constexpr double kRadius = 100.0;
const std::array<double, 3> kCentre{10.0, -20.0, 30.0};  // x, y, z

// What is set up in a plane when its approach starts (docs/circgen.md "Test sets"): a grid
// plate over the circle; a ballbar's pivot and base at the centre, kept as far clear as its
// default clearance (the bar is mounted after the approach).
double reach(const std::string& instrument) {
  return instrument == "ballbar" ? kBallbarDefaultClearanceMm : kRadius;
}

std::string plane_list(const std::vector<Plane>& planes) {
  std::string text;
  for (Plane p : planes) text += (text.empty() ? "" : ",") + std::string(plane_name(p));
  return text;
}

std::string number_list(const std::vector<double>& values) {
  std::string text;
  for (double v : values) text += (text.empty() ? "" : ",") + fmt::format("{}", v);
  return text;
}

std::vector<std::string> set_args(const std::vector<Plane>& planes,
                                  const std::vector<double>& clearances,
                                  const std::string& instrument) {
  return {"--plane",      plane_list(planes), "--d",       "200",         "--f",
          "500",          "--centre",         "10,-20,30", "--clearance", number_list(clearances),
          "--instrument", instrument};
}

// Where the straight move from a to b crosses (or touches) the plane's circle plane, as the
// distance from the circle's centre in the plane; none when it stays on one side.
std::optional<double> crossing(Plane plane, const std::array<double, 3>& a,
                               const std::array<double, 3>& b) {
  const PlaneAxes axes = plane_axes(plane);
  const int n = axes.normal - 'x', f = axes.first - 'x', s = axes.second - 'x';
  const double da = a[n] - kCentre[n], db = b[n] - kCentre[n];
  constexpr double kOn = 1e-6;
  if ((da > kOn && db > kOn) || (da < -kOn && db < -kOn)) return std::nullopt;
  const double t = std::abs(db - da) < 1e-12 ? 0.0 : da / (da - db);
  auto at = [&](int i) { return a[i] + std::clamp(t, 0.0, 1.0) * (b[i] - a[i]); };
  return std::hypot(at(f) - kCentre[f], at(s) - kCentre[s]);
}

// Where one plane's program leaves the tool, as rs274 runs it.
std::array<double, 3> end_point(Plane plane, double clearance, const std::string& instrument) {
  const CommandResult gen = run_circgen(set_args({plane}, {clearance}, instrument));
  EXPECT_EQ(gen.exit_code, 0) << gen.err;
  const Rs274Result rs = run_rs274(gen.out);
  EXPECT_EQ(rs.exit_code, 0) << rs.output;
  if (rs.canon.motions.empty()) return {};
  return rs.canon.motions.back().end;
}

struct Tally {
  int accepted = 0;
  int refused = 0;
  int interpreted = 0;  // accepted sets run through rs274
};

// A plane's part of a program writes its own moves from its own spec alone; its rapids start
// where the plane before left the tool. So the rapids of plane k depend on plane k's (plane,
// clearance) and on those of the plane before it: what rs274 has shown for one such
// neighbouring pair (and for a first plane) it shows again for every set that holds it.
using PlaneClearance = std::pair<Plane, double>;
using Neighbours = std::pair<std::optional<PlaneClearance>, PlaneClearance>;

// One set: refused exactly when the rapid from where the plane before left the tool to the
// next plane's clearance passes through the next circle; when accepted (and it holds a
// neighbouring pair not yet run), no rapid after a plane's pause passes through that plane's
// circle as rs274 runs the program.
void check_set(const std::vector<Plane>& planes, const std::vector<double>& clearances,
               const std::string& instrument,
               std::map<std::pair<Plane, double>, std::array<double, 3>>& ends, Tally& tally,
               std::set<Neighbours>& interpreted) {
  const std::vector<std::string> args = set_args(planes, clearances, instrument);
  SCOPED_TRACE(plane_list(planes) + " --clearance " + number_list(clearances) + " " + instrument);
  std::optional<std::size_t> first_bad;
  for (std::size_t k = 1; k < planes.size() && !first_bad; ++k) {
    const auto key = std::make_pair(planes[k - 1], clearances[k - 1]);
    if (!ends.count(key)) ends[key] = end_point(planes[k - 1], clearances[k - 1], instrument);
    std::array<double, 3> to = ends[key];
    to[plane_axes(planes[k]).normal - 'x'] = clearances[k];
    const auto at = crossing(planes[k], ends[key], to);
    if (at && *at <= reach(instrument) + 1e-3) first_bad = k;
  }
  const CommandResult gen = run_circgen(args);
  if (first_bad) {
    ++tally.refused;
    EXPECT_EQ(gen.exit_code, 2) << gen.out.substr(0, 200);
    const std::string names =
        std::string(plane_name(planes[*first_bad - 1])) + " leaves the tool at";
    EXPECT_NE(gen.err.find(names), std::string::npos) << gen.err;
    EXPECT_NE(gen.err.find("the " + std::string(plane_name(planes[*first_bad])) + " clearance"),
              std::string::npos)
        << gen.err;
    return;
  }
  ++tally.accepted;
  ASSERT_EQ(gen.exit_code, 0) << gen.err;
  // Through rs274 when the set holds a neighbouring pair (or a first plane) no set before it
  // brought there.
  bool fresh = false;
  for (std::size_t k = 0; k < planes.size(); ++k) {
    Neighbours pair{std::nullopt, {planes[k], clearances[k]}};
    if (k > 0) pair.first = PlaneClearance{planes[k - 1], clearances[k - 1]};
    fresh = interpreted.insert(pair).second || fresh;
  }
  if (!fresh) return;
  ++tally.interpreted;
  const Rs274Result rs = run_rs274(gen.out);
  ASSERT_EQ(rs.exit_code, 0) << rs.output;
  // Each plane's section: from its pause (the M0 after its "plane k of N" message) on.
  std::vector<std::size_t> section;
  for (std::size_t k = 0; k < planes.size(); ++k) {
    const std::string words = "plane " + std::to_string(k + 1) + " of " +
                              std::to_string(planes.size()) + ": " +
                              std::string(plane_name(planes[k]));
    for (const CanonCall& call : rs.canon.call_log) {
      if (call.name == "MESSAGE" && call.args.find(words) != std::string::npos) {
        section.push_back(call.motions_before);
        break;
      }
    }
    ASSERT_EQ(section.size(), k + 1) << words;
  }
  section.push_back(rs.canon.motions.size());
  for (std::size_t k = 0; k < planes.size(); ++k) {
    // The first plane's first rapid starts wherever the operator left the tool.
    for (std::size_t i = section[k] + (k == 0 ? 1 : 0); i < section[k + 1]; ++i) {
      const CanonMotion& m = rs.canon.motions[i];
      if (m.kind != CanonMotion::traverse) continue;
      const auto at = crossing(planes[k], m.start, m.end);
      EXPECT_FALSE(at && *at <= reach(instrument))
          << "a rapid through the " << plane_name(planes[k]) << " circle, " << *at
          << " mm from its centre, canon line " << m.source_line;
    }
  }
}

TEST(Rs274Clearance, EveryRapidOfEverySetOrderKeepsOutOfTheCircleSetUp) {
  if (!rs274_available()) GTEST_SKIP() << "rs274 not installed (linuxcnc-uspace)";
  // Clearances relative to the centre on each plane's normal axis: above an XY circle only
  // (below is refused on its own), on either side of a YZ or ZX one, near and far.
  const std::map<Plane, std::vector<double>> offsets{{Plane::XY, {10.0, 120.0}},
                                                     {Plane::YZ, {-120.0, -30.0, 30.0, 120.0}},
                                                     {Plane::ZX, {-120.0, -30.0, 30.0, 120.0}}};
  std::vector<std::vector<Plane>> orders;
  std::vector<Plane> all{Plane::XY, Plane::YZ, Plane::ZX};
  do orders.push_back(all);
  while (std::next_permutation(all.begin(), all.end(), [](Plane a, Plane b) {
    return static_cast<int>(a) < static_cast<int>(b);
  }));
  ASSERT_EQ(orders.size(), 6u);
  Tally tally;
  for (const std::string instrument : {"grid", "ballbar"}) {
    std::map<std::pair<Plane, double>, std::array<double, 3>> ends;
    std::set<Neighbours> interpreted;
    for (const auto& planes : orders) {
      for (double a : offsets.at(planes[0])) {
        for (double b : offsets.at(planes[1])) {
          for (double c : offsets.at(planes[2])) {
            std::vector<double> clearances{a, b, c};
            for (std::size_t k = 0; k < 3; ++k)
              clearances[k] += kCentre[plane_axes(planes[k]).normal - 'x'];
            ASSERT_NO_FATAL_FAILURE(
                check_set(planes, clearances, instrument, ends, tally, interpreted));
          }
        }
      }
    }
  }
  std::printf("sets accepted %d (%d through rs274), refused %d\n", tally.accepted,
              tally.interpreted, tally.refused);
  // Both outcomes occur often: the check is neither always on nor always off.
  EXPECT_GT(tally.accepted, 50);
  EXPECT_GT(tally.refused, 50);
}

// In YZ and ZX a clearance in the circle's own plane is refused, naming the plane; the case
// the probe found is one of them (circgen would rapid through the YZ circle).
TEST(Rs274Clearance, AClearanceInTheCirclesOwnPlaneIsRefusedInEveryPlane) {
  const CommandResult probe =
      run_circgen({"--plane", "XY,YZ,ZX", "--centre", "50,50,0", "--clearance", "50",
                   "--instrument", "grid", "--d", "100", "--f", "500"});
  EXPECT_EQ(probe.exit_code, 2);
  EXPECT_EQ(probe.err,
            "circgen: error: --clearance: X 50 mm is the YZ circle's own plane (X 50 mm): the "
            "clearance in YZ must be beside it, on either side\n");
  struct Case {
    std::string plane, centre, clearance, words;
  };
  for (const Case& c : std::vector<Case>{
           {"XY", "1,2,3", "3", "Z 3 mm is not above the circle's height Z 3 mm"},
           {"YZ", "1,2,3", "1", "X 1 mm is the YZ circle's own plane (X 1 mm)"},
           {"ZX", "1,2,3", "2", "Y 2 mm is the ZX circle's own plane (Y 2 mm)"},
           {"YZ", "1,2,3", "1.00001", "X 1 mm is the YZ circle's own plane (X 1 mm)"}}) {
    SCOPED_TRACE(c.plane + " " + c.clearance);
    const CommandResult r = run_circgen({"--plane", c.plane, "--centre", c.centre, "--clearance",
                                         c.clearance, "--d", "100", "--f", "500"});
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("--clearance: " + c.words), std::string::npos) << r.err;
  }
  // In the user's units with --inch.
  const CommandResult inch = run_circgen({"--inch", "--plane", "ZX", "--centre", "0,1,0",
                                          "--clearance", "1", "--d", "4", "--f", "20"});
  EXPECT_EQ(inch.exit_code, 2);
  EXPECT_NE(inch.err.find("--clearance: Y 1 in is the ZX circle's own plane (Y 1 in)"),
            std::string::npos)
      << inch.err;
  // Between the planes: the rapid from where XY leaves the tool to the YZ clearance.
  const CommandResult between = run_circgen({"--d", "100", "--f", "500", "--plane", "XY,YZ",
                                             "--centre", "50,50,0", "--clearance", "10,-50"});
  EXPECT_EQ(between.exit_code, 2);
  EXPECT_EQ(between.err,
            "circgen: error: --clearance: XY leaves the tool at X99.2404 Y41.3176 Z10 mm; the "
            "rapid on X from there to the YZ clearance X -50 mm passes through the YZ circle's "
            "plane 13.2433 mm from its centre, inside its radius 50 mm: give clearances that keep "
            "the tool on one side of the YZ circle, or another plane order\n");
  // Off the plane by one written digit is beside it.
  EXPECT_EQ(run_circgen({"--plane", "YZ", "--centre", "1,2,3", "--clearance", "1.0001", "--d",
                         "100", "--f", "500"})
                .exit_code,
            0);
}

}  // namespace
}  // namespace circtest::testing
