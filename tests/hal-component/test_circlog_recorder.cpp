// circlog-record's loop without HAL: a producer in heap memory runs the servo periods that
// pass while the recorder sleeps, on a fake clock, so every scenario is deterministic.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "circlog_kernel.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"
#include "fake_servo.hpp"
#include "options.hpp"
#include "pty_capture.hpp"
#include "recorder.hpp"
#include "scratch.hpp"

namespace {

namespace rec = circtest::circlog_record;
namespace fs = std::filesystem;
using circtest::testing::FakeServo;
using circtest::testing::Recorder;

rec::RecordRequest options_for(const std::string& output) {
  rec::RecordRequest o;
  o.output = output;
  o.poll_s = 0.005;
  return o;
}

std::optional<rec::RecordRequest> parse(std::vector<const char*> args) {
  args.insert(args.begin(), "circlog-record");
  std::FILE* out = std::tmpfile();
  auto o = rec::parse_options(static_cast<int>(args.size()), args.data(), out);
  std::fclose(out);
  return o;
}

TEST(CirclogRecordOptions, ParsesAndValidates) {
  const auto o = parse({"-o", "a.csv", "--columns", "x_cmd,y_cmd,x,y", "--duration", "2.5",
                        "--describe", "x=grid encoder X", "--until-idle", "0.5"});
  ASSERT_TRUE(o);
  EXPECT_EQ(o->output, "a.csv");
  EXPECT_EQ(o->columns, (std::vector<std::string>{"x_cmd", "y_cmd", "x", "y"}));
  EXPECT_EQ(*o->duration_s, 2.5);
  EXPECT_EQ(*o->idle_s, 0.5);
  ASSERT_EQ(o->descriptions.size(), 1u);
  EXPECT_EQ(o->descriptions[0].second, "grid encoder X");
  EXPECT_FALSE(parse({"--help"}));
}

// The clause 4.4 / 6 conditions: metadata keys of core/conditions, values checked.
TEST(CirclogRecordOptions, TestConditionsBecomeMetadataKeys) {
  const auto o =
      parse({"-o", "a.csv", "--machine", "VMC-3", "--serial", "SN 1234", "--instrument",
             "grid encoder KGM 182", "--operator", "A. Sato", "--location", "hall 2", "--t-machine",
             "21.5", "--t-instrument", " 20.25 ", "--notes", "after crash"});
  ASSERT_TRUE(o);
  using KV = std::pair<std::string, std::string>;
  EXPECT_EQ(o->conditions, (std::vector<KV>{{"machine", "VMC-3"},
                                            {"machine_serial", "SN 1234"},
                                            {"instrument", "grid encoder KGM 182"},
                                            {"operator", "A. Sato"},
                                            {"location", "hall 2"},
                                            {"temperature_machine_C", "21.5"},
                                            {"temperature_instrument_C", "20.25"},
                                            {"notes", "after crash"}}));
  EXPECT_THROW(parse({"-o", "a", "--t-machine", "warm"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--t-instrument", "inf"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--machine", "  "}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--notes", "two\nlines"}), circtest::UsageError);
}

// --condition KEY=VALUE: any other condition as a metadata key (circtest verify marks its
// trace so); the recorder's own keys, a channel's description, a named condition refused.
TEST(CirclogRecordOptions, AnotherConditionBecomesAMetadataKey) {
  const auto o = parse({"-o", "a.csv", "--condition", "circtest_step=verify", "--operator", "A",
                        "--condition", "coolant= off "});
  ASSERT_TRUE(o);
  using KV = std::pair<std::string, std::string>;
  EXPECT_EQ(o->conditions,
            (std::vector<KV>{{"operator", "A"}, {"circtest_step", "verify"}, {"coolant", "off"}}));
  for (const char* bad : {"novalue", "=verify", "circtest_step=", "two words=x", "rows=3",
                          "sample_period_s=0.001", "channel.x=grid", "machine=VMC"}) {
    EXPECT_THROW(parse({"-o", "a", "--condition", bad}), circtest::UsageError) << bad;
  }
  EXPECT_THROW(parse({"-o", "a", "--condition", "k=1", "--condition", "k=2"}),
               circtest::UsageError);
}

TEST(CirclogRecordOptions, RefusesBadValues) {
  EXPECT_THROW(parse({}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--columns", "x,x"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--columns", "x,,y"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--columns", "x,t"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--columns", "x y"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--duration", "0"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--duration", "nan"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--describe", "novalue"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--bogus"}), circtest::UsageError);
}

TEST_F(Recorder, ProgramHeaderStopsAtTheFirstLineOfCode) {
  std::ofstream(path("p.ngc")) << "%\n(plane: XY)\n( radius_mm : 50 )\n\n(Note: prose)\n"
                                  "(feed_mm_per_min: 1000)\nG21 G17\n(after: ignored)\n%\n";
  const auto h = rec::read_program_header(path("p.ngc"));
  ASSERT_EQ(h.size(), 3u);
  EXPECT_EQ(h[0], (std::pair<std::string, std::string>{"plane", "XY"}));
  EXPECT_EQ(h[1], (std::pair<std::string, std::string>{"radius_mm", "50"}));
  EXPECT_EQ(h[2].first, "feed_mm_per_min");
  EXPECT_THROW(rec::read_program_header(path("missing.ngc")), circtest::IoError);
}

// --program names a FIFO: refused unopened (opening it would wait for a writer), before any
// HAL work, with exit code io; --ini the same when the recording starts.
TEST_F(Recorder, AFifoAsTheProgramIsRefusedUnopened) {
  const std::string fifo = path("p.ngc");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    (void)parse({"-o", "a.csv", "--program", fifo.c_str()});
    FAIL() << "a FIFO was read as the program";
  } catch (const circtest::IoError& e) {
    EXPECT_EQ(std::string(e.what()), fifo + ": is a FIFO, not a regular file");
    EXPECT_EQ(e.code(), circtest::ExitCode::io);
  }
}

// circgen marks its header lines with a "circtest:" prefix; the key follows it.
TEST_F(Recorder, ProgramHeaderOfCircgenDropsTheCirctestPrefix) {
  std::ofstream(path("p.ngc")) << "(circtest: generator: circgen 0.1.0)\n(circtest: plane: ZX)\n"
                                  "(circtest: centre_mm: 1,2,3)\n(circtest: prose only)\nG21\n";
  const auto h = rec::read_program_header(path("p.ngc"));
  ASSERT_EQ(h.size(), 3u);
  EXPECT_EQ(h[0], (std::pair<std::string, std::string>{"generator", "circgen 0.1.0"}));
  EXPECT_EQ(h[1], (std::pair<std::string, std::string>{"plane", "ZX"}));
  EXPECT_EQ(h[2], (std::pair<std::string, std::string>{"centre_mm", "1,2,3"}));
}

TEST_F(Recorder, RecordsARunAndStopsWhenIdle) {
  FakeServo servo(2, 1024);
  servo.enable = [](std::uint64_t p) { return p >= 200 && p < 500; };
  servo.segment = [](std::uint64_t) { return 4.0; };
  rec::RecordRequest o = options_for(path("t.csv"));
  o.columns = {"x", "y"};
  o.descriptions = {{"x", "grid encoder"}};
  o.idle_s = 0.1;
  std::ofstream(path("p.ngc")) << "(plane: XY)\n(rows: 12)\n(machine: from program)\nG0 X0\n";
  o.program = path("p.ngc");
  o.program_plan = rec::read_program_plan(o.program);
  o.conditions = {{"machine", "VMC-3"}, {"temperature_machine_C", "21.5"}};
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.rows, 301u);  // 300 enabled periods and the one where enable fell
  EXPECT_EQ(s.runs, 1u);
  EXPECT_EQ(s.lost, 0u);
  EXPECT_EQ(s.stop_reason, "idle");
  EXPECT_FALSE(servo.status().reader_attached);
  EXPECT_FALSE(fs::exists(path("t.csv.part")));

