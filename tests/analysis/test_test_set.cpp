// Test sets (analysis/include/circtest/analysis/test_set.hpp): a set's trace split into its
// planes, the refusals of a set that cannot be split, and the planes' diagnoses joined (the
// joint value, the planes' agreement, the three squarenesses). Traces from the machine
// simulator's set program (tests/support/machine_sim).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "circtest/analysis/test_set.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace_keys.hpp"
#include "expect_error.hpp"
#include "machine_sim.hpp"

using namespace circtest;

namespace {

sim::TestSetProgram set_program(std::vector<Plane> planes, std::vector<double> feeds) {
  sim::TestSetProgram set;
  for (Plane p : planes) {
    sim::CircleProgram c;
    c.plane = p;
    c.radius_mm = 50.0;
    c.centre_mm[0] = 10.0;
    c.centre_mm[1] = -20.0;
    c.centre_mm[2] = 5.0;
    c.runs.clear();
    for (double f : feeds) {
      c.runs.push_back(Direction::CCW);
      c.runs.push_back(Direction::CW);
      c.run_feeds_mm_per_min.push_back(f);
      c.run_feeds_mm_per_min.push_back(f);
    }
    c.dwell_s = 0.1;
    set.planes.push_back(c);
  }
  return set;
}

Trace three_plane_trace(const sim::MachineModel& m) {
  return sim::simulate_set(m, set_program({Plane::XY, Plane::YZ, Plane::ZX}, {2000.0, 4000.0}));
}

void set_meta(Trace& t, const std::string& key, const std::string& value) {
  TraceMetadata m;
  for (const auto& [k, v] : t.metadata.entries()) {
    if (k != key) m.set(k, v);
  }
  m.set(key, value);
  t.metadata = m;
}

}  // namespace

TEST(TestSet, SinglePlaneTraceIsNoSet) {
  sim::CircleProgram p;
  const Trace t = sim::simulate(sim::MachineModel{}, p);
  EXPECT_FALSE(test_set_planes(t));
}

TEST(TestSet, ASinglePlanesSegmentsNameItsPlane) {
  sim::CircleProgram p;
  p.plane = Plane::YZ;
  Trace t = sim::simulate(sim::MachineModel{}, p);
  // circgen writes the plane for every program: the trace's own is fine, so is none.
  set_meta(t, meta_key::segments, "1:CCW:F1000:YZ,2:CW:F1000");
  EXPECT_FALSE(test_set_planes(t));
  set_meta(t, meta_key::segments, "1:CCW:F1000:YZ,2:CW:F1000:XY");
  EXPECT_ERROR(test_set_planes(t), ExitCode::parse,
               "metadata 'segments': entry '2:CW:F1000:XY' names the plane 'XY', the trace's "
               "plane is YZ");
}

TEST(TestSet, SplitsIntoPlanesInProgramOrder) {
  const Trace t = three_plane_trace(sim::MachineModel{});
  const auto planes = test_set_planes(t);
  ASSERT_TRUE(planes);
  ASSERT_EQ(planes->size(), 3u);
  const std::vector<PlaneTrace> split = split_test_set(t, *planes);
  ASSERT_EQ(split.size(), 3u);
  EXPECT_EQ(split[0].plane, Plane::XY);
  EXPECT_EQ(split[1].plane, Plane::YZ);
  EXPECT_EQ(split[2].plane, Plane::ZX);
  std::size_t rows = 0;
  for (const PlaneTrace& p : split) {
    rows += p.trace.rows();
    EXPECT_EQ(*p.trace.metadata.find(meta_key::plane), plane_name(p.plane));
    EXPECT_EQ(p.trace.values.size(), t.columns.size());
  }
  // The planes share the trace's rows out among them, none twice.
  EXPECT_EQ(rows, t.rows());
  EXPECT_EQ(*split[1].trace.metadata.find(meta_key::segments),
            "5:CCW:F2000,6:CW:F2000,7:CCW:F4000,8:CW:F4000");
  // Row lines are kept, so that messages name the set's lines.
  EXPECT_EQ(split[1].trace.line_of_row.front(), t.line_of_row[split[0].trace.rows()]);
  const Evaluation ev = evaluate(split[1].trace, {});
  EXPECT_EQ(ev.plane, Plane::YZ);
  EXPECT_EQ(ev.runs.size(), 4u);
  EXPECT_EQ(ev.runs.front().run.segment_id, 5);
}

