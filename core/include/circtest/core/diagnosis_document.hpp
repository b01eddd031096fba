#pragma once
// The diagnosis document (`circtest.diagnosis/1`, docs/diagnosis-json.md) as one unit: the
// diagnosis of a plane (what circana's fit finds, analysis/diagnosis.hpp), its JSON written
// and read back, the schema and version check and the reader's limits. circana writes it,
// circcomp (compensation/diagnosis_input.hpp) and circana report read it, all through here:
// library circtest::diagnosis_document, in core because compensation does not link the
// analysis. The keys are spelled once, in diagnosis_keys.hpp.
#include <array>
#include <cstddef>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/core/plane.hpp"

namespace circtest {

// A fitted value with its standard error; both absent when the trace cannot separate it.
struct Estimate {
  std::optional<double> value;
  std::optional<double> standard_error;
};

struct CyclicEstimate {
  double amplitude_mm = 0.0;
  double pitch_mm = 0.0;
  double phase_rad = 0.0;  // d_axis = amplitude sin(2 pi pos / pitch + phase)
  double amplitude_se_mm = 0.0;
  std::string pitch_source;                    // "option" or "periodogram"
  std::optional<double> peak_to_median_power;  // periodogram: how far it stands out
};

struct FeedRadius {
  double feed_mm_per_min = 0.0;
  Estimate dr_mm;  // mean radius minus the nominal radius at this feed
};

struct Contribution {
  std::string source;     // "backlash X", "squareness", ...
  double g_mm = 0.0;      // range of this model term alone over a run (the largest over runs)
  double share_mm = 0.0;  // its part of the modelled G: term(max point) - term(min point)
  double percent = 0.0;   // share_mm / modelled G * 100
};

// The following lag of one axis: following error over velocity at constant feed.
struct AxisLag {
  Estimate lag_ms;
  std::optional<double> kv_per_s;  // effective position gain, 1000 / lag_ms
  // "feedback" (commanded minus motor feedback), "instrument" (commanded minus the measured
  // position, geometry fitted out) or "feeds" (mean lag from the radius change over a feed
  // sweep, split by the fitted mismatch); empty when not measurable.
  std::string source;
};

// What the lag mismatch makes of the circle at one feed.
struct ServoShare {
  double feed_mm_per_min = 0.0;
  double g_mm = 0.0;                    // G of the mismatch ellipse alone: v |lag_A - lag_B|
  std::optional<double> measured_g_mm;  // the largest G of the runs at this feed
  std::optional<double> percent;        // g_mm / measured_g_mm * 100
};

struct Diagnosis {
  std::string source;
  Plane plane = Plane::XY;
  std::array<char, 2> axes{'X', 'Y'};  // uppercase letters of A and B
  std::vector<double> feeds_mm_per_min;
  std::size_t runs = 0;
  std::size_t samples = 0;
  double radius_mm = 0.0;  // the nominal radius the deviations are taken from
  bool absolute_channels = true;

  std::array<Estimate, 2> backlash_mm;
  // Backlash step at the reversal at the + end and at the - end of each axis, when both are
  // covered (a local estimate from the steps in the residual plus the fitted backlash).
  std::array<std::optional<std::array<double, 2>>, 2> backlash_reversals_mm;
  std::array<Estimate, 2> spike_mm;
  std::array<Estimate, 2> spike_ms;
  // Time from the reversal to the spike's peak when the table sticks (the profile rises after
  // the reversal); no value when the spike is the decaying step that peaks at it.
  std::array<Estimate, 2> spike_peak_ms;
  std::array<Estimate, 2> scale_ppm;
  Estimate scale_mismatch_ppm;  // s_A - s_B
  Estimate squareness_urad;     // a_actual = a + alpha b
  Estimate servo_mismatch_ms;   // lag time of A minus lag time of B
  std::vector<FeedRadius> radius_change;
  Estimate kv_per_s;
  std::string kv_source;  // "feeds", "lag" or empty
  Estimate lag_ms;        // mean following lag of the axes (commanded columns)