  const circtest::Trace t = circtest::read_trace(path("t.csv"));
  EXPECT_EQ(t.columns, (std::vector<std::string>{"t", "period", "x", "y", "marker", "segment"}));
  ASSERT_EQ(t.rows(), 301u);
  EXPECT_EQ(t.column("period")->front(), 200.0);
  EXPECT_DOUBLE_EQ(t.column("t")->front(), 0.2);
  EXPECT_DOUBLE_EQ(t.column("y")->at(10), 210.001);
  EXPECT_EQ(t.column("marker")->back(), 0.0);
  EXPECT_EQ(t.column("segment")->front(), 4.0);
  const auto& m = t.metadata;
  EXPECT_EQ(*m.find("sample_period_s"), "0.001");
  EXPECT_EQ(*m.find("channels"), "x,y");
  EXPECT_EQ(*m.find("channel.x"), "grid encoder");
  EXPECT_EQ(*m.find("module.depth"), "1024");
  EXPECT_EQ(*m.find("plane"), "XY");
  EXPECT_EQ(*m.find("rows"), "301");  // the trailer, not the program's "rows: 12"
  EXPECT_EQ(*m.find("lost_samples"), "0");
  EXPECT_EQ(*m.find("start_time"), "2026-01-02T03:04:05.000Z");
  EXPECT_EQ(*m.find("machine"), "VMC-3");  // the command line wins over the program header
  EXPECT_EQ(*m.find("temperature_machine_C"), "21.5");
  std::size_t machine_lines = 0;
  for (const auto& [k, v] : m.entries()) machine_lines += k == "machine";
  EXPECT_EQ(machine_lines, 1u);
  EXPECT_NE(log_text().find("header key 'rows'"), std::string::npos);
}

