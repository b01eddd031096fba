// The servo thread's late periods in a recorded trace (the servo_period channel circtest
// install adds): synthetic traces with jitter and known late periods inserted.
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"
#include "scratch.hpp"
#include "session_steps.hpp"

namespace fs = std::filesystem;
using namespace circtest;
using namespace circtest::session;
using circtest::testing::ScratchDir;

namespace {

// A trace of ROWS samples of a thread of NOMINAL_NS with +-20 us of jitter, the periods in
// LATE (row -> ns) put in; SAMPLE_PERIOD: whether the metadata states the thread's period.
std::string trace_text(std::size_t rows, double nominal_ns,
                       const std::vector<std::pair<std::size_t, double>>& late,
                       bool sample_period = true) {
  std::ostringstream t;
  t.precision(10);
  if (sample_period) t << "# sample_period_s: " << nominal_ns * 1e-9 << "\n";
  t << "t,period,x_fb,servo_period\n";
  for (std::size_t i = 0; i < rows; ++i) {
    double period_ns =
        nominal_ns + static_cast<double>(static_cast<int>((i * 37) % 41) - 20) * 1000;
    for (const auto& [row, ns] : late) {
      if (row == i) period_ns = ns;
    }
    t << static_cast<double>(i) * nominal_ns * 1e-9 << "," << i << ","
      << 0.001 * static_cast<double>(i) << "," << period_ns << "\n";
  }
  return t.str();
}

ServoPeriods periods_of(const std::string& text, std::optional<double> ini_ns = std::nullopt) {
  return servo_periods(parse_trace(text, "trace.csv"), ini_ns);
}

}  // namespace

TEST(ServoPeriods, LatePeriodsInsertedAreCountedWithTheLongest) {
  // Three late periods; 1500 us is 1.5 periods exactly (on time), 1499 us too.
  const ServoPeriods p = periods_of(trace_text(
      2000, 1e6, {{100, 1.6e6}, {500, 2.3e6}, {900, 3.0e6}, {1200, 1.5e6}, {1300, 1.499e6}}));
  EXPECT_TRUE(p.logged);
  EXPECT_EQ(p.samples, 2000u);
  EXPECT_DOUBLE_EQ(p.nominal_ns, 1e6);
  EXPECT_EQ(p.late, 3u);
  EXPECT_DOUBLE_EQ(p.longest_ns, 3.0e6);
  EXPECT_EQ(servo_period_line(p),
            "the servo thread missed its period 3 times (longest 3000 us of 1000 us): a latency "
            "problem of this PC, not a machine error; nothing applied from this run");
}

TEST(ServoPeriods, JitterAloneIsOnTime) {
  const ServoPeriods p = periods_of(trace_text(2000, 1e6, {}));
  EXPECT_EQ(p.late, 0u);
  EXPECT_DOUBLE_EQ(p.longest_ns, 1.02e6);  // the jitter's largest: +20 us
  EXPECT_EQ(servo_period_line(p),
            "the servo thread kept its period (2000 samples, longest 1020 us of 1000 us)");
}

TEST(ServoPeriods, CpuClocksAsLinuxCnc29CountsThemAreScaledByTheirMean) {
  // LinuxCNC 2.9's last-period: CPU clocks (2096 per us here). A 30 ms stall, then the thread
  // runs the 29 periods it owes back to back (3000 clocks each) and keeps its deadlines again.
  const double clocks_per_us = 2096;
  std::vector<std::pair<std::size_t, double>> stall = {{1000, 30000 * clocks_per_us}};
  for (std::size_t i = 1; i <= 29; ++i) stall.emplace_back(1000 + i, 3000);
  std::string text = trace_text(5000, 1e6 * clocks_per_us / 1000, stall);
  // The metadata states the thread's period in s: 1 ms.
  text.replace(text.find("# sample_period_s: ") + 19, text.find('\n') - 19, "0.001");
  const ServoPeriods p = periods_of(text);
  EXPECT_FALSE(p.unit_is_ns);
  EXPECT_NEAR(p.units_per_us, clocks_per_us, 0.01 * clocks_per_us);
  EXPECT_EQ(p.late, 1u);
  EXPECT_NEAR(p.longest_ns / 1000, 30000, 300);  // 30 ms, within the mean's 1 %
}

