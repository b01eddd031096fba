// Every LinuxCNC sample INI through `circgen --ini`: accepted, or refused for a real limit of
// that machine, checked against LinuxCNC's own INI reader (inivar). Prints why for each refusal.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "support.hpp"

namespace fs = std::filesystem;
using circtest::testing::run_circgen;
using circtest::testing::run_command;

namespace {

const fs::path kSamples = "/usr/share/doc/linuxcnc/examples/sample-configs";

std::optional<std::string> inivar(const std::string& ini, const std::string& section,
                                  const std::string& key) {
  const auto r = run_command({"/usr/bin/inivar", "-ini", ini, "-sec", section, "-var", key});
  if (r.exit_code != 0) return std::nullopt;
  std::string v = r.out;
  while (!v.empty() && (v.back() == '\n' || v.back() == ' ')) v.pop_back();
  return v;
}

// inivar does not follow #INCLUDE; the linuxcnc script expands them first, and so do we here.
std::string expanded(const fs::path& ini, const fs::path& dir) {
  const std::string text = circtest::testing::slurp(ini.string());
  if (text.find("#INCLUDE") == std::string::npos) return ini.string();
  std::string out;
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    end = end == std::string::npos ? text.size() : end + 1;
    const std::string line = text.substr(begin, end - begin);
    begin = end;
    if (line.rfind("#INCLUDE ", 0) == 0) {
      std::string name = line.substr(9);
      while (!name.empty() && std::isspace(static_cast<unsigned char>(name.back())))
        name.pop_back();
      const fs::path inc = ini.parent_path() / name;
      if (fs::exists(inc)) out += circtest::testing::slurp(inc.string()) + "\n";
    } else {
      out += line;
    }
  }
  const fs::path p = dir / (ini.filename().string() + ".expanded");
  circtest::testing::spit(p.string(), out);
  return p.string();
}

}  // namespace

TEST(SampleInis, EachIsAcceptedOrRefusedForARealLimit) {
  ASSERT_TRUE(fs::is_directory(kSamples));
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(kSamples)) {
    if (e.is_regular_file() && e.path().extension() == ".ini") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 300u);
  circtest::testing::ScratchDir scratch;
  const std::string out = scratch.file("t.ngc");
  // "... [AXIS_X] MIN_LIMIT = -254", "... [TRAJ] MAX_LINEAR_VELOCITY = 53.34"
  const std::regex named_limit(R"(\[(AXIS_[XYZ]|TRAJ)\] ([A-Z_]+) = (\S+)$)");
  const std::regex no_axis(R"(the machine has no ([XYZ]) axis)");
  // "FILE.ini:29: #INCLUDE without a file name": an include LinuxCNC cannot expand either.
  const std::regex broken_include(R"(\.ini:([0-9]+): #INCLUDE )");
  int accepted = 0, limits = 0, no_axes = 0, broken_includes = 0;
  for (const auto& path : files) {
    const auto r = run_circgen({"--d", "50", "--f", "500", "--ini", path.string(), "-o", out});
    const std::string name = fs::relative(path, kSamples).string();
    std::string why = r.err;
    while (!why.empty() && why.back() == '\n') why.pop_back();
    if (r.exit_code == 0) {
      ++accepted;
      continue;
    }
    std::smatch m;
    if (r.exit_code == 6 && std::regex_search(why, m, named_limit)) {
      // The limit named is the machine's: LinuxCNC reads the same value (or, with no key,
      // uses its default: 1 unit/s, 1 unit/s^2, +-1e99).
      const std::string section = m[1], key = m[2];
      const double ours = std::stod(m[3]);
      const auto theirs = inivar(expanded(path, scratch.path()), section, key);
      double expected = key == "MIN_LIMIT" ? -1e99 : key == "MAX_LIMIT" ? 1e99 : 1.0;
      if (theirs) expected = std::stod(*theirs);
      EXPECT_NEAR(ours, expected, 1e-9 * std::max(1.0, std::fabs(expected))) << name << ": " << why;
      ++limits;
    } else if (r.exit_code == 4 && std::regex_search(why, m, no_axis)) {
      const auto coordinates = inivar(expanded(path, scratch.path()), "TRAJ", "COORDINATES");
      if (coordinates) {
        EXPECT_EQ(coordinates->find(m[1].str()[0]), std::string::npos) << name << ": " << why;
      }
      ++no_axes;
    } else if ((r.exit_code == 3 || r.exit_code == 4) &&
               std::regex_search(why, m, broken_include)) {
      // The line named holds an #INCLUDE whose file is not there (or not named).
      const std::string text = circtest::testing::slurp(path.string());
      std::size_t at = 0;
      for (int line = 1; line < std::stoi(m[1]) && at != std::string::npos; ++line) {
        at = text.find('\n', at);
        if (at != std::string::npos) ++at;
      }
      ASSERT_NE(at, std::string::npos) << name;
      const std::string line = text.substr(at, text.find('\n', at) - at);
      ASSERT_EQ(line.rfind("#INCLUDE", 0), 0u) << name << ": " << line;
      std::string target = line.substr(8);
      target.erase(0, target.find_first_not_of(" \t"));
      while (!target.empty() && std::isspace(static_cast<unsigned char>(target.back())))
        target.pop_back();
      EXPECT_TRUE(target.empty() || !fs::exists(path.parent_path() / target))
          << name << ": " << why;
      ++broken_includes;
    } else {
      ADD_FAILURE() << name << ": refused for no real limit (exit " << r.exit_code << "): " << why;
      continue;
    }
    const auto at = why.find(path.string() + ": ");
    std::cout << "refused " << name << ": "
              << (at == std::string::npos ? why : why.substr(at + path.string().size() + 2))
              << "\n";
  }
  std::cout << files.size() << " sample INIs: " << accepted << " accepted, " << limits
            << " refused for a limit of the machine (soft limits, velocity), " << no_axes
            << " for an axis the machine does not have, " << broken_includes
            << " for an #INCLUDE that names no file there\n";
  EXPECT_EQ(accepted + limits + no_axes + broken_includes, static_cast<int>(files.size()));
  EXPECT_GT(accepted, 150);
}