// --live: while it records, the live copy holds the rows recorded up to at most 0.1 s before
// (the panel's live plot); at the end it is the trace's text.
TEST_F(Recorder, TheLiveCopyGrowsWhileItRecordsAndEndsAsTheTrace) {
  FakeServo servo(2, 4096);
  servo.enable = [](std::uint64_t p) { return p >= 100 && p < 2100; };
  rec::RecordRequest o = options_for(path("t.csv"));
  o.idle_s = 0.1;
  o.live = path("live.csv");
  std::vector<std::pair<double, std::size_t>> seen;  // fake time, rows in the live copy
  servo.on_sleep = [&] {
    if (!fs::exists(path("live.csv"))) return;
    const std::string text = circtest::testing::slurp(path("live.csv"));
    const auto lines = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
    seen.emplace_back(servo.monotonic_s(), lines);
  };
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.rows, 2001u);
  ASSERT_FALSE(seen.empty());
  const std::size_t header = seen.front().second;
  std::size_t in_between = 0;
  for (const auto& [t_s, lines] : seen) {
    const double recorded = std::clamp(t_s - 0.1, 0.0, 2.001);  // s of enabled periods so far
    const double rows = static_cast<double>(lines - header);
    EXPECT_LE(rows, recorded * 1000.0 + 2.0) << t_s;  // nothing ahead
    if (t_s < 2.0)
      EXPECT_GE(rows, (recorded - 0.1) * 1000.0 - 10.0) << t_s;  // at most 0.1 s behind
    in_between += rows > 0 && rows < 2001;
  }
  EXPECT_GT(in_between, 10u);
  EXPECT_EQ(circtest::testing::slurp(path("live.csv")), circtest::testing::slurp(path("t.csv")));
}

TEST_F(Recorder, ATinyRingLosesRecordsAndSaysSoEverywhere) {
  FakeServo servo(1, 4);
  servo.enable = [](std::uint64_t p) { return p >= 100 && p < 400; };
  rec::RecordRequest o = options_for(path("t.csv"));
  o.poll_s = 0.02;  // 20 periods between polls into a ring of 4
  o.idle_s = 0.05;
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_GT(s.lost, 0u);
  EXPECT_EQ(s.lost, s.overruns);
  EXPECT_EQ(s.overruns, servo.status().overruns);
  EXPECT_GT(s.gaps, 0u);
  EXPECT_EQ(s.rows + s.lost, 301u);
  const circtest::Trace t = circtest::read_trace(path("t.csv"));
  EXPECT_EQ(*t.metadata.find("lost_samples"), std::to_string(s.lost));
  EXPECT_EQ(*t.metadata.find("overruns"), std::to_string(s.overruns));
  EXPECT_EQ(*t.metadata.find("gaps"), std::to_string(s.gaps));
  const auto& period = *t.column("period");
  double jumps = 0;
  for (std::size_t i = 1; i < period.size(); ++i) jumps += period[i] - period[i - 1] - 1;
  EXPECT_GT(jumps, 0);
  EXPECT_NE(log_text().find("gap:"), std::string::npos);
}

TEST_F(Recorder, BackToBackRunsAndSegments) {
  FakeServo servo(1, 4096);
  // Run 1 (segment 1) 100-199, run 2 (segment 1) 250-349, segment 2 from 300 on.
  servo.enable = [](std::uint64_t p) { return (p >= 100 && p < 200) || (p >= 250 && p < 400); };
  servo.segment = [](std::uint64_t p) { return p < 300 ? 1.0 : 2.0; };
  rec::RecordRequest o = options_for(path("t.csv"));
  o.idle_s = 0.2;  // longer than the 50-period pause between the runs
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.runs, 2u);
  const circtest::Trace t = circtest::read_trace(path("t.csv"));
  const auto& marker = *t.column("marker");
  const auto& segment = *t.column("segment");
  ASSERT_EQ(t.rows(), 100u + 1 + 150 + 1);
  EXPECT_EQ(marker[100], 0.0);  // the period enable fell separates the two runs
  EXPECT_EQ(segment[100 + 1 + 49], 1.0);
  EXPECT_EQ(segment[100 + 1 + 50], 2.0);
}

