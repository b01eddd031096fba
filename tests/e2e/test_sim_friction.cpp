// Friction compensation proven on the simulated servo mill (configs/sim-servo: circdrive's
// Coulomb friction and stiction make the reversal spikes, docs/sim-servo.md) in the real
// LinuxCNC: circgen's circle, circana diagnose on the logged table positions, circcomp plan +
// apply of the friction correction alone (circfric spliced in by circtest-fric.hal, step 1),
// the circle again, step 2 when more than 30 % of a spike is left, and the circle again. Then
// a slow jog over a reversal with the compensator on, circfric's pins logged beside the table.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "circtest/core/trace.hpp"
#include "linuxcnc_test.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using circtest::testing::run_command;
using nlohmann::json;

namespace {

// The circle: D150 at F1000, the size and feed the spike was characterised on (a smaller
// circle at the same feed reverses with a larger acceleration, where the stick is shorter
// than the lag of the untuned loop and a command pulse can cancel less of it).
constexpr const char* kDiameter = "150";
constexpr const char* kFeed = "1000";
// A spike below this is none (circcomp's threshold, kMinFrictionSpikeMm).
constexpr double kSpikeMm = 0.002;

// The axis' spike from circana, 0 when not found (null).
double spike_mm(const json& d, const std::string& axis) {
  const json& s = d["reversal_spike_mm"][axis];
  return s.is_null() ? 0.0 : s.get<double>();
}

double num(const json& v) {
  return v.is_null() ? NAN : v.get<double>();
}

double worst_g(const json& analysis) {
  double g = 0;
  for (const auto& run : analysis["runs"]) g = std::max(g, run["G"].get<double>());
  return g;
}

class SimFriction : public circtest::testing::LinuxcncTest {
 protected:
  SimFriction() : LinuxcncTest("friction", {"circlog.so", "circdrive.so", "circfric.so"}) {}
  void SetUp() override {
    LinuxcncTest::SetUp();
    if (IsSkipped()) return;
    // The machine as circcomp meets it: a folder of its own (links followed, as circtest-run
    // copies it), edited only by circcomp and the INI tool.
    fs::create_directories(out_ / "machine");
    for (const auto& e : fs::directory_iterator(fs::path(CIRCTEST_SERVO_INI).parent_path())) {
      fs::copy_file(fs::canonical(e.path()), out_ / "machine" / e.path().filename());
    }
    ini_ = (out_ / "machine" / "sim-servo.ini").string();
  }

  void set(const std::string& section, const std::string& key, const std::string& value) {
    const auto r = run_command({CIRCTEST_INI_PATH, "set", ini_, section, key, value});
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }

  // Runs PROGRAM on the configuration as it is now into out_/NAME.
  void run(const std::string& name, const fs::path& program) {
    const auto r = circtest::testing::run_linuxcnc(CIRCTEST_RUN_PATH, CIRCTEST_BINARY_DIR,
                                                   {ini_, program, out_ / name});
    ASSERT_EQ(r.command.exit_code, 0) << r.log;
  }

  json circana(const std::string& command, const std::string& name) {
    return circtest::testing::circana_json(CIRCANA_PATH, command, out_ / name / "trace.csv",
                                           out_ / (name + "-" + command + ".json"));
  }

  // circcomp apply of the friction correction alone from NAME's diagnosis.
  void apply_friction(const std::string& name) {
    const std::string djson = (out_ / (name + "-diagnose.json")).string();
    const auto plan =
        run_command({CIRCCOMP_PATH, "plan", "--ini", ini_, djson, "--only", "friction"});
    ASSERT_EQ(plan.exit_code, 0) << plan.out << plan.err;
    std::printf("circcomp plan after %s:\n%s", name.c_str(), plan.out.c_str());
    const auto r = run_command({CIRCCOMP_PATH, "apply", "--ini", ini_, djson, "--only", "friction"},
                               {std::string("CIRCTEST_FRIC_MODULE=") + CIRCTEST_BINARY_DIR +
                                "/hal-component/circfric.so"});
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  }

  struct Measurement {
    json analysis, diagnosis;
  };
  Measurement measure(const std::string& name) {
    run(name, out_ / "circle.ngc");
    if (HasFatalFailure()) return {};
    Measurement m{circana("analyze", name), circana("diagnose", name)};
    const json& d = m.diagnosis;
    std::printf(
        "%s: spike X %.2f um / %.0f ms, Y %.2f um / %.0f ms; G %.2f um (worst run), H %.2f um; "
        "backlash X %.2f um, Y %.2f um; residual G %.2f um\n",
        name.c_str(), spike_mm(d, "X") * 1e3, num(d["reversal_spike_ms"]["X"]),
        spike_mm(d, "Y") * 1e3, num(d["reversal_spike_ms"]["Y"]), worst_g(m.analysis) * 1e3,
        num(m.analysis["H"]) * 1e3, num(d["backlash_mm"]["X"]) * 1e3,
        num(d["backlash_mm"]["Y"]) * 1e3, num(d["residual"]["G_mm"]) * 1e3);
    return m;
  }

