// The safe program structure of every circgen variant (rs274_variants.hpp) through LinuxCNC's
// real interpreter (rs274 -g), from its canonical calls.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/plane.hpp"
#include "rs274_variants.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

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

}  // namespace
}  // namespace circtest::testing
