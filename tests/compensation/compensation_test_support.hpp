#pragma once
// What the circcomp library's tests on a fixture mill share (test_compensation.cpp,
// test_compensation_tables.cpp, and the INI sections of test_plan_json.cpp and
// test_test_set_plan.cpp): a scratch folder per test, the mill's INI, a diagnosis of X
// backlash, a plan of one correction, the change a plan makes to a file.
#include <string>

#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/sha256.hpp"
#include "scratch.hpp"

namespace circtest::testing {

// A private folder per test (ScratchDir, tests/support), named for the suite.
struct Scratch : ScratchDir {
  Scratch() : ScratchDir("circcomp") {}
};

inline std::string joint(int n, const std::string& extra = "") {
  return "[JOINT_" + std::to_string(n) + "]\nTYPE = LINEAR\nMIN_LIMIT = -300\nMAX_LIMIT = 300\n" +
         extra + "\n";
}

// A trivkins XYZ mill, X, Y, Z on joints 0, 1, 2 (+-300 mm); J0: joint 0's extra lines.
inline std::string machine(const std::string& kins = "trivkins coordinates=XYZ",
                           const std::string& j0 = "BACKLASH = 0.008\n") {
  return "# fixture mill\n[TRAJ]\nCOORDINATES = X Y Z\nLINEAR_UNITS = mm\n\n[KINS]\nKINEMATICS = " +
         kins + "\nJOINTS = 3\n\n" + joint(0, j0) + joint(1) + joint(2);
}

// A diagnosis with X backlash B (se 1e-5), Y zero, nothing else.
inline compensation::DiagnosisInput diag(double backlash_x, const std::string& ini_path = "") {
  compensation::DiagnosisInput d;
  d.source = "d.json";
  d.diagnosis.plane = Plane::XY;
  d.diagnosis.axes = {'X', 'Y'};
  d.diagnosis.backlash_mm[0] = {backlash_x, 1e-5};
  d.diagnosis.backlash_mm[1] = {0.0, 1e-5};
  if (!ini_path.empty()) d.diagnosis.ini_sha256 = sha256_hex(read_file(ini_path));
  return d;
}

inline compensation::PlanOptions only(compensation::Correction what) {
  compensation::PlanOptions o;
  o.only = {what};
  return o;
}

// The plan's change to the file whose path ends with SUFFIX, or null.
inline const compensation::FileChange* change_of(const compensation::Plan& plan,
                                                 const std::string& suffix) {
  for (const auto& f : plan.files) {
    if (f.path.ends_with(suffix)) return &f;
  }
  return nullptr;
}

}  // namespace circtest::testing