  std::string ini_;
};

// The slow jog: circfric's reversal count and offset logged beside the table (two more
// circlog channels, in a HAL file loaded after circtest-fric.hal).
void add_jog_probe(const fs::path& machine, const std::string& ini) {
  using circtest::testing::slurp;
  using circtest::testing::spit;
  std::string log = slurp(machine / "circlog.hal");
  const std::string from = "channels=9";
  ASSERT_NE(log.find(from), std::string::npos);
  log.replace(log.find(from), from.size(), "channels=11");
  spit(machine / "circlog.hal", log);
  spit(machine / "jog-probe.hal",
       "loadrt conv_u32_float names=fric-x-count\n"
       "addf fric-x-count servo-thread\n"
       "net fric-x-reversals fric-x.reversals => fric-x-count.in\n"
       "net fric-x-count fric-x-count.out => circlog.0.in-09\n"
       "net fric-x-offset fric-x.offset => circlog.0.in-10\n");
  std::string text = slurp(ini);
  const std::string hal = "HALFILE = circtest-fric.hal\n";
  ASSERT_NE(text.find(hal), std::string::npos);
  text.replace(text.find(hal), hal.size(), hal + "HALFILE = jog-probe.hal\n");
  const std::string cols = "COLUMNS = x_cmd,y_cmd,z_cmd,x_fb,y_fb,z_fb,x,y,z\n";
  ASSERT_NE(text.find(cols), std::string::npos);
  text.replace(text.find(cols), cols.size(),
               "COLUMNS = x_cmd,y_cmd,z_cmd,x_fb,y_fb,z_fb,x,y,z,fric_x_count,fric_x_offset\n");
  spit(ini, text);
}

}  // namespace

