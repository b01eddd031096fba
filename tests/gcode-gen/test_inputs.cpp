// What circgen reads and says: every input file a regular one (a FIFO is refused at once,
// never waited on), every documented range enforced, messages in the user's units, and a
// --help that lists what the command accepts and the man page documents.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "expect_refused.hpp"
#include "support.hpp"

namespace circtest::testing {
namespace {

// circgen, killed after 20 s: a read that waits for ever fails the test (exit 124).
CommandResult run_bounded(const std::vector<std::string>& args) {
  std::vector<std::string> argv{"/usr/bin/timeout", "20", CIRCGEN_EXE};
  argv.insert(argv.end(), args.begin(), args.end());
  return run_command(argv, {"SOURCE_DATE_EPOCH=1700000000"});
}

const char* kIni =
    "[TRAJ]\nLINEAR_UNITS = mm\n[AXIS_X]\nMIN_LIMIT = -200\nMAX_LIMIT = 200\n"
    "[AXIS_Y]\nMIN_LIMIT = -200\nMAX_LIMIT = 200\n[AXIS_Z]\nMIN_LIMIT = -100\nMAX_LIMIT = 10\n";

TEST(CircgenInputs, AFifoGivenAsAnyInputFileIsRefusedAtOnce) {
  ScratchDir dir;
  ASSERT_EQ(::mkfifo(dir.file("fifo").c_str(), 0600), 0);
  const std::vector<std::string> test{"--d", "100", "--f", "500"};
  auto with_ini = [&](const std::string& ini) {
    std::vector<std::string> args = test;
    args.insert(args.end(), {"--ini", ini});
    return run_bounded(args);
  };
  expect_refused(with_ini(dir.file("fifo")), 3,
                 dir.file("fifo") + ": is a FIFO, expected a regular INI file");
  spit(dir.file("var.ini"), std::string(kIni) + "[RS274NGC]\nPARAMETER_FILE = fifo\n");
  expect_refused(with_ini(dir.file("var.ini")), 3,
                 dir.file("fifo") + ": is a FIFO, expected a regular parameter file");
  spit(dir.file("hal.ini"), std::string(kIni) + "[HAL]\nHALFILE = fifo.hal\n");
  ASSERT_EQ(::mkfifo(dir.file("fifo.hal").c_str(), 0600), 0);
  expect_refused(with_ini(dir.file("hal.ini")), 3,
                 dir.file("fifo.hal") + ": is a FIFO, expected a regular HAL file");
  // A directory where the parameter file should be is no parameter file either.
  ::mkdir(dir.file("dir.var").c_str(), 0700);
  spit(dir.file("dir.ini"), std::string(kIni) + "[RS274NGC]\nPARAMETER_FILE = dir.var\n");
  expect_refused(with_ini(dir.file("dir.ini")), 3,
                 dir.file("dir.var") + ": is a directory, expected a regular parameter file");
}

struct UnitCase {
  std::string name;
  std::vector<std::string> args;  // after --inch
  int exit_code;
  std::string words;
};

// With --inch the user's lengths and feeds are inch: so are the refusals.
TEST(CircgenInputs, MessagesSayTheUsersUnits) {
  const std::vector<UnitCase> cases{
      {"floor_range",
       {"--d", "4", "--f", "20", "--floor", "1e6"},
       2,
       "--floor: floor height of 1e+06 in is outside the plausible range -3937..3937 in"},
      {"offset_range",
       {"--d", "4", "--f", "20", "--offset", "1e5,0,0"},
       2,
       "--offset: work offset of 100000 in is outside the plausible range -3937..3937 in"},
      {"approach_feed",
       {"--d", "4", "--f", "20", "--approach-feed", "30"},
       2,
       "--approach-feed: 30 in/min is above the test feed 20 in/min"},
      {"feed_in",
       {"--d", "3.937", "--f", "20", "--instrument", "ballbar", "--feed-in", "1"},
       2,
       "--feed-in: the ballbar feed-in must be 0.5..3 mm [0.019685..0.11811 in], got 1 in"},
      {"ballbar_radius",
       {"--d", "3", "--f", "20", "--instrument", "ballbar"},
       2,
       "--instrument ballbar: radius 1.5 in is outside the 50..600 mm [1.9685..23.622 in]"},
      {"ballbar_length",
       {"--d", "30", "--f", "20", "--instrument", "ballbar"},
       2,
       "--instrument ballbar: radius 15 in is not a length of the ballbar profile"},
      {"ballbar_feed",
       {"--d", "3.937008", "--f", "400", "--instrument", "ballbar"},
       2,
       "--instrument ballbar: feed 400 in/min is above the 393.700787402 in/min circgen allows"},
      {"annex_c_reference",
       {"--d", "4", "--ref-d", "1000", "--ref-f", "1"},
       2,
       "--ref-d: Annex C reference diameter of 1000 in is outside the plausible range "
       "0.03937..393.7 in"},
      {"floor_reached",
       {"--d", "4", "--f", "20", "--plane", "YZ", "--floor", "-1.5"},
       6,
       "--floor -1.5: the path in YZ reaches Z -2 in (work offset), 0.5 in below that floor"},
  };
  for (const UnitCase& c : cases) {
    SCOPED_TRACE(c.name);
    std::vector<std::string> args{"--inch"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    expect_refused(run_bounded(args), c.exit_code, c.words);
  }
}

// --offset against the parameter file, in the user's inch (the file's 25.4 mm is 1 in).
TEST(CircgenInputs, OffsetDisagreementInTheUsersUnits) {
  ScratchDir dir;
  spit(dir.file("m.ini"), std::string(kIni) + "[RS274NGC]\nPARAMETER_FILE = p.var\n");
  spit(dir.file("p.var"), "5220 1\n5221 25.4\n");
  expect_refused(run_bounded({"--inch", "--d", "4", "--f", "20", "--work-offset", "G54", "--offset",
                              "2,0,0", "--ini", dir.file("m.ini")}),
                 2,
                 "--offset 2,0,0 in disagrees with G54 #5221..#5223 in " + dir.file("p.var") +
                     " = 1,0,0 in: give the origin that is right, or drop --offset");
}

// An INI in inch states its limits in inch; the feed and circle are the user's.
TEST(CircgenInputs, MachineLimitMessagesInTheIniAndTheUsersUnits) {
  ScratchDir dir;
  std::string ini = "[TRAJ]\nLINEAR_UNITS = inch\n";
  for (const char* axis : {"X", "Y", "Z"}) {
    ini += std::string("[AXIS_") + axis +
           "]\nMIN_LIMIT = -5\nMAX_LIMIT = 5\nMAX_VELOCITY = 1\nMAX_ACCELERATION = 20\n";
  }
  spit(dir.file("inch.ini"), ini);
  expect_refused(run_bounded({"--inch", "--d", "12", "--f", "20", "--ini", dir.file("inch.ini")}),
                 6,
                 "the test reaches X = -6 inch in machine coordinates, below [AXIS_X] "
                 "MIN_LIMIT = -5");
  expect_refused(run_bounded({"--inch", "--d", "4", "--f", "120", "--ini", dir.file("inch.ini")}),
                 6, "feed 120 in/min = 2 inch/s exceeds [AXIS_X] MAX_VELOCITY = 1");
  expect_refused(run_bounded({"--inch", "--d", "0.05", "--f", "50", "--ini", dir.file("inch.ini")}),
                 6, "at F50 on R0.025 in exceeds [AXIS_X] MAX_ACCELERATION = 20");
}

// The options --help lists, and those the man page documents.
std::set<std::string> options_in(const std::string& text, const std::regex& pattern) {
  std::set<std::string> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), pattern);
       it != std::sregex_iterator(); ++it) {
    out.insert((*it)[1].str());
  }
  return out;
}

