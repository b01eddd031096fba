#pragma once
// The end-to-end tests that start LinuxCNC (configs/circtest-run): one fixture and one run
// helper for all of them.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "scratch.hpp"

namespace circtest::testing {

// One run of configs/circtest-run: PROGRAM on the configuration INI with --set
// SECTION.KEY=VALUE on top, its machine copy, trace and logs in OUT.
struct LinuxcncRun {
  LinuxcncRun(std::string ini_path, std::filesystem::path program_path,
              std::filesystem::path out_dir, std::vector<std::string> set_values = {})
      : ini(std::move(ini_path)),
        program(std::move(program_path)),
        out(std::move(out_dir)),
        sets(std::move(set_values)) {}
  std::string ini;
  std::filesystem::path program;
  std::filesystem::path out;
  std::vector<std::string> sets;
  // Extra KEY=value environment entries (CIRCTEST_BIN, the build tree, is always given).
  std::vector<std::string> env;
  int timeout_s = 300;
};

struct LinuxcncResult {
  CommandResult command;
  double seconds = 0;  // wall time, the wait for the machine-wide lock included
  // circtest-run's output and the run's linuxcnc.log: the message of a failed check.
  std::string log;
};

// Runs circtest-run (RUN_SCRIPT) with the build tree BINARY_DIR's programs and modules.
LinuxcncResult run_linuxcnc(const std::string& run_script, const std::string& binary_dir,
                            const LinuxcncRun& run);

// circana (CIRCANA_PATH) COMMAND TRACE --json ARGS...: the document it prints, also kept as
// KEEP_AS (the folder a failed test leaves holds it); a failed circana fails the test with
// its stderr.
nlohmann::json circana_json(const std::string& circana_path, const std::string& command,
                            const std::filesystem::path& trace,
                            const std::filesystem::path& keep_as,
                            const std::vector<std::string>& args = {});

// The fixture of the LinuxCNC tests. A test is skipped without root (circtest-run's private
// namespaces) unless the HAL modules it needs are installed; each test gets a scratch folder
// named after it that rtapi_app, running as nobody, can enter, kept when the test fails.
class LinuxcncTest : public ::testing::Test {
 protected:
  // PREFIX names the scratch folder; MODULES (e.g. circlog.so) are what a run needs installed
  // when it runs without root.
  explicit LinuxcncTest(std::string prefix, std::vector<std::string> modules = {"circlog.so"});
  void SetUp() override;
  void TearDown() override;

  std::unique_ptr<ScratchDir> scratch_;
  std::filesystem::path out_;

 private:
  std::string prefix_;
  std::vector<std::string> modules_;
};

}  // namespace circtest::testing