TEST(TestSet, RefusesWhatCannotBeSplit) {
  const Trace good = three_plane_trace(sim::MachineModel{});
  const std::vector<Plane> planes = *test_set_planes(good);
  {
    Trace t = good;
    set_meta(t, meta_key::segments, "1:CCW:F2000:XY,2:CW:F2000");
    EXPECT_ERROR(split_test_set(t, planes), ExitCode::parse,
                 "entry '2:CW:F2000' names no plane: a test set's entries are id:DIR:Ffeed:PLANE");
  }
  {
    Trace t = good;
    set_meta(t, meta_key::segments, "1:CCW:F2000:XY,2:CW:F2000:XZ");
    EXPECT_ERROR(split_test_set(t, planes), ExitCode::parse,
                 "plane 'XZ' is not one of the set's planes (XY,YZ,ZX");
  }
  {
    Trace t = good;
    set_meta(t, meta_key::segments, "1:CCW:F2000:XY,1:CW:F2000:YZ");
    EXPECT_ERROR(split_test_set(t, planes), ExitCode::parse, "run id 1 is given twice");
  }
  {
    // Runs 1-4 announced only: run 5 has no plane.
    Trace t = good;
    set_meta(t, meta_key::segments, "1:CCW:F2000:XY,2:CW:F2000:XY,3:CCW:F4000:XY,4:CW:F4000:XY");
    EXPECT_ERROR(split_test_set(t, planes), ExitCode::data,
                 "segment 5: a run the metadata 'segments'");
  }
  {
    // Run 9 (ZX's first) said to be XY's: XY's runs resume after YZ's.
    Trace t = good;
    std::string segs;
    for (int id = 1; id <= 12; ++id) {
      const char* p = id <= 4 || id == 9 ? "XY" : (id <= 8 ? "YZ" : "ZX");
      segs += (id > 1 ? "," : "") + std::to_string(id) + ":CCW:F2000:" + p;
    }
    set_meta(t, meta_key::segments, segs);
    EXPECT_ERROR(split_test_set(t, planes), ExitCode::data,
                 "segment 9 (XY) comes after runs of YZ: a set's planes run one after another");
  }
  {
    // ZX announced but never run.
    Trace t = good;
    std::string segs;
    for (int id = 1; id <= 12; ++id) {
      segs += (id > 1 ? "," : "") + std::to_string(id) + ":CCW:F2000:" + (id <= 6 ? "XY" : "YZ");
    }
    set_meta(t, meta_key::segments, segs);
    EXPECT_ERROR(split_test_set(t, planes), ExitCode::data,
                 "plane ZX of the set has no run in the trace");
  }
  {
    Trace t = good;
    const std::size_t seg = *t.column_index(column_name::segment);
    t.columns.erase(t.columns.begin() + static_cast<std::ptrdiff_t>(seg));
    t.values.erase(t.values.begin() + static_cast<std::ptrdiff_t>(seg));
    EXPECT_ERROR(split_test_set(t, planes), ExitCode::data,
                 "a test set without a 'segment' column");
  }
  {
    Trace t = good;
    set_meta(t, meta_key::segments, "");
    TraceMetadata m;
    for (const auto& [k, v] : t.metadata.entries()) {
      if (k != meta_key::segments) m.set(k, v);
    }
    t.metadata = m;
    EXPECT_ERROR(split_test_set(t, planes), ExitCode::data, "without 'segments' metadata");
  }
}

TEST(TestSet, PlaneListsInMetadata) {
  EXPECT_EQ(parse_plane_list("XY, yz ,ZX")->size(), 3u);
  EXPECT_FALSE(parse_plane_list("XY,XY"));
  EXPECT_FALSE(parse_plane_list("XY,"));
  EXPECT_FALSE(parse_plane_list("XY,XZ"));
  // A repeated plane is refused where the trace is read, with its line.
  const std::string text = "# plane: XY,YZ,XY\nt,x,y\n0,1,2\n";
  EXPECT_ERROR(parse_trace(text, "set.csv"), ExitCode::parse,
               "set.csv:1: metadata 'plane': expected XY, YZ or ZX");
}