TEST_F(Recorder, StopsAfterTheDurationInServoTime) {
  FakeServo servo(1, 4096);
  servo.enable = [](std::uint64_t) { return true; };
  rec::RecordRequest o = options_for(path("t.csv"));
  o.duration_s = 0.5;
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.stop_reason, "duration");
  EXPECT_GE(s.rows, 500u);
  EXPECT_LE(s.rows, 520u);
  EXPECT_EQ(s.lost, 0u);
}

TEST_F(Recorder, StopsOnASignalWithACompleteFile) {
  FakeServo servo(1, 4096);
  servo.enable = [](std::uint64_t) { return true; };
  servo.stop_after_sleeps = 30;
  const rec::Summary s = rec::record(servo.consumer, 42, options_for(path("t.csv")), servo, log_);
  EXPECT_EQ(s.stop_reason, "signal");
  const circtest::Trace t = circtest::read_trace(path("t.csv"));
  EXPECT_EQ(t.rows(), s.rows);
  EXPECT_EQ(*t.metadata.find("stop_reason"), "signal");
  EXPECT_EQ(*t.metadata.find("lost_samples"), "0");
}

// The servo thread stops (LinuxCNC shut down) after `sleeps` polls of the recorder.
class StoppingServo final : public rec::Environment {
 public:
  StoppingServo(FakeServo& servo, int sleeps) : servo_(servo), left_(sleeps) {}
  void sleep(double d) override {
    if (--left_ == 0) servo_.running = false;
    servo_.sleep(d);
  }
  double monotonic_s() override { return servo_.monotonic_s(); }
  bool stop_requested() override { return false; }
  bool process_alive(std::int32_t) override { return false; }
  std::string utc_now_iso8601() override { return servo_.utc_now_iso8601(); }

 private:
  FakeServo& servo_;
  int left_;
};

TEST_F(Recorder, StopsWhenTheServoThreadStops) {
  FakeServo servo(1, 4096);
  servo.enable = [](std::uint64_t) { return true; };
  StoppingServo env(servo, 50);
  const rec::Summary s = rec::record(servo.consumer, 42, options_for(path("t.csv")), env, log_);
  EXPECT_EQ(s.stop_reason, "servo thread stopped");
  EXPECT_EQ(s.lost, 0u);
  EXPECT_TRUE(fs::exists(path("t.csv")));
}

TEST_F(Recorder, RefusesAServoThatDoesNotRun) {
  FakeServo servo(1, 16);
  servo.running = false;
  EXPECT_THROW(rec::record(servo.consumer, 42, options_for(path("t.csv")), servo, log_),
               circtest::HalError);
  EXPECT_FALSE(fs::exists(path("t.csv")));
}

TEST_F(Recorder, RefusesASecondReaderButTakesOverFromADeadOne) {
  FakeServo servo(1, 16);
  circtest::circlog::Consumer other;
  ASSERT_EQ(other.attach(const_cast<circtest::circlog::SharedHeader*>(&servo.consumer.header()),
                         circtest::circlog::shared_size(1, 16)),
            circtest::circlog::AttachResult::ok);
  ASSERT_EQ(other.claim(7), 0);
  servo.alive = {7};
  rec::RecordRequest o = options_for(path("t.csv"));
  o.duration_s = 0.05;
  try {
    rec::record(servo.consumer, 42, o, servo, log_);
    FAIL() << "expected HalError";
  } catch (const circtest::HalError& e) {
    EXPECT_NE(std::string(e.what()).find("process 7"), std::string::npos);
  }
  servo.alive.clear();
  EXPECT_EQ(rec::record(servo.consumer, 42, o, servo, log_).stop_reason, "duration");
  EXPECT_NE(log_text().find("took over"), std::string::npos);
}

TEST_F(Recorder, ColumnsMustMatchTheModulesChannels) {
  FakeServo servo(3, 16);
  rec::RecordRequest o = options_for(path("t.csv"));
  o.columns = {"x", "y"};
  EXPECT_THROW(rec::record(servo.consumer, 42, o, servo, log_), circtest::UsageError);
  o.columns = {"x", "y", "z"};
  o.descriptions = {{"w", "nope"}};
  EXPECT_THROW(rec::record(servo.consumer, 42, o, servo, log_), circtest::UsageError);
  EXPECT_FALSE(servo.status().reader_attached);
}

// A ballbar program as circgen writes it: two runs at F1000 on R50 with 20 deg overshoot,
// and between them the overshoot arcs and the radial feed-out and feed-in (about 3 s).
std::string ballbar_header(const std::string& segments) {
  return "(circtest: generator: circgen 0.1.0)\n(circtest: units: mm)\n"
         "(circtest: radius_mm: 50)\n(circtest: arc_deg: 360)\n(circtest: lead_deg: 20)\n"
         "(circtest: dwell_s: 0)\n(circtest: instrument_profile: ballbar)\n"
         "(circtest: approach_feed_mm_per_min: 200)\n(circtest: feed_in_mm: 1.5)\n"
         "(circtest: segments: " +
         segments + ")\nM5 M9\n";
}

