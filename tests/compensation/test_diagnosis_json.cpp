// The diagnosis JSON is one unit (core/diagnosis_document.hpp): circana writes a diagnosis of
// a simulated machine, the one reader reads it back (the whole document written again from it
// is the same), and circcomp's and the report's views of it come back with the same value and
// the same presence (a number stays a number, a null a null).
// A key renamed on one side only, or a value written in another type, fails here.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/html_report.hpp"
#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/trace_keys.hpp"
#include "expect_error.hpp"
#include "machine_sim.hpp"

using namespace circtest;
using nlohmann::json;

namespace {

// Same presence and, when present, the same double (the JSON keeps 17 digits: exact).
void expect_same(const std::optional<double>& written, const std::optional<double>& read,
                 const std::string& what) {
  ASSERT_EQ(written.has_value(), read.has_value()) << what;
  if (written) {
    EXPECT_EQ(*written, *read) << what;
  }
}

void expect_same(const Estimate& written, const compensation::Measured& read,
                 const std::string& what) {
  expect_same(written.value, read.value, what + " value");
  expect_same(written.standard_error, read.standard_error, what + " standard error");
}

struct RoundTrip {
  Diagnosis written;
  compensation::DiagnosisInput read;
};

RoundTrip round_trip(Plane plane) {
  sim::MachineModel m;
  const auto [a, b, normal] = plane_axes(plane);
  (void)normal;
  sim::AxisModel& first = a == 'x' ? m.x : a == 'y' ? m.y : m.z;
  sim::AxisModel& second = b == 'x' ? m.x : b == 'y' ? m.y : m.z;
  first.kv_per_s = 30.0;
  first.backlash_mm = 0.008;
  first.spike_mm = 0.004;
  first.spike_ms = 15.0;
  first.scale = 40e-6;
  second.kv_per_s = 33.0;
  second.cyclic_amplitude_mm = 0.002;
  second.cyclic_pitch_mm = 5.0;
  second.cyclic_phase_rad = 0.7;
  m.squareness_rad = 80e-6;
  m.noise_mm = 0.2e-3;
  sim::CircleProgram p;
  p.plane = plane;
  p.radius_mm = 50.0;
  p.feed_mm_per_min = 2000.0;
  Trace trace = sim::simulate(m, p);
  trace.metadata.set(meta_key::ini_sha256, std::string(64, 'a'));
  DiagnosisOptions o;
  o.pitch_mm[b] = 5.0;
  RoundTrip r;
  r.written = diagnose(trace, o);
  r.read = compensation::parse_diagnosis(to_json(r.written).dump(), "diagnosis.json");
  return r;
}

class DiagnosisJson : public ::testing::TestWithParam<Plane> {};

TEST_P(DiagnosisJson, EveryFieldCirccompReadsComesBackAsCircanaWroteIt) {
  const auto [d, in] = round_trip(GetParam());
  // The simulated machine makes every field a number, so a key lost on one side shows.
  for (int k = 0; k < 2; ++k) {
    ASSERT_TRUE(d.scale_ppm[k].value) << k;
    ASSERT_TRUE(d.backlash_mm[k].value) << k;
  }
  ASSERT_TRUE(d.backlash_mm[0].standard_error);
  ASSERT_TRUE(d.spike_mm[0].value);
  ASSERT_TRUE(d.spike_ms[0].value && d.spike_ms[0].standard_error);
  ASSERT_TRUE(d.squareness_urad.value && d.servo_mismatch_ms.value && d.kv_per_s.value);
  ASSERT_TRUE(d.scale_mismatch_ppm.value);
  ASSERT_TRUE(d.cyclic[1]);
  ASSERT_TRUE(d.ini_sha256);

  EXPECT_EQ(in.source, "diagnosis.json");
  EXPECT_EQ(in.diagnosis.plane, d.plane);
  EXPECT_EQ(in.diagnosis.axes, d.axes);
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string axis(1, d.axes[k]);
    expect_same(d.backlash_mm[k], in.diagnosis.backlash_mm[k], "backlash " + axis);
    expect_same(d.spike_mm[k], in.diagnosis.spike_mm[k], "spike " + axis);
    expect_same(d.spike_ms[k].value, in.diagnosis.spike_ms[k].value, "spike time " + axis);
    expect_same(d.spike_ms[k].standard_error, in.diagnosis.spike_ms[k].standard_error,
                "spike time se " + axis);
    expect_same(d.spike_peak_ms[k].value, in.diagnosis.spike_peak_ms[k].value,
                "spike peak " + axis);
    expect_same(d.scale_ppm[k], in.diagnosis.scale_ppm[k], "scale " + axis);
    ASSERT_EQ(d.cyclic[k].has_value(), in.diagnosis.cyclic[k].has_value()) << "cyclic " << axis;
    if (d.cyclic[k]) {
      EXPECT_EQ(d.cyclic[k]->amplitude_mm, in.diagnosis.cyclic[k]->amplitude_mm);
      EXPECT_EQ(d.cyclic[k]->pitch_mm, in.diagnosis.cyclic[k]->pitch_mm);
      EXPECT_EQ(d.cyclic[k]->phase_rad, in.diagnosis.cyclic[k]->phase_rad);
      expect_same(d.cyclic[k]->amplitude_se_mm, in.diagnosis.cyclic[k]->amplitude_se_mm,
                  "cyclic amplitude se " + axis);
    }
  }
  expect_same(d.scale_mismatch_ppm, in.diagnosis.scale_mismatch_ppm, "scale mismatch");
  expect_same(d.squareness_urad, in.diagnosis.squareness_urad, "squareness");
  expect_same(d.servo_mismatch_ms, in.diagnosis.servo_mismatch_ms, "servo mismatch");
  expect_same(d.kv_per_s.value, in.diagnosis.kv_per_s.value, "kv");
  EXPECT_EQ(d.ini_sha256, in.diagnosis.ini_sha256);
}