TEST(TestSet, JointValueAndAgreement) {
  auto plane = [](Plane p, double backlash_a_mm, double se_mm) {
    Diagnosis d;
    d.plane = p;
    const PlaneAxes ax = plane_axes(p);
    d.axes = {static_cast<char>(ax.first - 'a' + 'A'), static_cast<char>(ax.second - 'a' + 'A')};
    d.backlash_mm[0] = {backlash_a_mm, se_mm};
    d.squareness_urad = {12.0, 0.5};
    return d;
  };
  // X: 10 um +- 0.1 in XY (first axis) and, in ZX, X is the second axis: none given there.
  Diagnosis xy = plane(Plane::XY, 0.010, 0.0001);
  Diagnosis zx = plane(Plane::ZX, 0.0, 0.0001);
  zx.backlash_mm[1] = {0.0104, 0.0002};
  {
    const SetDiagnosis s = join_set_diagnoses("t", {xy, zx});
    const AxisJoint& x = s.axes.front();
    ASSERT_EQ(x.axis, 'X');
    ASSERT_EQ(x.backlash_mm.planes.size(), 2u);
    // Weights 1/0.1^2 and 1/0.2^2: (4 * 10 + 10.4) / 5 = 10.08 um, se 1/sqrt(125) mm.
    EXPECT_NEAR(*x.backlash_mm.joint.value, 0.01008, 1e-9);
    EXPECT_NEAR(*x.backlash_mm.joint.standard_error, 1.0 / std::sqrt(1e8 + 0.25e8), 1e-12);
    EXPECT_TRUE(x.backlash_mm.consistent);
    EXPECT_EQ(x.backlash_mm.dof, 1);
    ASSERT_TRUE(s.squareness_urad[0]);
    EXPECT_FALSE(s.squareness_urad[1]);
    ASSERT_TRUE(s.squareness_urad[2]);
    const auto j = to_json(s);
    namespace K = diagnosis_json::key;
    EXPECT_EQ(j[K::plane], "XY,ZX");
    EXPECT_EQ(j[K::test_set][K::agreement][K::backlash_mm]["X"]["ZX"][K::value], 0.0104);
    EXPECT_EQ(j[K::test_set][K::squareness_urad]["XY"][K::value], 12.0);
    EXPECT_TRUE(j[K::squareness_urad].is_null());
  }
  // 10 um against 14 um, each +- 0.2: chi2 = 200, the planes disagree.
  zx.backlash_mm[1] = {0.014, 0.0002};
  xy.backlash_mm[0] = {0.010, 0.0002};
  const SetDiagnosis s = join_set_diagnoses("t", {xy, zx});
  const AxisJoint& x = s.axes.front();
  EXPECT_FALSE(x.backlash_mm.consistent);
  EXPECT_NEAR(*x.backlash_mm.chi2, 200.0, 1e-6);
  // Widened by sqrt(chi2 / dof): the spread of the planes, not the fit's precision.
  EXPECT_NEAR(*x.backlash_mm.joint.standard_error, 0.0002 / std::sqrt(2.0) * std::sqrt(200.0),
              1e-9);
  ASSERT_FALSE(s.notes.empty());
  EXPECT_NE(s.notes.front().find("the planes disagree on X backlash"), std::string::npos)
      << s.notes.front();
  EXPECT_NE(s.notes.front().find("XY 10.000 um (+- 0.200) ZX 14.000 um"), std::string::npos)
      << s.notes.front();
  EXPECT_NE(text_report(s).find("DISAGREE"), std::string::npos);

  // Without standard errors: the plain mean, and more than 10 % apart is a disagreement.
  xy.backlash_mm[0] = {0.010, std::nullopt};
  zx.backlash_mm[1] = {0.0105, std::nullopt};
  const SetDiagnosis close = join_set_diagnoses("t", {xy, zx});
  EXPECT_NEAR(*close.axes.front().backlash_mm.joint.value, 0.01025, 1e-12);
  EXPECT_FALSE(close.axes.front().backlash_mm.joint.standard_error);
  EXPECT_TRUE(close.axes.front().backlash_mm.consistent);
  zx.backlash_mm[1] = {0.012, std::nullopt};
  const SetDiagnosis apart = join_set_diagnoses("t", {xy, zx});
  EXPECT_FALSE(apart.axes.front().backlash_mm.consistent);
  ASSERT_FALSE(apart.notes.empty());
  EXPECT_NE(apart.notes.front().find("the planes disagree on X backlash by more than 10 % (no "
                                     "standard errors): XY 10.000 um ZX 12.000 um"),
            std::string::npos)
      << apart.notes.front();
}

