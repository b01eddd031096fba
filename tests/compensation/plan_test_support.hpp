#pragma once
// What the circcomp plan tests share: a fixture configuration copied into a scratch folder
// per test, and lookups in a Plan (a file by name, a line holding some words).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "circtest/compensation/plan.hpp"
#include "circtest/core/atomic_file.hpp"

namespace circtest::testing {

// A copy of the fixture folder ROOT/FIXTURE (with FIXTURE.ini) under the temporary folder,
// named after TAG, the process and the running test; removed when the test ends.
struct ConfigCopy {
  std::filesystem::path dir;
  std::string ini;
  ConfigCopy(const std::filesystem::path& root, const std::string& fixture,
             const std::string& tag) {
    dir = std::filesystem::temp_directory_path() /
          ("circcomp-" + tag + "-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    for (const auto& e : std::filesystem::directory_iterator(root / fixture)) {
      std::filesystem::copy_file(e.path(), dir / e.path().filename());
    }
    ini = (dir / (fixture + ".ini")).string();
  }
  ConfigCopy(const ConfigCopy&) = delete;
  ConfigCopy& operator=(const ConfigCopy&) = delete;
  ~ConfigCopy() { std::filesystem::remove_all(dir); }
  std::string path(const std::string& name) const { return (dir / name).string(); }
  std::string read(const std::string& name) const { return read_file(path(name)); }
  void write(const std::string& name, const std::string& text) const {
    std::ofstream(dir / name, std::ios::binary) << text;
  }
  // Every regular file of the folder (not .circcomp) with its bytes.
  std::map<std::string, std::string> files() const {
    std::map<std::string, std::string> out;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      if (e.is_regular_file()) out[e.path().filename().string()] = read_file(e.path().string());
    }
    return out;
  }
};

// The plan's change of the file called NAME, or null.
inline const compensation::FileChange* file_of(const compensation::Plan& plan,
                                               const std::string& name) {
  for (const auto& f : plan.files) {
    if (std::filesystem::path(f.path).filename() == name) return &f;
  }
  return nullptr;
}

// Whether one of LINES holds WORDS.
inline bool has_text(const std::vector<std::string>& lines, const std::string& words) {
  for (const auto& l : lines) {
    if (l.find(words) != std::string::npos) return true;
  }
  return false;
}

// LINES one per line, for a failure message.
inline std::string all(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

}  // namespace circtest::testing
