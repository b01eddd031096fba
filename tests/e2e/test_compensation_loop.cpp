// The closed loop on the simulated LinuxCNC mill: measure with known backlash and scale
// errors, write the correction with circcomp (provenance from the trace's ini_sha256), run
// the corrected configuration in the real LinuxCNC again, and see H and G fall. The sim's
// errors sit after the motor (sim-mill.hal: joint.N.motor-pos-cmd -> loop -> play -> scale),
// so LinuxCNC's BACKLASH/COMP_FILE, which act on the motor command, really compensate there.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

int run(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string metadata(const fs::path& trace, const std::string& key) {
  std::ifstream in(trace);
  for (std::string line; std::getline(in, line) && line.rfind("#", 0) == 0;) {
    const std::string prefix = "# " + key + ": ";
    if (line.rfind(prefix, 0) == 0) return line.substr(prefix.size());
  }
  return {};
}

class CompensationLoop : public ::testing::Test {
 protected:
  void SetUp() override {
    if (geteuid() != 0 && !fs::exists("/usr/lib/linuxcnc/modules/circlog.so")) {
      GTEST_SKIP() << "needs root (private namespaces) or circlog installed";
    }
    out_ = fs::temp_directory_path() / "circtest-e2e-compensation-loop";
    fs::remove_all(out_);
    fs::create_directories(out_);
    fs::copy(fs::path(CIRCTEST_SIM_INI).parent_path(), out_ / "machine");
    ini_ = (out_ / "machine" / "sim-mill.ini").string();
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(out_);
  }
  void set(const std::string& key, const std::string& value) {
    ASSERT_EQ(run(std::string(CIRCTEST_INI_PATH) + " set " + ini_ + " SIM " + key + " " + value),
              0);
  }
  // Runs the program on the configuration as it is now; returns circana's JSON.
  json measure(const std::string& name) {
    const fs::path dir = out_ / name;
    const std::string cmd = std::string("CIRCTEST_BIN=") + CIRCTEST_BINARY_DIR + " " +
                            CIRCTEST_RUN_PATH + " --ini " + ini_ + " --program " +
                            (out_ / "test.ngc").string() + " --out " + dir.string() +
                            " --timeout 300 >" + (out_ / (name + ".log")).string() + " 2>&1";
    EXPECT_EQ(run(cmd), 0) << slurp(out_ / (name + ".log")) << slurp(dir / "linuxcnc.log");
    const fs::path js = out_ / (name + ".json");
    EXPECT_EQ(run(std::string(CIRCANA_PATH) + " analyze " + (dir / "trace.csv").string() +
                  " --json >" + js.string()),
              0);
    return json::parse(slurp(js));
  }
  static double worst_g(const json& r) {
    double g = 0;
    for (const auto& run : r["runs"]) g = std::max(g, run["G"].get<double>());
    return g;
  }

  fs::path out_;
  std::string ini_;
};

}  // namespace

TEST_F(CompensationLoop, BacklashAndScaleWrittenBackAndGone) {
  // Ideal loops, 20 um play and +100 ppm scale on X, nothing else.
  for (const char* axis : {"X", "Y", "Z"}) {
    set(std::string("KV_") + axis, "1000");
    set(std::string("BACKLASH_") + axis, "0");
    set(std::string("SCALE_") + axis, "0");
  }
  for (const char* sq : {"SQUARENESS_XY", "SQUARENESS_YZ", "SQUARENESS_ZX"}) set(sq, "0");
  set("BACKLASH_X", "0.020");
  set("SCALE_X", "100e-6");
  const std::string original = slurp(ini_);
  ASSERT_EQ(run(std::string(CIRCGEN_PATH) + " --d 150 --f 3000 --ini " + ini_ + " -o " +
                (out_ / "test.ngc").string()),
            0);
  const json before = measure("before");
  const fs::path trace = out_ / "before" / "trace.csv";
  // Provenance: the recorder wrote the SHA-256 of the INI that ran.
  const std::string sha = metadata(trace, "ini_sha256");
  ASSERT_EQ(sha.size(), 64u) << "no ini_sha256 in " << trace;

  // The diagnosis of these errors (circtest.diagnosis/1): the sim's injected values.
  const json diagnosis = {
      {"schema", "circtest.diagnosis/1"},
      {"units", "mm"},
      {"plane", "XY"},
      {"axes", {"X", "Y"}},
      {"backlash_mm", {{"X", 0.020}, {"Y", 0.0}}},
      {"scale_ppm", {{"X", 100.0}, {"Y", 0.0}}},
      {"standard_error",
       {{"backlash_mm", {{"X", 1e-4}, {"Y", 1e-4}}}, {"scale_ppm", {{"X", 1.0}, {"Y", 1.0}}}}},
      {"ini_sha256", sha},
      {"source", trace.string()}};
  const fs::path djson = out_ / "diagnosis.json";
  std::ofstream(djson) << diagnosis.dump();
  ASSERT_EQ(run(std::string(CIRCCOMP_PATH) + " apply --ini " + ini_ + " " + djson.string() + " >" +
                (out_ / "apply.log").string() + " 2>&1"),
            0)
      << slurp(out_ / "apply.log");
  EXPECT_TRUE(fs::exists(out_ / "machine" / "circtest-joint0.comp"));
  // The same correction again is refused: the INI is not the one measured any more.
  EXPECT_EQ(run(std::string(CIRCCOMP_PATH) + " apply --ini " + ini_ + " " + djson.string() +
                " >/dev/null 2>&1"),
            10);

  const json after = measure("after");  // the real linuxcnc starts the applied INI
  const double h0 = before["H"].get<double>(), h1 = after["H"].get<double>();
  const double g0 = worst_g(before), g1 = worst_g(after);
  std::cout << "H " << h0 * 1e3 << " -> " << h1 * 1e3 << " um, G " << g0 * 1e3 << " -> " << g1 * 1e3
            << " um\n";
  EXPECT_GT(h0, 0.015);  // the play shows before
  EXPECT_LT(h1, 0.15 * h0);
  EXPECT_LT(g1, 0.3 * g0);

  ASSERT_EQ(run(std::string(CIRCCOMP_PATH) + " revert --ini " + ini_ + " >/dev/null"), 0);
  EXPECT_EQ(slurp(ini_), original);
  EXPECT_FALSE(fs::exists(out_ / "machine" / "circtest-joint0.comp"));
}