// Runs of a script: [first, last) periods with enable set, each with its segment id.
struct ScriptedRun {
  std::uint64_t first, last;
  double segment;
};

void script(FakeServo& servo, std::vector<ScriptedRun> runs) {
  servo.enable = [runs](std::uint64_t p) {
    return std::any_of(runs.begin(), runs.end(),
                       [p](const ScriptedRun& r) { return p >= r.first && p < r.last; });
  };
  servo.segment = [runs](std::uint64_t p) {
    for (const ScriptedRun& r : runs)
      if (p >= r.first && p < r.last) return r.segment;
    return 0.0;
  };
}

// Recording into t.csv with a ballbar program (p.ngc) that announces `segments`.
rec::RecordRequest with_program(const fs::path& dir, const std::string& segments) {
  std::ofstream(dir / "p.ngc") << ballbar_header(segments);
  rec::RecordRequest o = options_for((dir / "t.csv").string());
  o.program = (dir / "p.ngc").string();
  o.program_plan = rec::read_program_plan(o.program);
  return o;
}

TEST_F(Recorder, WaitsForEveryAnnouncedRunThroughAPauseLongerThanTheIdleTime) {
  FakeServo servo(1, 1 << 14);
  // CCW 100..1100, a 4 s pause (the ballbar's feed-out and feed-in), CW 5100..6100.
  script(servo, {{100, 1100, 1.0}, {5100, 6100, 2.0}});
  rec::RecordRequest o = with_program(dir_, "1:CCW:F1000,2:CW:F1000");
  o.idle_s = 2.0;  // as the README shows it
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.runs, 2u);
  EXPECT_EQ(s.stop_reason, "idle");
  EXPECT_TRUE(s.missing_runs.empty());
  const circtest::Trace t = circtest::read_trace(path("t.csv"));
  EXPECT_EQ(t.column("segment")->at(t.rows() - 2), 2.0);
  EXPECT_EQ(*t.metadata.find("runs_announced"), "2");
  EXPECT_EQ(*t.metadata.find("runs_missing"), "none");
  // Stopped 2 s after the last run, not later.
  EXPECT_LE(servo.monotonic_s(), 6.1 + 2.0 + 0.1);
}

TEST_F(Recorder, AProgramThatEndsWithoutARunSaysWhichIsMissing) {
  FakeServo servo(1, 1 << 14);
  // Runs 1 and 2 of three; run 3 never comes.
  script(servo, {{100, 1100, 1.0}, {3000, 4000, 2.0}});
  rec::RecordRequest o = with_program(dir_, "1:CCW:F1000,2:CW:F1000,3:CCW:F2000");
  o.idle_s = 2.0;
  const double wait_s = rec::run_wait_s(o);
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.stop_reason, "idle with runs missing");
  EXPECT_EQ(s.missing_runs, (std::vector<std::string>{"3 (CCW F2000) not recorded"}));
  EXPECT_EQ(s.lost, 0u);
  // The program's silence, not --until-idle, ended it.
  EXPECT_GE(servo.monotonic_s(), 4.0 + wait_s);
  EXPECT_LE(servo.monotonic_s(), 4.0 + wait_s + 0.1);
  const circtest::Trace t = circtest::read_trace(path("t.csv"));
  EXPECT_EQ(t.rows(), s.rows);
  EXPECT_EQ(t.rows(), 1000u + 1 + 1000 + 1);  // both runs whole, each with its falling row
  EXPECT_EQ(*t.metadata.find("runs_announced"), "3");
  EXPECT_EQ(*t.metadata.find("runs_missing"), "3 (CCW F2000) not recorded");
  EXPECT_EQ(*t.metadata.find("stop_reason"), "idle with runs missing");
}

TEST_F(Recorder, ARunWhoseStartWasNotRecordedIsIncomplete) {
  FakeServo servo(1, 1 << 14);
  // Run 1 is already under way when the recorder attaches.
  script(servo, {{0, 1000, 1.0}, {2000, 3000, 2.0}});
  rec::RecordRequest o = with_program(dir_, "1:CCW:F1000,2:CW:F1000");
  o.idle_s = 0.5;
  o.run_wait_s = 1.0;
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.missing_runs, (std::vector<std::string>{"1 (CCW F1000) incomplete"}));
  EXPECT_EQ(s.stop_reason, "idle with runs missing");
}

