// circcomp plan --json (circtest.plan/1): every INI key a plan changes, with its file, section,
// values before and after and one line in plain words, and every other file it writes; read
// off the plan's files, so any kind of correction appears.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>

#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/compensation/plan_json.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/sha256.hpp"
#include "compensation_test_support.hpp"
#include "scratch.hpp"

using namespace circtest;
using namespace circtest::compensation;
using ojson = nlohmann::ordered_json;
using circtest::testing::joint;

namespace {

// X is joint 1 here, so that the words name the axis, not the joint.
std::string yxz_machine() {
  return "[TRAJ]\nCOORDINATES = Y X Z\nLINEAR_UNITS = mm\n\n[KINS]\nKINEMATICS = trivkins "
         "coordinates=YXZ\nJOINTS = 3\n\n[HAL]\nHALFILE = mill.hal\n\n" +
         joint(0) + joint(1, "BACKLASH = 0.008\nFF1 = 0\n") + joint(2);
}

DiagnosisInput diagnosis(const std::string& ini) {
  DiagnosisInput d;
  d.source = "d.json";
  d.diagnosis.plane = Plane::XY;
  d.diagnosis.axes = {'X', 'Y'};
  d.diagnosis.backlash_mm[0] = {0.0022, 1e-5};
  d.diagnosis.backlash_mm[1] = {0.0, 1e-5};
  d.diagnosis.squareness_urad = {100.0, 0.5};
  d.diagnosis.ini_sha256 = sha256_hex(read_file(ini));
  return d;
}

const ojson* change(const ojson& j, const std::string& section, const std::string& key) {
  for (const auto& c : j["changes"]) {
    if (c["section"] == section && c["key"] == key) return &c;
  }
  return nullptr;
}

std::string words(const ojson& j) {
  std::string all;
  for (const auto& c : j["changes"]) all += c["words"].get<std::string>() + "\n";
  return all;
}

}  // namespace

TEST(PlanJson, BacklashAndSquarenessInPlainWords) {
  circtest::testing::ScratchDir s("plan-json");
  const std::string ini = s.write("m.ini", yxz_machine());
  s.write("mill.hal", "loadrt trivkins coordinates=YXZ\nloadrt motmod\n");
  PlanOptions o;
  o.only = {Correction::backlash, Correction::squareness};
  const Plan plan = make_plan(ini, diagnosis(ini), o);
  const ojson j = plan_json(plan);
  EXPECT_EQ(j["schema"], "circtest.plan/1");
  const ojson* b = change(j, "JOINT_1", "BACKLASH");
  ASSERT_NE(b, nullptr) << j.dump(2);
  EXPECT_EQ((*b)["file"], ini);
  EXPECT_EQ((*b)["before"], "0.008");
  EXPECT_EQ((*b)["after"], "0.0102");
  EXPECT_EQ((*b)["words"], "X backlash 8.0 → 10.2 µm");
  const ojson* q = change(j, "CIRCTEST_COMP", "SQUARENESS_XY");
  ASSERT_NE(q, nullptr) << j.dump(2);
  EXPECT_TRUE((*q)["before"].is_null());
  EXPECT_EQ((*q)["words"], "squareness XY correction 0 → 100.0 µrad");
  EXPECT_EQ((*q)["effective"], true);
  EXPECT_EQ((*q)["kind"], "setting");
  EXPECT_EQ((*change(j, "KINS", "KINEMATICS"))["kind"], "wiring");
  // The other planes' values are written as 0: a change of the file without effect.
  const ojson* yz = change(j, "CIRCTEST_COMP", "SQUARENESS_YZ");
  ASSERT_NE(yz, nullptr);
  EXPECT_EQ((*yz)["effective"], false);
  const std::string all = words(j);
  EXPECT_NE(all.find("kinematics trivkins coordinates=YXZ → circtest_kins coordinates=YXZ"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("HAL file circtest-comp.hal added"), std::string::npos) << all;
  // The HAL file circcomp writes is listed as a file, with words of its own.
  EXPECT_NE(all.find("circtest-comp.hal created"), std::string::npos) << all;
  // Unchanged keys are not listed.
  EXPECT_EQ(change(j, "JOINT_1", "FF1"), nullptr);
  EXPECT_EQ(j["summary"].size(), plan.changes.size());
}

TEST(PlanJson, ACompensationTableIsReadAsBacklashAndScale) {
  circtest::testing::ScratchDir s("plan-json");
  const std::string ini = s.write("m.ini", yxz_machine());
  DiagnosisInput d = diagnosis(ini);
  d.diagnosis.scale_ppm[0] = {20.0, 0.5};
  d.diagnosis.scale_ppm[1] = {0.0, 0.5};
  PlanOptions o;
  o.only = {Correction::backlash, Correction::scale};
  const ojson j = plan_json(make_plan(ini, d, o));
  const std::string all = words(j);
  // The table holds the old and the new play (8 + 2.2 um) and the scale correction.
  EXPECT_NE(all.find("X compensation table circtest-joint1.comp created: backlash 0 → 10.2 µm, "
                     "scale correction 0 → -20.0 ppm"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("X compensation table (none) → circtest-joint1.comp"), std::string::npos)
      << all;
  EXPECT_NE(all.find("X backlash 8.0 → 0 µm"), std::string::npos) << all;
  for (const auto& c : j["changes"]) {
    if (c["section"].is_null()) {
      EXPECT_EQ(c["kind"], "setting") << c.dump();  // the table
    }
  }
}

// --json is an output of plan only: apply and revert refuse it before touching anything.
TEST(PlanJson, OnlyForPlan) {
  circtest::testing::ScratchDir s("plan-json");
  const std::string ini = s.write("m.ini", yxz_machine());
  for (const char* command : {"apply", "revert"}) {
    const std::string cmd = std::string(CIRCCOMP_PATH) + " " + command + " --ini " + ini +
                            " --json 2>" + (s.dir() / "err").string();
    const int rc = std::system(cmd.c_str());
    EXPECT_EQ(WEXITSTATUS(rc), 2) << command;
    EXPECT_NE(s.read("err").find("--json: only for circcomp plan"), std::string::npos)
        << s.read("err");
    EXPECT_EQ(read_file(ini), yxz_machine());
  }
}