TEST(CircgenInputs, HelpListsWhatTheCommandAcceptsAndTheManPageDocuments) {
  const CommandResult help = run_bounded({"--help"});
  ASSERT_EQ(help.exit_code, 0);
  const std::set<std::string> listed =
      options_in(help.out, std::regex(R"(\n  (?:-\w \[ )?--([a-z-]+))"));
  ASSERT_GT(listed.size(), 25u);
  for (const std::string& name : listed) {
    SCOPED_TRACE(name);
    // Each is accepted: with a value where it takes one, it is never an unknown option.
    const CommandResult r = run_bounded({"--" + name, "1"});
    EXPECT_EQ(r.err.find("unrecognised option"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("unrecognized option"), std::string::npos) << r.err;
  }
  // The man page's option lines (.B, .BI, .BR), every --name on them.
  const std::string man =
      slurp(std::string(CIRCTEST_GCODE_GOLDEN_DIR) + "/../../../docs/man/circgen.1");
  std::set<std::string> documented;
  std::istringstream lines(std::regex_replace(man, std::regex(R"(\\-)"), "-"));
  for (std::string line; std::getline(lines, line);) {
    if (line.starts_with(".B"))
      documented.merge(options_in("\n  " + line, std::regex(R"(--([a-z-]+))")));
  }
  EXPECT_EQ(listed, documented);
}

}  // namespace
}  // namespace circtest::testing