TEST_F(Recorder, ASignalBeforeTheLastRunListsIt) {
  FakeServo servo(1, 1 << 14);
  script(servo, {{100, 1100, 1.0}, {50000, 51000, 2.0}});
  servo.stop_after_sleeps = 400;  // 2 s of 5 ms polls
  rec::RecordRequest o = with_program(dir_, "1:CCW:F1000,2:CW:F1000");
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.stop_reason, "signal");
  EXPECT_EQ(s.missing_runs, (std::vector<std::string>{"2 (CW F1000) not recorded"}));
}

// The wait for a missing run: twice the longest planned pause between two runs plus 10 s.
TEST_F(Recorder, TheWaitForAMissingRunComesFromTheProgramsPauses) {
  std::ofstream(path("p.ngc")) << ballbar_header("1:CCW:F1000,2:CW:F1000");
  rec::RecordRequest o;
  o.program_plan = rec::read_program_plan(path("p.ngc"));
  // Two 20 deg overshoots of R50 at F1000 (17.45 mm each, 1.047 s) and the 1.5 mm feed-out
  // and feed-in at F200 (0.45 s each).
  const double lead_s = 2.0 * 3.141592653589793 * 50.0 * 20.0 / 360.0 / (1000.0 / 60.0);
  ASSERT_TRUE(o.program_plan.longest_pause_s);
  EXPECT_NEAR(*o.program_plan.longest_pause_s, 2.0 * lead_s + 2.0 * 1.5 / (200.0 / 60.0), 1e-9);
  EXPECT_NEAR(rec::run_wait_s(o), 2.0 * *o.program_plan.longest_pause_s + 10.0, 1e-9);
  // One direction at two feeds: the way back (2 x 20 deg on R51.5) at the second feed.
  std::ofstream(path("q.ngc")) << ballbar_header("1:CCW:F500,2:CCW:F1000");
  const auto q = rec::read_program_plan(path("q.ngc"));
  const double back_s = 2.0 * 3.141592653589793 * 51.5 * 40.0 / 360.0 / (1000.0 / 60.0);
  EXPECT_NEAR(*q.longest_pause_s, lead_s * 2.0 + lead_s + 0.9 + back_s, 1e-9);
  o.run_wait_s = 7.0;
  EXPECT_EQ(rec::run_wait_s(o), 7.0);
  // Without the numbers it takes, a fixed wait.
  std::ofstream(path("r.ngc")) << "(segments: 1:CCW:F500,2:CW:F500)\nG0 X0\n";
  rec::RecordRequest r;
  r.program_plan = rec::read_program_plan(path("r.ngc"));
  EXPECT_EQ(r.program_plan.runs.size(), 2u);
  EXPECT_EQ(rec::run_wait_s(r), rec::kDefaultRunWait_s);
}

// circgen's own programs (tests/gcode-gen/golden): the recorder reads the runs and the
// numbers of the pauses from the header keys circgen writes.
TEST(CirclogRecordProgram, ReadsTheRunsAndPausesCircgenAnnounces) {
  const std::string golden = std::string(CIRCTEST_SOURCE_DIR) + "/tests/gcode-gen/golden/";
  const auto ballbar = rec::read_program_plan(golden + "ballbar_xy_safe.ngc");
  ASSERT_EQ(ballbar.runs.size(), 2u);
  EXPECT_EQ(ballbar.runs[1].segment_id, 2);
  EXPECT_EQ(ballbar.runs[1].direction, circtest::Direction::CW);
  EXPECT_EQ(ballbar.runs[1].label, "CW F1000");
  // R100, 20 deg overshoots at F1000 (2 x 2.094 s), 1.5 mm feed-out and feed-in at F200.
  ASSERT_TRUE(ballbar.longest_pause_s);
  EXPECT_NEAR(*ballbar.longest_pause_s, 2 * 2.0943951 + 0.9, 1e-6);
  // Inch, CW at F10 then F20 in/min on R2 in (50.8 mm), 10 deg leads: the lead-out at
  // 254 mm/min (2.094 s), the 20 deg way back and the lead-in at 508 mm/min (2.094 s, 1.047 s).
  const auto inch = rec::read_program_plan(golden + "inch_sweep_cw.ngc");
  ASSERT_EQ(inch.runs.size(), 2u);
  ASSERT_TRUE(inch.longest_pause_s);
  EXPECT_NEAR(*inch.longest_pause_s, 2.0943951 + 2.0943951 + 1.0471976, 1e-6);
}

std::string parse_error(const std::string& file) {
  try {
    rec::read_program_plan(file);
  } catch (const circtest::ParseError& e) {
    return e.what();
  }
  return "no error";
}