TEST_F(SimFriction, SpikesFallByTheCompensationAndASlowJogDoesNotExciteIt) {
  const auto g = run_command({CIRCGEN_PATH, "--d", kDiameter, "--f", kFeed, "--ini", ini_, "-o",
                              (out_ / "circle.ngc").string()});
  ASSERT_EQ(g.exit_code, 0) << g.err;

  const Measurement before = measure("before");
  ASSERT_FALSE(HasFatalFailure());
  std::vector<std::string> spiking;
  for (const char* axis : {"X", "Y"}) {
    if (spike_mm(before.diagnosis, axis) >= kSpikeMm) spiking.push_back(axis);
  }
  ASSERT_FALSE(spiking.empty()) << "sim-servo's friction makes no spike of 2 um or more";

  apply_friction("before");
  ASSERT_FALSE(HasFatalFailure());
  Measurement after = measure("step1");
  ASSERT_FALSE(HasFatalFailure());
  bool step2 = false;
  for (const auto& axis : spiking) {
    step2 |= std::abs(spike_mm(after.diagnosis, axis)) > 0.3 * spike_mm(before.diagnosis, axis);
  }
  if (step2) {
    apply_friction("step1");
    ASSERT_FALSE(HasFatalFailure());
    after = measure("step2");
    ASSERT_FALSE(HasFatalFailure());
  }

  for (const auto& axis : spiking) {
    const double s0 = spike_mm(before.diagnosis, axis), s1 = spike_mm(after.diagnosis, axis);
    std::printf("spike %s: %.2f -> %.2f um (%.0f %% left)\n", axis.c_str(), s0 * 1e3, s1 * 1e3,
                100.0 * std::abs(s1) / s0);
    EXPECT_LE(std::abs(s1), 0.3 * s0) << "the spike of " << axis << " falls by 70 % or more";
  }
  // G falls: the spikes sit at the quadrants, so each run's G falls where a spike made one of
  // its extremes. On this machine the servo mismatch's ellipse and the squareness make the
  // CCW run's extremes at 45 deg, away from the reversals: that run's G stays (within 0.5 um,
  // what the timing of a loaded host moves it), the CW run's falls. Before the compensation
  // the diagnosis explains the circle, the spikes as their measured profiles: its residual G
  // is at most 15 % of the largest G of the runs.
  double sum0 = 0, sum1 = 0, max0 = 0;
  for (std::size_t r = 0; r < before.analysis["runs"].size(); ++r) {
    const double g0 = before.analysis["runs"][r]["G"].get<double>();
    const double g1 = after.analysis["runs"][r]["G"].get<double>();
    std::printf("G run %zu: %.2f -> %.2f um\n", r, g0 * 1e3, g1 * 1e3);
    EXPECT_LE(g1, g0 + 0.5e-3) << "run " << r << ": G not worse";
    sum0 += g0;
    sum1 += g1;
    max0 = std::max(max0, g0);
  }
  EXPECT_LT(sum1, sum0 - 1e-3) << "G falls (the runs' G summed, by 1 um or more)";
  const double rg0 = num(before.diagnosis["residual"]["G_mm"]);
  const double rg1 = num(after.diagnosis["residual"]["G_mm"]);
  std::printf("H %.2f -> %.2f um; residual G %.2f -> %.2f um\n", num(before.analysis["H"]) * 1e3,
              num(after.analysis["H"]) * 1e3, rg0 * 1e3, rg1 * 1e3);
  EXPECT_LE(rg0, 0.15 * max0) << "the model explains the circle before the compensation";
  // Backlash is the play between motor and table (10 um on X): the pulse acts before the
  // play, so the fitted play stays within 1 um (the fit shares the samples just after the
  // reversal with the spike, whose shape the compensation changes).
  for (const char* axis : {"X", "Y"}) {
    EXPECT_NEAR(num(after.diagnosis["backlash_mm"][axis]),
                num(before.diagnosis["backlash_mm"][axis]), 1e-3)
        << "backlash " << axis;
  }
  // H (the runs' hysteresis, CCW against CW) is made by the play and the lag, which the
  // compensation does not touch: not more than 1 um worse (the spikes sit at the same
  // quadrants in both directions, so their change moves H by less than that).
  EXPECT_LE(num(after.analysis["H"]), num(before.analysis["H"]) + 1e-3) << "H not worse";

  // The slow jog over a reversal of X at F10 with the compensator as tuned: circfric counts
  // the one real reversal, its offset decays to exactly 0, and the table comes to rest.
  add_jog_probe(out_ / "machine", ini_);
  ASSERT_FALSE(HasFatalFailure());
  circtest::testing::spit(out_ / "jog.ngc",
                          "G21 G90 G17 G94\n"
                          "G1 X0 Y0 F1000\n"
                          "M67 E0 Q1\n"
                          "M62 P0\n"
                          "G1 X0.1 F10\n"
                          "G1 X0 F10\n"
                          "G4 P1.5\n"
                          "G1 X-0.001 F10\n"
                          "M63 P0\n"
                          "M67 E0 Q0\n"
                          "M2\n");
  run("jog", out_ / "jog.ngc");
  ASSERT_FALSE(HasFatalFailure());
  const circtest::Trace t = circtest::read_trace((out_ / "jog" / "trace.csv").string());
  const auto* count = t.column("fric_x_count");
  const auto* offset = t.column("fric_x_offset");
  const auto* x = t.column("x");
  const auto* xc = t.column("x_cmd");
  ASSERT_TRUE(count && offset && x && xc);
  ASSERT_GT(t.rows(), 2000u);
  // The commanded reversals: sign changes of x_cmd's steps beyond 1 nm.
  int real = 0, last = 0;
  for (std::size_t i = 1; i < t.rows(); ++i) {
    const double d = (*xc)[i] - (*xc)[i - 1];
    const int s = d > 1e-6 ? 1 : (d < -1e-6 ? -1 : 0);
    if (s != 0 && last != 0 && s != last) ++real;
    if (s != 0) last = s;
  }
  const double counted = (*count)[t.rows() - 1] - (*count)[0];
  double offset_max = 0;
  for (std::size_t i = 0; i < t.rows(); ++i)
    offset_max = std::max(offset_max, std::abs((*offset)[i]));
  // The dwell: the longest stretch of an unchanged command; its last half second.
  const std::size_t n = t.rows();
  std::size_t dwell_end = 0, best = 0;
  for (std::size_t i = 1, run = 0; i < n; ++i) {
    run = (*xc)[i] == (*xc)[i - 1] ? run + 1 : 0;
    if (run > best) {
      best = run;
      dwell_end = i + 1;
    }
  }
  ASSERT_GT(best, 1000u) << "no dwell of a second in the jog's trace";
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t i = dwell_end - 500; i < dwell_end; ++i) {
    lo = std::min(lo, (*x)[i]);
    hi = std::max(hi, (*x)[i]);
  }
  std::printf(
      "jog F10: %d real reversal(s), circfric counted %.0f; offset max %.3f um, last "
      "%.6f um; table range over the dwell's last 0.5 s %.4f um\n",
      real, counted, offset_max * 1e3, (*offset)[dwell_end - 1] * 1e3, (hi - lo) * 1e3);
  EXPECT_EQ(real, 1) << "the program reverses X once (out, back, onward the same way)";
  EXPECT_EQ(counted, real) << "one pulse per real reversal, none from the crawl itself";
  EXPECT_EQ((*offset)[dwell_end - 1], 0.0) << "the pulse has ended";
  EXPECT_LT(hi - lo, 0.1e-3) << "the table is at rest: no limit cycle";
}
