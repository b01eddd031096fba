// Standard output that cannot be written: every program that prints a document (a program, a
// JSON result, a history, a plan) exits non-zero with a message when the write fails, instead
// of leaving a truncated file behind an exit status of 0 (`circana analyze --json > out.json`
// on a full disk).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hostile_example.hpp"
#include "scratch.hpp"

namespace {

using namespace circtest::testing;  // ScratchDir, slurp, spit, run_command, kExample

const std::string kSimIni = std::string(CIRCTEST_SOURCE_DIR) + "/configs/sim-mill/sim-mill.ini";

// Runs ARGV with standard output on /dev/full (every write fails with ENOSPC).
CommandResult to_full_disk(const std::vector<std::string>& argv) {
  return run_command(argv, {}, "/dev/full");
}

void expect_refused_write(const std::vector<std::string>& argv) {
  SCOPED_TRACE(argv.at(0) + (argv.size() > 1 ? " " + argv[1] : std::string()));
  const CommandResult r = to_full_disk(argv);
  EXPECT_EQ(r.exit_code, 3) << r.err;  // ExitCode::io
  // The reason follows when the last flush fails; a write that failed earlier left none.
  EXPECT_NE(r.err.find(": error: standard output: write failed"), std::string::npos) << r.err;
}

TEST(HostileOutput, AFullDiskUnderEveryDocumentIsAnError) {
  ScratchDir dir;
  expect_refused_write({CIRCGEN_PATH, "--d", "150", "--f", "300"});
  expect_refused_write({CIRCANA_PATH, "analyze", kExample, "--json"});
  expect_refused_write({CIRCANA_PATH, "analyze", kExample});
  expect_refused_write({CIRCANA_PATH, "diagnose", kExample, "--json"});

  const std::string db = "sqlite:" + dir.file("history.sqlite");
  const CommandResult stored =
      run_command({CIRCANA_PATH, "analyze", kExample, "--store", "--db", db, "--machine", "m1"});
  ASSERT_EQ(stored.exit_code, 0) << stored.err;
  expect_refused_write({CIRCANA_PATH, "history", "--machine", "m1", "--db", db});

  const CommandResult diagnosis = run_command({CIRCANA_PATH, "diagnose", kExample, "--json"});
  ASSERT_EQ(diagnosis.exit_code, 0) << diagnosis.err;
  spit(dir.file("diagnosis.json"), diagnosis.out);
  expect_refused_write({CIRCCOMP_PATH, "plan", "--ini", kSimIni, dir.file("diagnosis.json")});
  expect_refused_write({CIRCTEST_INI_PATH, "get", kSimIni, "TRAJ", "LINEAR_UNITS"});
}

TEST(HostileOutput, AFullDiskUnderHelpAndVersionIsAnError) {
  for (const std::string program :
       {CIRCGEN_PATH, CIRCANA_PATH, CIRCCOMP_PATH, CIRCLOG_RECORD_PATH}) {
    expect_refused_write({program, "--help"});
    expect_refused_write({program, "--version"});
  }
}

TEST(HostileOutput, AWritableStandardOutputStillExitsZero) {
  const CommandResult r = run_command({CIRCANA_PATH, "analyze", kExample, "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"plane\""), std::string::npos);
}

}  // namespace
