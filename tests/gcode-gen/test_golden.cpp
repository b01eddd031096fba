// Whole programs compared with reviewed files under golden/. After a deliberate change,
// regenerate with CIRCTEST_UPDATE_GOLDEN=1 and review the diff.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "support.hpp"

namespace circtest::testing {
namespace {

struct Golden {
  std::string name;
  std::vector<std::string> args;
};

class CircgenGolden : public ::testing::TestWithParam<Golden> {};

TEST_P(CircgenGolden, ProgramMatchesTheReviewedFile) {
  const Golden& g = GetParam();
  const CommandResult r = run_circgen(g.args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string path = std::string(CIRCTEST_GCODE_GOLDEN_DIR) + "/" + g.name + ".ngc";
  if (std::getenv("CIRCTEST_UPDATE_GOLDEN")) spit(path, r.out);
  EXPECT_EQ(r.out, slurp(path)) << "regenerate with CIRCTEST_UPDATE_GOLDEN=1 if intended";
}

INSTANTIATE_TEST_SUITE_P(
    Programs, CircgenGolden,
    ::testing::Values(
        Golden{"default_d150_f300", {"--d", "150", "--f", "300"}},
        Golden{"zx_partial_safe",
               {"--plane", "ZX", "--d", "100", "--f", "500", "--arc", "180", "--start", "0",
                "--lead", "15", "--centre", "0,-20,-50", "--safe-z", "10"}},
        Golden{"inch_sweep_cw",
               {"--inch", "--d", "4", "--feeds", "10,20", "--dir", "cw", "--marker", "1",
                "--segment-out", "2"}},
        Golden{"annex_c_d125",
               {"--d", "125", "--ref-d", "100", "--ref-f", "500", "--dwell", "0.5"}},
        Golden{"ballbar_xy_safe",
               {"--instrument", "ballbar", "--d", "200", "--f", "1000", "--safe-z", "30",
                "--offset", "250,-120,-400"}},
        Golden{"ballbar_yz_default",
               {"--instrument", "ballbar", "--plane", "YZ", "--d", "300", "--f", "800"}},
        Golden{"grid_xy_sweep",
               {"--instrument", "grid", "--d", "140", "--feeds", "500,2000", "--safe-z", "5",
                "--approach-feed", "300"}}),
    [](const ::testing::TestParamInfo<Golden>& p) { return p.param.name; });

}  // namespace
}  // namespace circtest::testing