namespace {

// The simulated machine of the joint-fit tests: per-axis backlash, reversal spike and scale,
// the three squarenesses, and noise on the measured positions.
sim::MachineModel set_machine() {
  sim::MachineModel m;
  m.x.backlash_mm = 0.010;
  m.y.backlash_mm = 0.006;
  m.z.backlash_mm = 0.008;
  m.x.scale = 40e-6;
  m.y.scale = -30e-6;
  m.z.scale = 25e-6;
  m.x.spike_mm = 0.004;
  m.y.spike_mm = 0.003;
  m.z.spike_mm = 0.005;
  m.x.spike_ms = m.y.spike_ms = m.z.spike_ms = 15.0;
  m.squareness_xy_rad = 100e-6;
  m.squareness_yz_rad = -60e-6;
  m.squareness_zx_rad = 45e-6;
  m.noise_mm = 0.0005;
  m.seed = 7;
  return m;
}

SetDiagnosis diagnose_trace(const Trace& t) {
  const std::vector<PlaneTrace> split = split_test_set(t, *test_set_planes(t));
  std::vector<Evaluation> ev;
  for (const PlaneTrace& p : split) ev.push_back(evaluate(p.trace, {}));
  return diagnose_set(split, ev);
}

const AxisJoint& axis(const SetDiagnosis& s, char a) {
  for (const AxisJoint& j : s.axes) {
    if (j.axis == a) return j;
  }
  throw std::logic_error("no axis");
}

double plane_se(const JointEstimate& j, Plane p) {
  for (const PlaneEstimate& e : j.planes) {
    if (e.plane == p) return *e.estimate.standard_error;
  }
  throw std::logic_error("no plane");
}

// The set's trace without its commanded columns (no axis's own lag can be measured).
Trace without_commanded(Trace t) {
  for (const char* c : {"x_cmd", "y_cmd", "z_cmd"}) {
    const auto k = t.column_index(c);
    if (!k) continue;
    t.columns.erase(t.columns.begin() + static_cast<std::ptrdiff_t>(*k));
    t.values.erase(t.values.begin() + static_cast<std::ptrdiff_t>(*k));
  }
  return t;
}

// An axis in two planes of equal noise: its joint standard error is 1/sqrt(2) of each plane's.
void expect_root_two_gain(const JointEstimate& e) {
  ASSERT_EQ(e.planes.size(), 2u);
  for (const PlaneEstimate& p : e.planes) {
    EXPECT_NEAR(*e.joint.standard_error / *p.estimate.standard_error, 1.0 / std::sqrt(2.0), 0.03)
        << plane_name(p.plane);
  }
}

// A joint scale whose standard error is the loop's bound shared by the planes: about each
// plane's own, never the 1/sqrt(2) of independent noise.
void expect_systematic_scale(const JointEstimate& e) {
  ASSERT_EQ(e.planes.size(), 2u);
  for (const PlaneEstimate& p : e.planes) {
    const double ratio = *e.joint.standard_error / *p.estimate.standard_error;
    EXPECT_GT(ratio, 0.9) << plane_name(p.plane);
    EXPECT_LT(ratio, 1.1) << plane_name(p.plane);
  }
}

}  // namespace

