// circcomp from a test set's diagnosis (circana diagnose --json of a set: docs/diagnosis-json.md):
// the document read as one entry per plane with the joint per-axis values, each axis carried
// by the first plane that has it; the plan puts the squareness of every plane into
// circtest_kins at once and each axis's backlash into its joint once; the refusals.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/ini.hpp"
#include "compensation_test_support.hpp"
#include "expect_error.hpp"
#include "scratch.hpp"

using namespace circtest;
using namespace circtest::compensation;
using json = nlohmann::ordered_json;
using circtest::testing::change_of;
using circtest::testing::joint;
namespace K = diagnosis_json::key;

namespace {

json plane_doc(const std::string& plane, const std::string& a, const std::string& b,
               double squareness_urad) {
  json d;
  d[K::units] = "mm";
  d[K::schema] = diagnosis_json::kSchema;
  d[K::version] = diagnosis_json::kVersion;
  d[K::plane] = plane;
  d[K::axes] = {a, b};
  // The plane's own per-axis values: the set's joint ones replace them.
  d[K::backlash_mm] = {{a, 0.5}, {b, 0.5}};
  d[K::squareness_urad] = squareness_urad;
  d[K::standard_error] = {{K::squareness_urad, 0.5}};
  return d;
}

json set_doc() {
  json d;
  d[K::units] = "mm";
  d[K::schema] = diagnosis_json::kSchema;
  d[K::version] = diagnosis_json::kVersion;
  d[K::plane] = "XY,YZ,ZX";
  d[K::axes] = {"X", "Y", "Z"};
  d[K::backlash_mm] = {{"X", 0.010}, {"Y", 0.006}, {"Z", 0.008}};
  d[K::squareness_urad] = nullptr;
  d[K::standard_error] = {{K::backlash_mm, {{"X", 1e-4}, {"Y", 1e-4}, {"Z", 1e-4}}}};
  d[K::test_set] = {{K::planes, {"XY", "YZ", "ZX"}},
                    {K::diagnoses,
                     {plane_doc("XY", "X", "Y", 100.0), plane_doc("YZ", "Y", "Z", -60.0),
                      plane_doc("ZX", "Z", "X", 45.0)}}};
  return d;
}

}  // namespace

TEST(TestSetPlan, ReadsEachPlaneWithTheJointValuesEachAxisOnce) {
  const auto planes = parse_diagnosis_planes(set_doc().dump(), "set.json");
  ASSERT_EQ(planes.size(), 3u);
  EXPECT_EQ(planes[0].diagnosis.plane, Plane::XY);
  EXPECT_EQ(*planes[0].diagnosis.backlash_mm[0].value,
            0.010);  // the joint value, not the plane's 0.5
  EXPECT_EQ(*planes[0].diagnosis.backlash_mm[1].value, 0.006);
  EXPECT_EQ(*planes[0].diagnosis.backlash_mm[1].standard_error, 1e-4);
  // YZ: Y is XY's, Z is new.
  EXPECT_TRUE(planes[1].axis_in_earlier_plane[0]);
  EXPECT_FALSE(planes[1].diagnosis.backlash_mm[0].value);
  EXPECT_EQ(*planes[1].diagnosis.backlash_mm[1].value, 0.008);
  // ZX: both axes carried already.
  EXPECT_TRUE(planes[2].axis_in_earlier_plane[0]);
  EXPECT_TRUE(planes[2].axis_in_earlier_plane[1]);
  EXPECT_EQ(*planes[2].diagnosis.squareness_urad.value, 45.0);
}

TEST(TestSetPlan, SquarenessFromTheSetsJointFit) {
  json doc = set_doc();
  // The joint fit's squareness of YZ beside the plane's own -60: the joint one is planned.
  doc[K::test_set][K::squareness_urad] = {{"YZ", {{K::value, -59.7}, {K::standard_error, 0.17}}}};
  const auto planes = parse_diagnosis_planes(doc.dump(), "set.json");
  EXPECT_EQ(*planes[1].diagnosis.squareness_urad.value, -59.7);
  EXPECT_EQ(*planes[1].diagnosis.squareness_urad.standard_error, 0.17);
  // A plane the object does not name keeps its own.
  EXPECT_EQ(*planes[0].diagnosis.squareness_urad.value, 100.0);
  doc[K::test_set][K::squareness_urad]["YZ"] = 12.0;
  EXPECT_ERROR(parse_diagnosis_planes(doc.dump(), "set.json"), ExitCode::parse,
               "set.json: \"test_set.squareness_urad.YZ\": expected an object with value and "
               "standard_error");
  doc[K::test_set][K::squareness_urad] = "12";
  EXPECT_ERROR(parse_diagnosis_planes(doc.dump(), "set.json"), ExitCode::parse,
               "\"test_set.squareness_urad\": expected an object or null");
  doc[K::test_set][K::squareness_urad] = {{"XY", {{K::value, "x"}}}};
  EXPECT_ERROR(parse_diagnosis_planes(doc.dump(), "set.json"), ExitCode::parse,
               "\"test_set.squareness_urad.XY.value\": expected a number or null");
}