  // The servo per axis (diagnosis/servo_axes.cpp): lag and gain, A minus B, per feed.
  std::array<AxisLag, 2> axis_lag;
  Estimate axis_lag_mismatch_ms;
  std::vector<ServoShare> servo_share;

  std::array<std::optional<CyclicEstimate>, 2> cyclic;
  std::array<Estimate, 2> centre_offset_mm;  // from the nominal centre (set-up, nuisance)

  std::vector<Contribution> contributions;  // ranked by g_mm
  double model_g_mm = 0.0;                  // G of the model without centring and radius
  double residual_rms_mm = 0.0;
  double residual_g_mm = 0.0;
  // The largest G (least squares centre) of the measured runs: residual_g_mm's share of it is
  // the part of G the model does not explain.
  std::optional<double> measured_g_mm;
  // Its expanded uncertainty U (k = 2): the evaluation's U_G (uncertainty budget), when the
  // diagnosis was made beside the evaluation (circana analyze, diagnose).
  std::optional<double> measured_g_u_mm;
  std::optional<std::string> ini_sha256;  // from the trace's metadata, when recorded
  // The terms this trace cannot tell apart, by where their values would be in the document
  // ("backlash_mm.X", "servo_mismatch_ms"): their values are not reported.
  std::vector<std::string> unseparable;
  std::vector<std::string> notes;
};

// A test set's document (several planes in one trace): each plane's own diagnosis, and what the
// set joined: per axis letter the joint values, per plane the squareness of the joint fit.
struct JointAxisValues {
  Estimate backlash_mm;
  Estimate spike_mm;
  Estimate spike_ms;
  Estimate scale_ppm;
};

struct DiagnosisDocument {
  // One plane's document: one entry. A test set's: each plane's own, in the set's order.
  std::vector<Diagnosis> planes;
  bool test_set = false;
  std::map<char, JointAxisValues> joint;            // a set's, by axis letter ('X')
  std::map<Plane, Estimate> joint_squareness_urad;  // a set's test_set.squareness_urad
  std::optional<std::string> ini_sha256;            // the document's own
  // Keys every circana diagnosis holds that a plane's document lacks (a hand-made one):
  // "contributions", "model_G_mm", "residual.G_mm"; a reader that needs them refuses.
  std::vector<std::string> absent;
};

// The reader's limits: a diagnosis is a few kB (a test set's some tens), objects four levels
// deep.
inline constexpr std::size_t kMaxDiagnosisBytes = std::size_t{4} << 20;
inline constexpr int kMaxDiagnosisDepth = 16;

// The head every diagnosis document starts with, a plane's and a test set's alike: units,
// schema, version, the plane (or the planes' list "XY,YZ"), the axes and the feeds.
nlohmann::ordered_json diagnosis_document_head(const std::string& plane,
                                               const std::vector<char>& axes,
                                               const std::vector<double>& feeds_mm_per_min);

nlohmann::ordered_json to_json(const Diagnosis& diagnosis);

// Reads a document written by to_json (or a test set's, analysis/test_set.hpp) in any minor
// version of its major; READER ("circcomp", "circana") is named in the refusal of a newer one.
// Keys absent are values absent; a term listed under "unseparable" has no value whatever the
// document holds beside it. Throws IoError (missing, a device, larger than
// kMaxDiagnosisBytes), ParseError (not JSON, nested deeper than kMaxDiagnosisDepth, a number
// beyond a double, another schema, a newer or older major, a "version" that is not
// MAJOR.MINOR, a key of the wrong type: the file and the key named) and DataError (a cyclic
// pitch outside 0.001..10000 mm).
DiagnosisDocument parse_diagnosis_document(const std::string& text, const std::string& source,
                                           std::string_view reader);
DiagnosisDocument read_diagnosis_document(const std::string& path, std::string_view reader);

}  // namespace circtest