TEST(TestSetJointFit, OneModelRecoversEachAxisAndTheThreeSquarenesses) {
  const sim::MachineModel m = set_machine();
  const SetDiagnosis s = diagnose_trace(three_plane_trace(m));
  EXPECT_TRUE(s.joint_fit);
  const sim::AxisModel* truth[] = {&m.x, &m.y, &m.z};
  for (const char a : {'X', 'Y', 'Z'}) {
    SCOPED_TRACE(std::string(1, a));
    const AxisJoint& j = axis(s, a);
    const sim::AxisModel& t = *truth[a - 'X'];
    ASSERT_TRUE(j.backlash_mm.joint.value && j.spike_mm.joint.value && j.scale_ppm.joint.value);
    // Within 0.1 um and 4 standard errors (about 10 nm here).
    EXPECT_NEAR(*j.backlash_mm.joint.value, t.backlash_mm, 1e-4);
    EXPECT_NEAR(*j.backlash_mm.joint.value, t.backlash_mm,
                4.0 * *j.backlash_mm.joint.standard_error);
    EXPECT_NEAR(*j.spike_mm.joint.value, t.spike_mm, 0.05 * t.spike_mm);
    EXPECT_NEAR(*j.scale_ppm.joint.value, t.scale * 1e6, 0.5);
    EXPECT_NEAR(*j.scale_ppm.joint.value, t.scale * 1e6, 4.0 * *j.scale_ppm.joint.standard_error);
    // Each axis is in two planes with the same noise: its joint standard error is about
    // 1/sqrt(2) of each plane's own; the scale's is mostly the loop's bound without feedback
    // columns (docs/diagnosis.md), the same servo in both planes, which does not average down.
    expect_root_two_gain(j.backlash_mm);
    expect_systematic_scale(j.scale_ppm);
    for (const JointEstimate* e : {&j.backlash_mm, &j.scale_ppm}) EXPECT_TRUE(e->consistent);
    // The following lag (none on this machine) shared too, from the planes' lag mismatches and
    // mean lags; the mean lags have no standard error, so neither has the joint lag. It is in
    // the convention of each plane's own axis lag (as the trace logs it): the same number.
    ASSERT_TRUE(j.lag_ms.joint.value);
    EXPECT_NEAR(*j.lag_ms.joint.value, 0.0, 0.01);
    EXPECT_FALSE(j.lag_ms.joint.standard_error);
    ASSERT_EQ(j.lag_ms.planes.size(), 2u);
    for (const PlaneEstimate& p : j.lag_ms.planes) {
      EXPECT_NEAR(*p.estimate.value, *j.lag_ms.joint.value, 0.01) << plane_name(p.plane);
      for (const Diagnosis& d : s.plane_diagnoses) {
        if (d.plane != p.plane) continue;
        const std::size_t k = d.axes[0] == a ? 0 : 1;
        EXPECT_EQ(*p.estimate.value, *d.axis_lag[k].lag_ms.value) << plane_name(p.plane);
      }
    }
    EXPECT_TRUE(j.lag_ms.consistent);
    EXPECT_LT(*j.spike_mm.joint.standard_error,
              std::min(plane_se(j.spike_mm, j.spike_mm.planes[0].plane),
                       plane_se(j.spike_mm, j.spike_mm.planes[1].plane)));
  }
  const double sq[] = {m.squareness_xy_rad, m.squareness_yz_rad, m.squareness_zx_rad};
  for (std::size_t p = 0; p < 3; ++p) {
    ASSERT_TRUE(s.squareness_urad[p] && s.squareness_urad[p]->value);
    EXPECT_NEAR(*s.squareness_urad[p]->value, sq[p] * 1e6, 1.0) << p;
  }
  const auto j = to_json(s);
  namespace K = diagnosis_json::key;
  EXPECT_EQ(j[K::test_set][K::method], "one model across the set");
  EXPECT_EQ(j[K::backlash_mm]["X"], *axis(s, 'X').backlash_mm.joint.value);
  EXPECT_EQ(j[K::test_set][K::squareness_urad]["YZ"][K::value], *s.squareness_urad[1]->value);
  EXPECT_NE(text_report(s).find("one least-squares model across the set"), std::string::npos);
  EXPECT_EQ(to_json(join_set_diagnoses("t", s.plane_diagnoses))[K::test_set][K::method],
            "planes joined");
}

TEST(TestSetJointFit, PlanesThatDisagreeAreFlagged) {
  // X's backlash 10 um where XY runs and 16 um where ZX runs: the ZX plane's rows from a second
  // simulation of the same program (same timing and noise) with the larger play.
  sim::MachineModel m = set_machine();
  Trace t = three_plane_trace(m);
  m.x.backlash_mm = 0.016;
  const Trace other = three_plane_trace(m);
  const std::vector<double>& seg = *t.column(column_name::segment);
  const auto zx = static_cast<std::size_t>(
      std::find_if(seg.begin(), seg.end(), [](double v) { return v >= 9.0; }) - seg.begin());
  for (std::size_t c = 0; c < t.values.size(); ++c)
    std::copy(other.values[c].begin() + static_cast<std::ptrdiff_t>(zx), other.values[c].end(),
              t.values[c].begin() + static_cast<std::ptrdiff_t>(zx));
  const SetDiagnosis s = diagnose_trace(t);
  const AxisJoint& x = axis(s, 'X');
  EXPECT_FALSE(x.backlash_mm.consistent);
  ASSERT_TRUE(x.backlash_mm.chi2);
  EXPECT_GT(*x.backlash_mm.chi2, 100.0);
  // The joint value lies between the planes', its standard error widened by sqrt(chi2 / dof):
  // the planes' spread, not the fit's precision.
  EXPECT_GT(*x.backlash_mm.joint.value, 0.0105);
  EXPECT_LT(*x.backlash_mm.joint.value, 0.0155);
  EXPECT_GT(*x.backlash_mm.joint.standard_error, 1e-3);
  EXPECT_TRUE(axis(s, 'Y').backlash_mm.consistent);
  EXPECT_TRUE(axis(s, 'Z').backlash_mm.consistent);
  const std::string text = text_report(s);
  EXPECT_NE(text.find("DISAGREE"), std::string::npos);
  ASSERT_FALSE(s.notes.empty());
  EXPECT_NE(s.notes.front().find("the planes disagree on X backlash beyond their standard "
                                 "errors"),
            std::string::npos)
      << s.notes.front();
}
TEST(TestSetJointFit, WithoutCommandedColumnsTheLagMismatchesStayThePlanes) {
  // No commanded columns: no plane's mean lag, so each plane's lag mismatch stays its own and
  // the planes share backlash, spike and scale alone: two planes of equal noise, 1/sqrt(2);
  // the per-axis scale then comes from the two feeds' radius change.
  const SetDiagnosis s = diagnose_trace(without_commanded(three_plane_trace(set_machine())));
  ASSERT_TRUE(s.joint_fit);
  for (const AxisJoint& j : s.axes) {
    SCOPED_TRACE(std::string(1, j.axis));
    expect_root_two_gain(j.backlash_mm);
    expect_systematic_scale(j.scale_ppm);
    EXPECT_FALSE(j.lag_ms.joint.standard_error);
  }
  EXPECT_NEAR(*axis(s, 'X').backlash_mm.joint.value, 0.010, 1e-4);
}

