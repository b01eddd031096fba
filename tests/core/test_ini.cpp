// The lossless INI document: every LinuxCNC sample INI renders back byte-identical, lookups
// agree with LinuxCNC's own reader (`inivar`), and edits change only the lines they mean.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using circtest::IniDocument;

namespace {

const fs::path kSamples = "/usr/share/doc/linuxcnc/examples/sample-configs";

// LinuxCNC's demonstration of #INCLUDE errors (an empty #INCLUDE and a missing file on lines
// 29 and 30, "to show prints to stderr"): the script starts without them, IniDocument refuses.
const fs::path kIncludeErrorsDemo = kSamples / "sim/axis/ini_with_includes/includes_demo.ini";

// Every sample INI but the include-errors demo.
std::vector<fs::path> sample_inis() {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(kSamples)) {
    if (e.is_regular_file() && e.path().extension() == ".ini" && e.path() != kIncludeErrorsDemo) {
      out.push_back(e.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// A private folder per test (ScratchDir, tests/support), named for the suite.
struct Scratch : circtest::testing::ScratchDir {
  Scratch() : ScratchDir("circtest-ini") {}
};

// Runs LinuxCNC's INI reader; nullopt when it does not find the key.
std::optional<std::string> inivar(const std::string& ini, const std::string& section,
                                  const std::string& key, int num = 1) {
  const std::string cmd = "inivar -ini '" + ini + "' -sec '" + section + "' -var '" + key +
                          "' -num " + std::to_string(num) + " 2>/dev/null";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return std::nullopt;
  std::string out;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  const int rc = ::pclose(p);
  if (rc != 0) return std::nullopt;
  if (out.ends_with('\n')) out.pop_back();
  return out;
}

// (lines of ORIGINAL missing from EDITED, lines of EDITED not in ORIGINAL), as multisets.
std::pair<int, int> line_diff(const std::string& original, const std::string& edited) {
  auto split = [](const std::string& s) {
    std::vector<std::string> lines;
    std::istringstream in(s);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    std::sort(lines.begin(), lines.end());
    return lines;
  };
  const auto a = split(original), b = split(edited);
  std::vector<std::string> only_a, only_b;
  std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(only_a));
  std::set_difference(b.begin(), b.end(), a.begin(), a.end(), std::back_inserter(only_b));
  return {static_cast<int>(only_a.size()), static_cast<int>(only_b.size())};
}

}  // namespace

TEST(IniDocument, EveryLinuxcncSampleRendersByteIdentical) {
  ASSERT_TRUE(fs::is_directory(kSamples)) << "linuxcnc-uspace sample configs missing";
  const auto files = sample_inis();
  ASSERT_GE(files.size(), 300u);
  std::size_t with_includes = 0, continued = 0;
  for (const auto& path : files) {
    const IniDocument doc = IniDocument::load(path.string());
    for (std::size_t i = 0; i < doc.file_count(); ++i) {
      ASSERT_EQ(doc.render_file(i), circtest::read_file(doc.file_path(i))) << doc.file_path(i);
      EXPECT_FALSE(doc.file_modified(i));
    }
    with_includes += doc.file_count() > 1;
    continued += circtest::read_file(path.string()).find("\\\n") != std::string::npos;
  }
  // The set holds the cases that matter: #INCLUDEd sections and continuation lines.
  EXPECT_GE(with_includes, 5u);
  EXPECT_GE(continued, 1u);
}

TEST(IniDocument, LookupsAgreeWithLinuxcncInivar) {
  // LinuxCNC's own reader is the truth. inivar does not follow #INCLUDE (the linuxcnc script
  // expands those first), so files with includes are compared through their expansion below.
  // inivar costs ~25 ms a call: every 40th sample, plus every one with continuation lines.
  std::size_t compared = 0, index = 0;
  for (const auto& path : sample_inis()) {
    const IniDocument doc = IniDocument::load(path.string());
    const bool continued = doc.render().find("\\\n") != std::string::npos;
    if (doc.file_count() > 1 || (index++ % 40 != 0 && !continued)) continue;
    for (const std::string section : {"KINS", "TRAJ", "APPLICATIONS"}) {
      for (const auto& entry : doc.entries(section)) {
        const auto ours = doc.get(section, entry.key);
        const auto theirs = inivar(path.string(), section, entry.key);
        EXPECT_EQ(ours, theirs) << path << " [" << section << "] " << entry.key;
        ++compared;
      }
    }
    const auto halfiles = doc.get_all("HAL", "HALFILE");
    for (std::size_t i = 0; i < halfiles.size(); ++i) {
      EXPECT_EQ(halfiles[i].value, inivar(path.string(), "HAL", "HALFILE", static_cast<int>(i + 1)))
          << path;
      ++compared;
    }
    EXPECT_EQ(inivar(path.string(), "HAL", "HALFILE", static_cast<int>(halfiles.size() + 1)),
              std::nullopt)
        << path;
  }
  EXPECT_GT(compared, 150u) << compared;
}

TEST(IniDocument, IncludesReadInPlaceAsTheLinuxcncScriptExpandsThem) {
  try {
    IniDocument::load(kIncludeErrorsDemo.string());
    FAIL() << "no error";
  } catch (const circtest::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("includes_demo.ini:29: #INCLUDE without a file name"),
              std::string::npos)
        << e.what();
  }
  // The demo without its two error lines.
  Scratch s;
  fs::copy(kIncludeErrorsDemo.parent_path(), s.dir() / "demo");
  const fs::path ini = s.dir() / "demo" / kIncludeErrorsDemo.filename();
  std::string text = circtest::read_file(ini.string());
  text.replace(text.find("#INCLUDE\n#INCLUDE nosuchfile\n"), 29, "");
  circtest::write_file_atomic(ini.string(), text);
  const IniDocument doc = IniDocument::load(ini.string());
  EXPECT_GT(doc.file_count(), 10u);
  const auto kins = doc.find("KINS", "KINEMATICS");
  ASSERT_TRUE(kins);
  EXPECT_TRUE(kins->file.ends_with("kins.inc")) << kins->file;
  EXPECT_EQ(doc.get("JOINT_1", "TYPE"), "LINEAR");
  EXPECT_TRUE(doc.has_section("AXIS_Z"));
}

TEST(IniDocument, LinuxcncReadingRules) {
  const std::string text =
      "# comment = not a key\n"
      "[HAL]\n"
      "HALFILE = a.hal\n"
      "  ; indented comment\n"
      "HALFILE=b.hal\n"
      "just words without an equals sign\n"
      "EMPTY =\n"
      "APP = sim_pin a \\\n"
      "      b \\\n"
      "      c\n"
      "[hal]\n"
      "HALFILE = lower.hal\n"
      "[TRAJ]\r\n"
      "LINEAR_UNITS = mm  \r\n"
      "[HAL]\n"
      "HALFILE = second-section.hal\n";
  const IniDocument doc = IniDocument::parse(text, "t.ini");
  EXPECT_EQ(doc.get("HAL", "HALFILE"), "a.hal");
  const auto all = doc.get_all("HAL", "HALFILE");
  ASSERT_EQ(all.size(), 2u);  // only the first [HAL] counts, as in LinuxCNC
  EXPECT_EQ(all[1].value, "b.hal");
  EXPECT_EQ(all[1].line, 5u);
  EXPECT_EQ(doc.get("HAL", "EMPTY"), std::nullopt);
  EXPECT_EQ(doc.get("HAL", "APP"), "sim_pin a       b       c");
  EXPECT_EQ(doc.get("hal", "HALFILE"), "lower.hal");  // names are case-sensitive
  EXPECT_EQ(doc.get("TRAJ", "LINEAR_UNITS"), "mm");
  EXPECT_EQ(doc.get("HAL", "just"), std::nullopt);
  EXPECT_EQ(doc.render(), text);
}

TEST(IniDocument, SetChangesOnlyThatLine) {
  const std::string path = (kSamples / "sim/axis/axis_mm.ini").string();
  const std::string original = circtest::read_file(path);
  IniDocument doc = IniDocument::load(path);
  doc.set("JOINT_0", "COMP_FILE", "x.comp");  // new key: one line added
  EXPECT_EQ(line_diff(original, doc.render()), std::make_pair(0, 1));
  const auto added = doc.find("JOINT_0", "COMP_FILE");
  ASSERT_TRUE(added);
  EXPECT_EQ(added->line, 177u);  // after HOME_IS_SHARED, the section's last entry
  EXPECT_EQ(doc.get("JOINT_1", "COMP_FILE"), std::nullopt);
  doc.set("JOINT_0", "BACKLASH", "0.012");  // existing key: that line replaced
  EXPECT_EQ(line_diff(original, doc.render()), std::make_pair(1, 2));
  EXPECT_EQ(doc.get("JOINT_1", "BACKLASH"), "0.000");
  doc.set("KINS", "KINEMATICS", "circtest_kins coordinates=XYZ");
  EXPECT_EQ(line_diff(original, doc.render()), std::make_pair(2, 3));
  EXPECT_TRUE(doc.remove("JOINT_0", "COMP_FILE"));
  doc.set("JOINT_0", "BACKLASH", "0.000");
  doc.set("KINS", "KINEMATICS", "trivkins");
  EXPECT_EQ(doc.render(), original);
}

TEST(IniDocument, NewKeyGoesAfterTheSectionsLastEntryNotIntoItsTrailingComments) {
  IniDocument doc = IniDocument::parse("[A]\nX = 1\n\n# about B\n[B]\nY = 2");
  doc.set("A", "Z", "3");
  doc.append("B", "Y", "4");
  doc.set("C", "W", "5");
  EXPECT_EQ(doc.render(), "[A]\nX = 1\nZ = 3\n\n# about B\n[B]\nY = 2\nY = 4\n\n[C]\nW = 5\n");
  EXPECT_EQ(doc.get_all("B", "Y").size(), 2u);
  EXPECT_TRUE(doc.remove_value("B", "Y", "2"));
  EXPECT_EQ(doc.get("B", "Y"), "4");
}

TEST(IniDocument, CrlfFilesGetCrlfLines) {
  const std::string text = "[JOINT_0]\r\nTYPE = LINEAR\r\nBACKLASH=0.01\r\n";
  IniDocument doc = IniDocument::parse(text);
  doc.set("JOINT_0", "BACKLASH", "0.02");
  doc.set("JOINT_0", "COMP_FILE", "x.comp");
  doc.comment_before("JOINT_0", "BACKLASH", "why");
  EXPECT_EQ(doc.render(),
            "[JOINT_0]\r\nTYPE = LINEAR\r\n# why\r\nBACKLASH=0.02\r\nCOMP_FILE = x.comp\r\n");
}

TEST(IniDocument, ContinuedValueBecomesOneLine) {
  IniDocument doc = IniDocument::parse("[A]\nK = a \\\n  b\nL = 1\n");
  EXPECT_EQ(doc.get("A", "K"), "a   b");
  doc.set("A", "K", "c");
  EXPECT_EQ(doc.render(), "[A]\nK = c\nL = 1\n");
}

TEST(IniDocument, EditInIncludedFileChangesThatFileOnly) {
  Scratch s;
  const std::string inc_text = "[JOINT_0]\nTYPE = LINEAR\n";
  const std::string main_text = "[EMC]\nVERSION = 1.1\n#INCLUDE joints.inc\n[HAL]\nHALFILE = x\n";
  s.write("joints.inc", inc_text);
  const std::string ini = s.write("m.ini", main_text);
  IniDocument doc = IniDocument::load(ini);
  ASSERT_EQ(doc.file_count(), 2u);
  doc.set("JOINT_0", "BACKLASH", "0.004");
  EXPECT_FALSE(doc.file_modified(0));
  EXPECT_TRUE(doc.file_modified(1));
  EXPECT_EQ(doc.render(), main_text);
  EXPECT_EQ(doc.render_file(1), inc_text + "BACKLASH = 0.004\n");
  EXPECT_EQ(doc.get("HAL", "HALFILE"), "x");
}

TEST(IniDocument, LoadRefusesWhatIsNoIniFile) {
  Scratch s;
  EXPECT_THROW(IniDocument::load(s.dir().string()), circtest::IoError);
  EXPECT_THROW(IniDocument::load("/dev/zero"), circtest::IoError);
  EXPECT_THROW(IniDocument::load((s.dir() / "missing.ini").string()), circtest::IoError);
  // LinuxCNC would start without an include it cannot read: refused, naming the INI's line.
  const std::string missing_include = s.write("a.ini", "[A]\n#INCLUDE nowhere.inc\nK = 1\n");
  try {
    IniDocument::load(missing_include);
    FAIL() << "no error";
  } catch (const circtest::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("a.ini:2: #INCLUDE nowhere.inc: "), std::string::npos)
        << e.what();
  }
  const std::string long_line = s.write("b.ini", "[A]\nK = " + std::string(2u << 20, 'x') + "\n");
  try {
    IniDocument::load(long_line);
    FAIL() << "no error";
  } catch (const circtest::ParseError& e) {
    EXPECT_EQ(e.line(), 2u);
  }
}