TEST(ServoPeriods, TheIniPeriodWhenTheTraceDoesNotStateIt) {
  // A 2 ms thread: 2.5 ms is on time, 3.5 ms late.
  const std::string text = trace_text(500, 2e6, {{10, 2.5e6}, {20, 3.5e6}}, false);
  const ServoPeriods p = periods_of(text, 2e6);
  EXPECT_DOUBLE_EQ(p.nominal_ns, 2e6);
  EXPECT_EQ(p.late, 1u);
  EXPECT_THROW(periods_of(text), DataError);  // neither states it: no guess
}

TEST(ServoPeriods, ATraceWithoutTheChannelIsNotJudged) {
  const ServoPeriods p = periods_of("# sample_period_s: 0.001\nt,x_fb\n0,1\n0.001,1\n");
  EXPECT_FALSE(p.logged);
  EXPECT_EQ(p.late, 0u);
  EXPECT_NE(servo_period_line(p).find("not logged"), std::string::npos);
}

TEST(ServoPeriods, TheSessionRefusesTheRunAndItsJsonSaysWhy) {
  ScratchDir scratch("session-servo");
  SessionSetup setup;
  const fs::path trace = scratch.dir() / "trace.csv";
  circtest::testing::spit(trace, trace_text(1000, 1e6, {{400, 5e6}, {401, 1.7e6}}));
  std::ostringstream out;
  EXPECT_EQ(check_servo_periods(setup, trace.string(), out), 5);
  EXPECT_EQ(out.str(),
            "circtest: the servo thread missed its period 2 times (longest 5000 us of 1000 us): a "
            "latency problem of this PC, not a machine error; nothing applied from this run\n");
  const auto j =
      nlohmann::json::parse(circtest::testing::slurp(scratch.dir() / "servo-period.json"));
  EXPECT_EQ(j["trace"], "trace.csv");
  EXPECT_EQ(j["late_periods"], 2);
  EXPECT_DOUBLE_EQ(j["longest_period_us"].get<double>(), 5000);
  EXPECT_DOUBLE_EQ(j["late_limit_us"].get<double>(), 1500);
  EXPECT_EQ(j["run_usable"], false);
  // verify's trace: its own file; on time: exit 0.
  const fs::path after = scratch.dir() / "verify-trace.csv";
  circtest::testing::spit(after, trace_text(1000, 1e6, {}));
  std::ostringstream out2;
  EXPECT_EQ(check_servo_periods(setup, after.string(), out2), 0);
  const auto j2 =
      nlohmann::json::parse(circtest::testing::slurp(scratch.dir() / "verify-servo-period.json"));
  EXPECT_EQ(j2["late_periods"], 0);
  EXPECT_EQ(j2["run_usable"], true);
  // A simulated machine whose INI says LATE_SERVO_PERIODS = note: said, the session goes on.
  setup.late_periods_noted = true;
  std::ostringstream out3;
  EXPECT_EQ(check_servo_periods(setup, trace.string(), out3), 0);
  EXPECT_NE(out3.str().find("missed its period 2 times (longest 5000 us of 1000 us): noted only"),
            std::string::npos)
      << out3.str();
}

TEST(ServoPeriods, TheIniSaysWhetherLatePeriodsStopTheSession) {
  ScratchDir scratch("session-servo");
  const fs::path ini = scratch.dir() / "m.ini";
  const std::string base =
      "[EMCMOT]\nSERVO_PERIOD = 1000000\n[CIRCTEST]\nCOLUMNS = x_fb\nMARKER_OUTPUT = 0\n";
  circtest::testing::spit(ini, base);
  EXPECT_FALSE(read_setup(ini.string()).late_periods_noted);
  EXPECT_DOUBLE_EQ(read_setup(ini.string()).servo_period_ns.value_or(0), 1e6);
  circtest::testing::spit(ini, base + "LATE_SERVO_PERIODS = note\n");
  EXPECT_TRUE(read_setup(ini.string()).late_periods_noted);
  circtest::testing::spit(ini, base + "LATE_SERVO_PERIODS = ignore\n");
  try {
    read_setup(ini.string());
    FAIL() << "expected a refusal";
  } catch (const DataError& e) {
    EXPECT_EQ(e.line(), 6u);
    EXPECT_NE(std::string(e.what()).find("expected refuse (a real machine) or note"),
              std::string::npos);
  }
}