TEST(TestSetPlan, RefusesWhatIsNotASet) {
  // One plane's reader: a set is refused by name.
  EXPECT_ERROR(parse_diagnosis(set_doc().dump(), "set.json"), ExitCode::parse,
               "set.json: \"plane\": a test set (3 planes): read it plane by plane");
  json d = set_doc();
  d[K::plane] = "XY,YZ";
  EXPECT_ERROR(parse_diagnosis_planes(d.dump(), "set.json"), ExitCode::parse,
               "\"test_set.diagnoses\": the planes' diagnoses are XY,YZ,ZX, the document's plane "
               "says XY,YZ");
  d = set_doc();
  d.erase(K::test_set);
  EXPECT_ERROR(parse_diagnosis_planes(d.dump(), "set.json"), ExitCode::parse,
               "\"test_set\": expected an object");
  d = set_doc();
  d[K::test_set][K::diagnoses][1][K::plane] = "XZ";
  EXPECT_ERROR(parse_diagnosis_planes(d.dump(), "set.json"), ExitCode::parse,
               "expected XY, YZ or ZX, got 'XZ'");
}

TEST(TestSetPlan, ThreeSquarenessesIntoCircTestKinsAndEachBacklashOnce) {
  circtest::testing::ScratchDir s("circcomp-set");
  const std::string ini =
      s.write("m.ini",
              "[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n\n[KINS]\nKINEMATICS = trivkins "
              "coordinates=XYZ\nJOINTS = 3\n\n[HAL]\nHALFILE = mill.hal\n\n" +
                  joint(0) + joint(1) + joint(2));
  s.write("mill.hal", "loadrt trivkins coordinates=XYZ\n");
  PlanOptions o;
  o.only = {Correction::backlash, Correction::squareness};
  const Plan plan = make_plan(ini, parse_diagnosis_planes(set_doc().dump(), "set.json"), o);
  const FileChange* m = change_of(plan, "m.ini");
  ASSERT_TRUE(m);
  const IniDocument after = IniDocument::parse(m->after);
  EXPECT_EQ(after.get("KINS", "KINEMATICS"), "circtest_kins coordinates=XYZ");
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_XY"), "1.000000e-04");
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_YZ"), "-6.000000e-05");
  EXPECT_EQ(after.get("CIRCTEST_COMP", "SQUARENESS_ZX"), "4.500000e-05");
  EXPECT_EQ(after.get("JOINT_0", "BACKLASH"), "0.01");
  EXPECT_EQ(after.get("JOINT_1", "BACKLASH"), "0.006");
  EXPECT_EQ(after.get("JOINT_2", "BACKLASH"), "0.008");
  EXPECT_EQ(after.get_all("HAL", "HALFILE").size(), 2u);
  ASSERT_TRUE(change_of(plan, "mill.hal"));
  EXPECT_EQ(change_of(plan, "mill.hal")->after, "loadrt circtest_kins coordinates=XYZ\n");
  EXPECT_TRUE(plan.needs_kins_module);
  int loadrt = 0, backlash = 0;
  for (const std::string& c : plan.changes) {
    loadrt += c.find("loadrt trivkins -> loadrt circtest_kins") != std::string::npos;
    backlash += c.find("BACKLASH") != std::string::npos;
  }
  EXPECT_EQ(loadrt, 1);
  EXPECT_EQ(backlash, 3);
  // No "not in the diagnosis" notes for the axes an earlier plane carries.
  for (const std::string& n : plan.notes) EXPECT_EQ(n.find("null"), std::string::npos) << n;
}

TEST(TestSetPlan, FrictionAloneIsRefusedForASet) {
  circtest::testing::ScratchDir s("circcomp-set");
  const std::string ini =
      s.write("m.ini",
              "[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n\n[KINS]\nKINEMATICS = trivkins "
              "coordinates=XYZ\nJOINTS = 3\n\n" +
                  joint(0) + joint(1) + joint(2));
  PlanOptions o;
  o.only = {Correction::friction};
  o.friction_requested = true;
  EXPECT_ERROR(make_plan(ini, parse_diagnosis_planes(set_doc().dump(), "set.json"), o),
               ExitCode::usage,
               "friction is planned from one plane's diagnosis, not from a test set");
}

// Servo gains from a set: a note says why not (each axis's lag measured in different
// circles); asked for alone, a usage error naming the one-plane command.
TEST(TestSetPlan, ServoIsNotPlannedFromASetAndANoteSaysWhy) {
  circtest::testing::ScratchDir s("circcomp-set");
  const std::string ini =
      s.write("m.ini",
              "[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n\n[KINS]\nKINEMATICS = trivkins "
              "coordinates=XYZ\nJOINTS = 3\n\n" +
                  joint(0) + joint(1) + joint(2));
  const auto planes = parse_diagnosis_planes(set_doc().dump(), "set.json");
  const Plan plan = make_plan(ini, planes, PlanOptions{});
  bool noted = false;
  for (const auto& n : plan.notes) {
    noted = noted || n.find("servo gains are not planned from a test set") != std::string::npos;
  }
  EXPECT_TRUE(noted);
  PlanOptions o;
  o.only = {Correction::servo};
  o.servo_requested = true;
  EXPECT_ERROR(make_plan(ini, planes, o), ExitCode::usage,
               "servo is planned from one plane's diagnosis, not from a test set");
}
