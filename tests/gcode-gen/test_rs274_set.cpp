// Test sets (several planes in one program) through LinuxCNC's real interpreter (rs274 -g):
// every ordered subset of the planes with every instrument.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/plane.hpp"
#include "rs274_variants.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

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

}  // namespace
}  // namespace circtest::testing