// Every reader of the document goes through one reader (core/diagnosis_document.hpp): read back,
// the diagnosis writes the same document again, key for key; the report's chart and circcomp's
// view are taken from it.
TEST_P(DiagnosisJson, TheOneReaderGivesBackTheWholeDocument) {
  const Diagnosis d = round_trip(GetParam()).written;
  const auto written = to_json(d);
  const DiagnosisDocument doc = parse_diagnosis_document(written.dump(), "d.json", "circcomp");
  ASSERT_EQ(doc.planes.size(), 1u);
  EXPECT_FALSE(doc.test_set);
  EXPECT_EQ(to_json(doc.planes.front()), written);
  // The report's reader: the same chart as from the diagnosis itself.
  const DiagnosisChart from_file = diagnosis_chart_from_document(doc, "d.json");
  const DiagnosisChart direct = diagnosis_chart(d);
  EXPECT_EQ(from_file.plane, direct.plane);
  EXPECT_EQ(from_file.source, direct.source);
  EXPECT_EQ(from_file.model_g_mm, direct.model_g_mm);
  EXPECT_EQ(from_file.residual_g_mm, direct.residual_g_mm);
  EXPECT_EQ(from_file.backlash_mm, direct.backlash_mm);
  EXPECT_EQ(from_file.squareness_urad, direct.squareness_urad);
  ASSERT_EQ(from_file.contributions.size(), direct.contributions.size());
  for (std::size_t i = 0; i < direct.contributions.size(); ++i) {
    EXPECT_EQ(from_file.contributions[i].source, direct.contributions[i].source);
    EXPECT_EQ(from_file.contributions[i].g_mm, direct.contributions[i].g_mm);
    EXPECT_EQ(from_file.contributions[i].percent, direct.contributions[i].percent);
    EXPECT_EQ(from_file.contributions[i].share_mm, direct.contributions[i].share_mm);
  }
  // A term listed as unseparable: no value for any reader.
  auto listed = written;
  listed["unseparable"] = {"squareness_urad"};
  const DiagnosisDocument u = parse_diagnosis_document(listed.dump(), "d.json", "circana");
  EXPECT_FALSE(u.planes.front().squareness_urad.value);
  EXPECT_FALSE(diagnosis_chart_from_document(u, "d.json").squareness_urad);
  EXPECT_FALSE(
      compensation::parse_diagnosis(listed.dump(), "d.json").diagnosis.squareness_urad.value);
}