// A test set: the program pauses for the operator before each plane, for as long as the
// operator takes; the recorder waits through it for the next plane's runs.
TEST_F(Recorder, ATestSetWaitsThroughTheOperatorsPauseBeforeEachPlane) {
  FakeServo servo(1, 1 << 14);
  // XY's runs, 60 s of the operator re-mounting the ball bar, YZ's runs.
  script(servo, {{100, 1100, 1.0}, {1200, 2200, 2.0}, {62200, 63200, 3.0}, {63300, 64300, 4.0}});
  rec::RecordRequest o =
      with_program(dir_, "1:CCW:F1000:XY,2:CW:F1000:XY,3:CCW:F1000:YZ,4:CW:F1000:YZ");
  o.idle_s = 2.0;
  ASSERT_LT(rec::run_wait_s(o), 60.0);  // the wait between two runs of one plane
  const rec::Summary s = rec::record(servo.consumer, 42, o, servo, log_);
  EXPECT_EQ(s.stop_reason, "idle");
  EXPECT_EQ(s.runs, 4u);
  EXPECT_TRUE(s.missing_runs.empty());
  const circtest::Trace t = circtest::read_trace(path("t.csv"));
  EXPECT_EQ(*t.metadata.find("runs_announced"), "4");
  EXPECT_EQ(*t.metadata.find("runs_missing"), "none");
}

TEST_F(Recorder, ATestSetsRunsNameTheirPlanesAndItsPausesAreThePlanes) {
  std::ofstream(path("p.ngc")) << ballbar_header("1:CCW:F1000:XY,2:CW:F1000:XY,3:CCW:F1000:ZX");
  rec::RecordRequest o;
  o.program_plan = rec::read_program_plan(path("p.ngc"));
  ASSERT_EQ(o.program_plan.runs.size(), 3u);
  EXPECT_EQ(o.program_plan.runs[2].plane, circtest::Plane::ZX);
  EXPECT_EQ(o.program_plan.runs[2].label, "CCW F1000 ZX");
  EXPECT_FALSE(rec::operator_pause_before(o.program_plan, 1));
  EXPECT_TRUE(rec::operator_pause_before(o.program_plan, 2));
  // The planned pause is XY's reversal only, not the change of plane.
  const double lead_s = 2.0 * 3.141592653589793 * 50.0 * 20.0 / 360.0 / (1000.0 / 60.0);
  ASSERT_TRUE(o.program_plan.longest_pause_s);
  EXPECT_NEAR(*o.program_plan.longest_pause_s, 2.0 * lead_s + 2.0 * 1.5 / (200.0 / 60.0), 1e-9);
  EXPECT_EQ(rec::run_wait_s(o, 1), rec::run_wait_s(o));
  EXPECT_EQ(rec::run_wait_s(o, 2), rec::kMaxWait_s);
  o.run_wait_s = 600.0;
  EXPECT_EQ(rec::run_wait_s(o, 2), 600.0);
  std::ofstream(path("p.ngc")) << "(circtest: segments: 1:CCW:F500:XZ)\nG0 X0\n";
  EXPECT_NE(parse_error(path("p.ngc")).find("is not ID:DIRECTION:FFEED[:PLANE]"), std::string::npos)
      << parse_error(path("p.ngc"));
}

TEST_F(Recorder, AnnouncedRunsThatCannotBeToldApartAreRefused) {
  for (const std::string bad :
       {"1:CCW:F500,x", "0:CCW:F500", "1:UP:F500", "1:CCW:500", "1:CCW:F-5", "1:CCW", "1.5:CW:F5",
        "1:CCW:F500:9", "1:CCW:F500:XZ", "1:CCW:F500:XY:1", ""}) {
    std::ofstream(path("p.ngc")) << "(circtest: plane: XY)\n(circtest: segments: " << bad
                                 << ")\nG0 X0\n";
    const std::string e = parse_error(path("p.ngc"));
    EXPECT_NE(e.find("p.ngc:2"), std::string::npos) << bad << ": " << e;
    EXPECT_NE(e.find("is not ID:DIRECTION:FFEED"), std::string::npos) << bad << ": " << e;
  }
  // circgen's plane field: a set's runs in two planes.
  std::ofstream(path("p.ngc")) << "(circtest: segments: 1:CCW:F500:XY,2:CW:F500:YZ)\nG0 X0\n";
  const auto set = rec::read_program_plan(path("p.ngc"));
  ASSERT_EQ(set.runs.size(), 2u);
  EXPECT_EQ(set.runs[1].direction, circtest::Direction::CW);
  EXPECT_EQ(set.runs[1].feed_per_min, 500.0);
  std::ofstream(path("p.ngc")) << "(circtest: segments: 1:CCW:F500,1:CW:F500)\nG0 X0\n";
  EXPECT_NE(parse_error(path("p.ngc")).find("p.ngc:1: segments: run 1 is announced twice"),
            std::string::npos)
      << parse_error(path("p.ngc"));
}