// A joint value outside every plane's own is never called agreeing (the probe's case: X
// reversal spike joint 5.25 +- 0.03 um, planes XY 9.08 +- 0.44 and ZX 9.17 +- 0.44).
TEST(TestSetJointFit, AJointValueOutsideThePlanesIsNeverAgreement) {
  AxisJoint x;
  x.axis = 'X';
  x.spike_mm.planes = {{Plane::XY, Estimate{9.08e-3, 0.44e-3}},
                       {Plane::ZX, Estimate{9.17e-3, 0.44e-3}}};
  // Planes that agree with each other, as the join finds them.
  x.spike_mm.chi2 = 0.02;
  x.spike_mm.dof = 1;
  x.spike_mm.consistent = true;
  const auto note =
      take_joint_value(x, x.spike_mm, Estimate{5.25e-3, 0.03e-3}, "reversal spike", "um", 1e3);
  EXPECT_FALSE(x.spike_mm.consistent);
  ASSERT_TRUE(note);
  EXPECT_NE(note->find("the joint X reversal spike 5.250 um is not what the planes found: XY "
                       "9.080 um (+- 0.440) ZX 9.170 um (+- 0.440)"),
            std::string::npos)
      << *note;
  // Widened by sqrt(chi2 / dof): chi2 of the planes about it on one dof per plane.
  const double chi2 = std::pow((9.08 - 5.25) / 0.44, 2) + std::pow((9.17 - 5.25) / 0.44, 2);
  ASSERT_TRUE(x.spike_mm.chi2);
  EXPECT_NEAR(*x.spike_mm.chi2, chi2, 1e-6);
  EXPECT_EQ(x.spike_mm.dof, 2);
  EXPECT_NEAR(*x.spike_mm.joint.standard_error, 0.03e-3 * std::sqrt(chi2 / 2), 1e-12);
  SetDiagnosis s;
  s.axes.push_back(x);
  EXPECT_NE(text_report(s).find("DISAGREE"), std::string::npos);
  EXPECT_EQ(text_report(s).find(" agree"), std::string::npos);

  // A joint value among the planes' agrees; one without standard errors far outside disagrees.
  AxisJoint y;
  y.axis = 'Y';
  y.backlash_mm.planes = {{Plane::XY, Estimate{9.08e-3, 0.44e-3}},
                          {Plane::YZ, Estimate{9.17e-3, 0.44e-3}}};
  EXPECT_FALSE(take_joint_value(y, y.backlash_mm, Estimate{9.1e-3, 0.3e-3}, "backlash", "um", 1e3));
  EXPECT_TRUE(y.backlash_mm.consistent);
  y.lag_ms.planes = {{Plane::XY, Estimate{2.0, std::nullopt}},
                     {Plane::YZ, Estimate{2.1, std::nullopt}}};
  EXPECT_TRUE(
      take_joint_value(y, y.lag_ms, Estimate{2.6, std::nullopt}, "following lag", "ms", 1.0));
  EXPECT_FALSE(y.lag_ms.consistent);
}