INSTANTIATE_TEST_SUITE_P(Planes, DiagnosisJson, ::testing::Values(Plane::XY, Plane::YZ, Plane::ZX));

// The spike's peak time (circfric's rise is set from it): read as written, absent in a file
// of an older circana, refused when it is not a number.
TEST(DiagnosisJsonSpikePeak, ReadAsWrittenAbsentWhenOlderRefusedWhenNotANumber) {
  Diagnosis d = round_trip(Plane::XY).written;
  d.spike_peak_ms[0].value = 61.5;
  json doc = to_json(d);
  const auto in = compensation::parse_diagnosis(doc.dump(), "d.json");
  EXPECT_EQ(in.diagnosis.spike_peak_ms[0].value, 61.5);
  EXPECT_FALSE(in.diagnosis.spike_peak_ms[1].value);
  doc.erase("reversal_spike_peak_ms");
  EXPECT_FALSE(
      compensation::parse_diagnosis(doc.dump(), "d.json").diagnosis.spike_peak_ms[0].value);
  doc["reversal_spike_peak_ms"] = {{"X", "61 ms"}, {"Y", nullptr}};
  EXPECT_ERROR(compensation::parse_diagnosis(doc.dump(), "d.json"), ExitCode::parse,
               "\"reversal_spike_peak_ms.X\": expected a number or null");
}

// The measured G's U (k = 2), circana's evaluation's U_G: read back as written by the one
// reader, absent in a document of an older circana, refused when it is not a number; circcomp
// reads a document that holds it.
TEST(DiagnosisJsonMeasuredGU, ReadAsWrittenAbsentWhenOlderRefusedWhenNotANumber) {
  Diagnosis d = round_trip(Plane::XY).written;
  ASSERT_TRUE(d.measured_g_mm);
  d.measured_g_u_mm = 0.0044;
  auto doc = to_json(d);
  EXPECT_EQ(doc.at("residual").at("measured_G_U_mm"), 0.0044);
  const DiagnosisDocument back = parse_diagnosis_document(doc.dump(), "d.json", "circana");
  EXPECT_EQ(back.planes.front().measured_g_u_mm, 0.0044);
  EXPECT_EQ(to_json(back.planes.front()), doc);
  EXPECT_NO_THROW(compensation::parse_diagnosis(doc.dump(), "d.json"));
  doc["residual"].erase("measured_G_U_mm");
  EXPECT_FALSE(
      parse_diagnosis_document(doc.dump(), "d.json", "circana").planes.front().measured_g_u_mm);
  doc["residual"]["measured_G_U_mm"] = "4.4 um";
  EXPECT_ERROR(parse_diagnosis_document(doc.dump(), "d.json", "circana"), ExitCode::parse,
               "\"residual.measured_G_U_mm\": expected a number or null");
}

// A term the diagnosis lists as unseparable gives the planner no number, whatever value
// stands beside it; the others are read as written.
TEST(DiagnosisJsonUnseparable, AListedTermHasNoValue) {
  const Diagnosis d = round_trip(Plane::XY).written;
  json doc = to_json(d);
  ASSERT_TRUE(d.backlash_mm[0].value && d.servo_mismatch_ms.value);
  doc["unseparable"] = {"backlash_mm.X", "servo_mismatch_ms"};
  const auto in = compensation::parse_diagnosis(doc.dump(), "d.json");
  EXPECT_FALSE(in.diagnosis.backlash_mm[0].value);
  EXPECT_FALSE(in.diagnosis.backlash_mm[0].standard_error);
  EXPECT_FALSE(in.diagnosis.servo_mismatch_ms.value);
  expect_same(d.backlash_mm[1], in.diagnosis.backlash_mm[1], "backlash Y");
  expect_same(d.squareness_urad, in.diagnosis.squareness_urad, "squareness");
  EXPECT_EQ(in.diagnosis.unseparable,
            (std::vector<std::string>{"backlash_mm.X", "servo_mismatch_ms"}));
  doc["unseparable"] = "backlash_mm.X";
  EXPECT_ERROR(compensation::parse_diagnosis(doc.dump(), "d.json"), ExitCode::parse,
               "\"unseparable\": expected an array");
}