TEST(CirclogRecordOptions, WaitsAreBounded) {
  EXPECT_THROW(parse({"-o", "a", "--run-wait", "5"}), circtest::UsageError);  // no --until-idle
  EXPECT_THROW(parse({"-o", "a", "--until-idle", "2", "--run-wait", "0"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--until-idle", "2", "--run-wait", "1e300"}),
               circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--until-idle", "1e300"}), circtest::UsageError);
  EXPECT_THROW(parse({"-o", "a", "--duration", "1e300"}), circtest::UsageError);
  const auto o = parse({"-o", "a", "--until-idle", "2", "--run-wait", "30"});
  ASSERT_TRUE(o);
  EXPECT_EQ(*o->run_wait_s, 30.0);
}

}  // namespace

TEST_F(Recorder, ShowsWhatItHasSeenOnATerminalOnly) {
  // Two announced runs with a pause between them, recorded once to a terminal, once to a file.
  for (const bool terminal : {true, false}) {
    circtest::testing::PtyCapture pty;
    FakeServo servo(1, 1 << 14);
    script(servo, {{1500, 2500, 1.0}, {4000, 5000, 2.0}});
    rec::RecordRequest o = with_program(dir_, "1:CCW:F1000,2:CW:F1000");
    o.idle_s = 1.0;
    const rec::Summary s =
        rec::record(servo.consumer, 42, o, servo, terminal ? pty.terminal() : log_);
    EXPECT_EQ(s.runs, 2u);
    const std::string shown = pty.finish();
    if (!terminal) {
      EXPECT_EQ(shown, "");
      EXPECT_EQ(log_text().find("samples"), std::string::npos) << log_text();
      continue;
    }
    // Nothing before a second; then elapsed, samples, runs and what it waits for, in place.
    EXPECT_TRUE(shown.starts_with("\rcirclog-record: 1 s, ")) << shown;
    for (const std::string words :
         {"samples, 0 run(s); waiting for run 1 of 2\033[K",
          "samples, 1 run(s); recording run 1 of 2\033[K",
          "samples, 1 run(s); waiting for run 2 of 2\033[K",
          "samples, 2 run(s); recording run 2 of 2\033[K",
          "samples, 2 run(s); all 2 runs recorded, waiting for idle\033[K"}) {
      EXPECT_NE(shown.find(words), std::string::npos) << words << "\n" << shown;
    }
    EXPECT_EQ(shown.find('\n'), std::string::npos) << shown;
    EXPECT_TRUE(shown.ends_with("\r\033[K")) << "the line is gone at the end:\n" << shown;
  }
}

TEST_F(Recorder, ShowsTheStatusOnTheTerminalItIsGiven) {
  // circtest-run's case: stderr goes to a log, the status line to the person's terminal.
  circtest::testing::PtyCapture pty;
  const std::string tty = ::ttyname(pty.terminal_fd());
  const auto parsed = parse({"-o", "t.csv", "--progress-to", tty.c_str()});
  ASSERT_TRUE(parsed);
  EXPECT_EQ(parsed->progress_to, tty);
  std::FILE* terminal = rec::open_progress_terminal(parsed->progress_to);
  FakeServo servo(1, 1 << 14);
  script(servo, {{1500, 2500, 1.0}});
  rec::RecordRequest o = options_for(path("t.csv"));
  o.idle_s = 0.5;
  EXPECT_EQ(rec::record(servo.consumer, 42, o, servo, log_, terminal).runs, 1u);
  std::fclose(terminal);
  const std::string shown = pty.finish();
  EXPECT_NE(shown.find("samples, 1 run(s); recording run 1\033[K"), std::string::npos) << shown;
  EXPECT_NE(shown.find("samples, 1 run(s); waiting for the next run\033[K"), std::string::npos)
      << shown;
  EXPECT_EQ(log_text().find("samples"), std::string::npos) << log_text();

  // Anything but a terminal is refused, and a file is neither created nor truncated.
  std::ofstream(path("notes.txt")) << "keep\n";
  for (const std::string& p : {path("notes.txt"), path("absent"), dir_.string()}) {
    try {
      std::fclose(rec::open_progress_terminal(p));
      ADD_FAILURE() << p << " accepted";
    } catch (const circtest::UsageError& e) {
      EXPECT_EQ(std::string(e.what()), "--progress-to " + p + ": not a terminal");
    }
  }
  EXPECT_EQ(circtest::testing::slurp(path("notes.txt")), "keep\n");
  EXPECT_FALSE(fs::exists(path("absent")));
}
