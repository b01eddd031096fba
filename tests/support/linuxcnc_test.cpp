#include "linuxcnc_test.hpp"

#include <unistd.h>

#include <chrono>
#include <utility>

namespace fs = std::filesystem;

namespace circtest::testing {

LinuxcncResult run_linuxcnc(const std::string& run_script, const std::string& binary_dir,
                            const LinuxcncRun& run) {
  std::vector<std::string> argv = {run_script,
                                   "--ini",
                                   run.ini,
                                   "--program",
                                   run.program.string(),
                                   "--out",
                                   run.out.string(),
                                   "--timeout",
                                   std::to_string(run.timeout_s)};
  for (const auto& s : run.sets) {
    argv.push_back("--set");
    argv.push_back(s);
  }
  std::vector<std::string> env = {"CIRCTEST_BIN=" + binary_dir};
  env.insert(env.end(), run.env.begin(), run.env.end());
  LinuxcncResult r;
  const auto start = std::chrono::steady_clock::now();
  r.command = run_command(argv, env);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.log = r.command.out + r.command.err + slurp_if_exists(run.out / "linuxcnc.log");
  return r;
}

nlohmann::json circana_json(const std::string& circana_path, const std::string& command,
                            const fs::path& trace, const fs::path& keep_as,
                            const std::vector<std::string>& args) {
  std::vector<std::string> argv = {circana_path, command, trace.string(), "--json"};
  argv.insert(argv.end(), args.begin(), args.end());
  const auto r = run_command(argv);
  EXPECT_EQ(r.exit_code, 0) << "circana " << command << ": " << r.err;
  spit(keep_as, r.out);
  return nlohmann::json::parse(r.out);
}

LinuxcncTest::LinuxcncTest(std::string prefix, std::vector<std::string> modules)
    : prefix_(std::move(prefix)), modules_(std::move(modules)) {}

void LinuxcncTest::SetUp() {
  if (geteuid() != 0) {
    for (const auto& m : modules_) {
      if (!fs::exists("/usr/lib/linuxcnc/modules/" + m)) {
        GTEST_SKIP() << "needs root (private namespaces) or " << m << " installed";
      }
    }
  }
  // rtapi_app's socket lies in the run's folder below this one, and a socket path has at most
  // 108 bytes: the test's name is cut to keep the folder's name at 60.
  const std::string name = "circtest-e2e-" + prefix_ + "-" +
                           ::testing::UnitTest::GetInstance()->current_test_info()->name();
  scratch_ = std::make_unique<ScratchDir>(name.substr(0, 60));
  out_ = scratch_->dir();
  // rtapi_app runs as nobody and binds its socket below this folder: mkdtemp's 0700 refuses it.
  fs::permissions(out_, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                            fs::perms::others_read | fs::perms::others_exec);
}

void LinuxcncTest::TearDown() {
  if (HasFailure() && scratch_) scratch_->keep();
}

}  // namespace circtest::testing