// A machine without errors: the values the trace cannot separate are written as null and read
// back as absent, never as zeros.
TEST(DiagnosisJsonNulls, WhatTheTraceCannotSeparateStaysAbsent) {
  sim::CircleProgram p;
  p.radius_mm = 50.0;
  p.feed_mm_per_min = 2000.0;
  const Diagnosis d = diagnose(sim::simulate(sim::MachineModel{}, p));
  const auto in = compensation::parse_diagnosis(to_json(d).dump(), "ideal.json");
  for (std::size_t k = 0; k < 2; ++k) {
    expect_same(d.spike_mm[k], in.diagnosis.spike_mm[k], "spike");
    expect_same(d.spike_ms[k].value, in.diagnosis.spike_ms[k].value, "spike time");
    EXPECT_FALSE(in.diagnosis.spike_peak_ms[k].value);
    EXPECT_EQ(d.cyclic[k].has_value(), in.diagnosis.cyclic[k].has_value());
  }
  expect_same(d.kv_per_s.value, in.diagnosis.kv_per_s.value, "kv");
  EXPECT_FALSE(in.diagnosis.ini_sha256);
}

// The version: written by circana, and a document of a newer major refused by the reader with
// the file named (exit 4); a newer minor only adds keys and is read.
// The JSON text of a diagnosis with `version` as its version's JSON text.
std::string with_version(const std::string& version_json) {
  static const std::string text = [] {
    sim::CircleProgram p;
    p.radius_mm = 50.0;
    auto j = to_json(diagnose(sim::simulate(sim::MachineModel{}, p)));
    j[diagnosis_json::key::version] = "@VERSION@";
    return j.dump();
  }();
  std::string out = text;
  out.replace(out.find("\"@VERSION@\""), 11, version_json);
  return out;
}

std::string quoted(const std::string& version) {
  return "\"" + version + "\"";
}

TEST(DiagnosisJsonVersion, WrittenAndNewerMajorsRefused) {
  sim::CircleProgram p;
  p.radius_mm = 50.0;
  const auto j = to_json(diagnose(sim::simulate(sim::MachineModel{}, p)));
  EXPECT_EQ(j.at("version"), "1.5");
  EXPECT_EQ(j.at("schema"), "circtest.diagnosis/1");
  EXPECT_NO_THROW(compensation::parse_diagnosis(with_version(quoted("1.0")), "d.json"));
  EXPECT_NO_THROW(compensation::parse_diagnosis(with_version(quoted("1.99")), "d.json"));
  EXPECT_NO_THROW(compensation::parse_diagnosis(with_version("null"), "d.json"));
  EXPECT_ERROR(compensation::parse_diagnosis(with_version(quoted("2.0")), "d.json"),
               ExitCode::parse,
               "d.json: \"version\": 2.0 is newer than this circcomp reads (1.x): use the "
               "circcomp of the circana that wrote it");
  EXPECT_ERROR(compensation::parse_diagnosis(with_version(quoted("10.3")), "d.json"),
               ExitCode::parse, "\"version\": 10.3 is newer than this circcomp reads");
  EXPECT_ERROR(compensation::parse_diagnosis(with_version(quoted("0.9")), "d.json"),
               ExitCode::parse,
               "d.json: \"version\": 0.9 does not match the schema circtest.diagnosis/1");
  for (const char* bad : {"2", "1.", ".1", "1.1.1", "v1.1", "-1.0", "1.x", "99999999.0", ""}) {
    EXPECT_ERROR(
        compensation::parse_diagnosis(with_version(quoted(bad)), "d.json"), ExitCode::parse,
        "d.json: \"version\": expected MAJOR.MINOR (\"1.5\"), got '" + std::string(bad) + "'");
  }
  EXPECT_ERROR(compensation::parse_diagnosis(with_version(quoted("\\u0001\\u00ff.1")), "d.json"),
               ExitCode::parse, "got '\\x01\\xc3\\xbf.1'");
  EXPECT_ERROR(compensation::parse_diagnosis(with_version("1.1"), "d.json"), ExitCode::parse,
               "d.json: \"version\": expected a string or null");
}

}  // namespace
