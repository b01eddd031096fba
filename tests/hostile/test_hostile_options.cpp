// A misspelt option is a usage error that names the option meant, in every program, so the
// person at the machine is not left to read a help page for the one letter that was wrong.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "scratch.hpp"

namespace {

using namespace circtest::testing;  // ScratchDir, slurp, spit, run_command

void expect_suggestion(const std::vector<std::string>& argv, const std::string& meant) {
  SCOPED_TRACE(argv.at(0) + " " + argv.back());
  const CommandResult r = run_command(argv);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("unknown option " + argv.back() + "; did you mean " + meant + "?"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
  EXPECT_EQ(r.out, "");
}

TEST(HostileOptions, AMisspeltOptionNamesTheOneMeantInEveryProgram) {
  expect_suggestion({CIRCGEN_PATH, "--d", "150", "--f", "300", "--lea"}, "--lead");
  expect_suggestion({CIRCANA_PATH, "analyze", "t.csv", "--radus"}, "--radius");
  expect_suggestion({CIRCCOMP_PATH, "plan", "--ini", "m.ini", "d.json", "--forse"}, "--force");
  expect_suggestion({CIRCLOG_RECORD_PATH, "-o", "t.csv", "--until-idel"}, "--until-idle");
}

TEST(HostileOptions, AnOptionFarFromEveryKnownOneIsRefusedWithoutAGuess) {
  const CommandResult r = run_command({CIRCGEN_PATH, "--d", "150", "--f", "300", "--zzzzzzzz"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("unknown option --zzzzzzzz"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("did you mean"), std::string::npos) << r.err;
}

}  // namespace
