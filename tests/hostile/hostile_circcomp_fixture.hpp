#pragma once
// The fixture of the hostile circcomp tests (test_hostile_circcomp.cpp,
// test_hostile_circcomp_inputs.cpp): a machine configuration in a scratch folder beside files
// it must never touch, the programs run on it, and what changed outside it.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "circtest/core/sha256.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;

namespace {

using namespace circtest::testing;  // ScratchDir, slurp, spit, run_command

// What lies at a path, without following a link: kind, bytes (or link target) and mtime.
struct Seen {
  std::string kind;
  std::string content;
  long long mtime_ns = 0;
  bool operator==(const Seen&) const = default;
};
using Snapshot = std::map<std::string, Seen>;

// Everything below TOP but the folders SKIP and TOP/diagnoses (the tests' inputs).
inline Snapshot snapshot(const fs::path& top, const fs::path& skip) {
  Snapshot out;
  for (auto it = fs::recursive_directory_iterator(top); it != fs::recursive_directory_iterator();
       ++it) {
    const fs::path p = it->path();
    if (p == skip || p == top / "diagnoses") {
      it.disable_recursion_pending();
      continue;
    }
    struct stat st {};
    ::lstat(p.c_str(), &st);
    Seen s;
    s.mtime_ns = static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
    if (S_ISLNK(st.st_mode)) {
      s.kind = "link";
      s.content = fs::read_symlink(p).string();
    } else if (S_ISREG(st.st_mode)) {
      s.kind = "file";
      s.content = slurp(p);
    } else if (S_ISDIR(st.st_mode)) {
      s.kind = "dir";
    } else {
      s.kind = "other";
    }
    out[p.string()] = s;
  }
  return out;
}

// The paths whose kind, content or mtime differ; "" when none.
inline std::string changes(const Snapshot& before, const Snapshot& after) {
  std::string out;
  for (const auto& [path, seen] : before) {
    const auto it = after.find(path);
    if (it == after.end()) {
      out += path + " removed\n";
    } else if (!(it->second == seen)) {
      out += path + (it->second.content == seen.content ? " touched\n" : " changed\n");
    }
  }
  for (const auto& [path, seen] : after) {
    if (!before.count(path)) out += path + " created\n";
  }
  return out;
}

inline const char* kMachineIni =
    "[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n\n[KINS]\nKINEMATICS = trivkins "
    "coordinates=XYZ\nJOINTS = 3\n\n[HAL]\nHALFILE = mill.hal\n\n"
    "[JOINT_0]\nMIN_LIMIT = -300\nMAX_LIMIT = 300\nBACKLASH = 0.008\n\n"
    "[JOINT_1]\nMIN_LIMIT = -300\nMAX_LIMIT = 300\nBACKLASH = 0.008\n\n"
    "[JOINT_2]\nMIN_LIMIT = -300\nMAX_LIMIT = 300\n";

// A scratch folder holding the configuration cfg/ and, beside it, what must never be touched:
// a victim file, a victim folder, an /etc-like folder, another configuration and the
// stand-in circtest_kins.so.
class Hostile : public ::testing::Test {
 protected:
  void SetUp() override {
    cfg_ = top() / "cfg";
    fs::create_directories(cfg_);
    ini_ = (cfg_ / "m.ini").string();
    spit(ini_, kMachineIni);
    spit(cfg_ / "mill.hal", "loadrt trivkins coordinates=XYZ\nloadrt motmod\n");
    spit(top() / "victim.txt", "victim\n");
    fs::create_directories(top() / "victimdir");
    spit(top() / "victimdir" / "keep.txt", "keep\n");
    fs::create_directories(top() / "etc");
    spit(top() / "etc" / "passwd", "root:x:0:0\n");
    fs::create_directories(top() / "other");
    spit(top() / "other" / "m.ini", kMachineIni);
    spit(top() / "circtest_kins.so", "");
    // mtimes a second in the past, so that a rewrite with the same bytes shows too.
    for (const auto& e : fs::recursive_directory_iterator(top())) {
      fs::last_write_time(e.path(), fs::last_write_time(e.path()) - std::chrono::seconds(2));
    }
  }
  fs::path top() const { return scratch_.dir(); }

  // X backlash 2 um, X scale 40 ppm, SQUARENESS urad of squareness, for the INI as it is now.
  std::string diagnosis(double squareness_urad = 0.0, const std::string& extra = "") {
    const std::string json =
        R"({"schema": "circtest.diagnosis/1", "units": "mm", "plane": "XY",
    "backlash_mm": {"X": 0.002, "Y": 0.0}, "scale_ppm": {"X": 40.0, "Y": 0.0},
    "squareness_urad": )" +
        std::to_string(squareness_urad) + extra + R"(,
    "standard_error": {"backlash_mm": {"X": 1e-5, "Y": 1e-5}, "scale_ppm": {"X": 0.5, "Y": 0.5},
                       "squareness_urad": 0.5},
    "ini_sha256": ")" +
        circtest::sha256_hex(slurp(ini_)) + "\"}";
    fs::create_directories(top() / "diagnoses");
    const std::string path =
        (top() / "diagnoses" / ("d" + std::to_string(n_++) + ".json")).string();
    spit(path, json);
    return path;
  }

  CommandResult circcomp(std::vector<std::string> args) {
    args.insert(args.begin(), CIRCCOMP_PATH);
    return run_command(args, {"CIRCTEST_KINS_MODULE=" + (top() / "circtest_kins.so").string()});
  }
  CommandResult apply(const std::string& diagnosis_path) {
    return circcomp({"apply", "--ini", ini_, diagnosis_path});
  }
  CommandResult revert(std::vector<std::string> more = {}) {
    std::vector<std::string> args{"revert", "--ini", ini_};
    args.insert(args.end(), more.begin(), more.end());
    return circcomp(args);
  }
  void write_manifest(const std::string& text) {
    fs::create_directories(cfg_ / ".circcomp");
    spit(cfg_ / ".circcomp" / "manifest", text);
  }

  // RUN refused with CODE and WORDS; nothing outside cfg/ changed.
  template <class Run>
  void expect_refused(Run&& run, int code, const std::string& words) {
    const Snapshot before = snapshot(top(), cfg_);
    const CommandResult r = run();
    EXPECT_EQ(r.exit_code, code) << r.err << r.out;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
    EXPECT_EQ(changes(before, snapshot(top(), cfg_)), "") << r.err;
  }

  ScratchDir scratch_{"circtest-hostile-circcomp"};
  fs::path cfg_;
  std::string ini_;
  int n_ = 0;
};

inline std::string sha(const std::string& text) {
  return circtest::sha256_hex(text);
}

}  // namespace
