#pragma once
// The diagnosis document (circana diagnose --json, docs/diagnosis-json.md): its schema, version
// and keys, spelled once. circana writes it, circcomp and circana's report read it; compensation
// does not link analysis, so the names live here in core and a rename cannot split writer and
// readers.
#include <charconv>
#include <string>
#include <string_view>

#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"

namespace circtest::diagnosis_json {

// The schema names the document's kind and major version; a reader refuses another major.
inline constexpr const char* kSchema = "circtest.diagnosis/1";
inline constexpr const char* kSchemaFamily = "circtest.diagnosis/";
// "MAJOR.MINOR": the major is the schema's; a minor adds keys, never renames or retypes one,
// so a reader reads every minor of its major and refuses a newer major.
inline constexpr int kVersionMajor = 1;
inline constexpr int kVersionMinor = 5;
inline constexpr const char* kVersion = "1.5";

namespace key {
inline constexpr const char* units = "units";    // "mm"
inline constexpr const char* schema = "schema";  // kSchema
inline constexpr const char* version = "version";
inline constexpr const char* plane = "plane";  // "XY", "YZ" or "ZX"
inline constexpr const char* axes = "axes";    // the plane's two axis letters
inline constexpr const char* feeds_mm_per_min = "feeds_mm_per_min";
// Per-axis objects {"X": number|null, "Y": number|null}, keyed by the plane's axis letters.
inline constexpr const char* backlash_mm = "backlash_mm";
inline constexpr const char* backlash_reversals_mm = "backlash_reversals_mm";
inline constexpr const char* positive_end = "positive_end";
inline constexpr const char* negative_end = "negative_end";
inline constexpr const char* reversal_spike_mm = "reversal_spike_mm";
inline constexpr const char* reversal_spike_ms = "reversal_spike_ms";
// The time from the reversal to the spike's peak where the table sticks (null: peaks at it).
inline constexpr const char* reversal_spike_peak_ms = "reversal_spike_peak_ms";
inline constexpr const char* scale_ppm = "scale_ppm";
// Plane-wide numbers (or null).
inline constexpr const char* scale_mismatch_ppm = "scale_mismatch_ppm";
inline constexpr const char* squareness_urad = "squareness_urad";
inline constexpr const char* servo_mismatch_ms = "servo_mismatch_ms";
inline constexpr const char* radius_change_mm = "radius_change_mm";  // [{feed, dr}]
inline constexpr const char* feed_mm_per_min = "feed_mm_per_min";
inline constexpr const char* dr = "dr";
inline constexpr const char* kv_per_s = "kv_per_s";
inline constexpr const char* cyclic = "cyclic";  // per axis: object or null
inline constexpr const char* amplitude_mm = "amplitude_mm";
inline constexpr const char* pitch_mm = "pitch_mm";
inline constexpr const char* phase_rad = "phase_rad";
inline constexpr const char* pitch_source = "pitch_source";
inline constexpr const char* peak_to_median_power = "peak_to_median_power";
inline constexpr const char* centre_offset_mm = "centre_offset_mm";  // [a, b]
inline constexpr const char* contributions = "contributions";
inline constexpr const char* source = "source";  // of a contribution and of the document
inline constexpr const char* g_mm = "G_mm";
inline constexpr const char* percent = "percent";
inline constexpr const char* share_mm = "share_mm";
inline constexpr const char* model_g_mm = "model_G_mm";
inline constexpr const char* residual = "residual";
inline constexpr const char* rms_mm = "rms_mm";
// The same keys again under standard_error, holding each value's standard error.
inline constexpr const char* standard_error = "standard_error";
inline constexpr const char* kv_source = "kv_source";
inline constexpr const char* lag_ms = "lag_ms";
// Per axis: the following lag, its effective position gain, how it was measured
// ("feedback", "instrument", "feeds" or null); the lag difference; per feed the mismatch
// ellipse's G and its share of the measured G ([{feed_mm_per_min, G_mm, measured_G_mm,
// percent}]). axis_lag_ms is defined with the test set's keys below (the same key).
inline constexpr const char* axis_kv_per_s = "axis_kv_per_s";
inline constexpr const char* axis_lag_source = "axis_lag_source";
inline constexpr const char* axis_lag_mismatch_ms = "axis_lag_mismatch_ms";
inline constexpr const char* servo_share = "servo_share";
inline constexpr const char* measured_g_mm = "measured_G_mm";
inline constexpr const char* measured_g_u_mm = "measured_G_U_mm";  // its U (k = 2)
inline constexpr const char* nominal_radius_mm = "nominal_radius_mm";
inline constexpr const char* absolute_channels = "absolute_channels";
inline constexpr const char* runs = "runs";
inline constexpr const char* samples = "samples";
inline constexpr const char* ini_sha256 = "ini_sha256";
inline constexpr const char* notes = "notes";
// The terms the trace cannot tell apart, each by the key (and ".AXIS" for a per-axis one) its
// value would have: ["backlash_mm.X", "servo_mismatch_ms"]; those values are null (added in 1.3).
inline constexpr const char* unseparable = "unseparable";
// A test set's document (several planes in one trace): `plane` lists the planes ("XY,YZ,ZX"),
// `axes` every axis they cover, the per-axis objects above hold the joint values, and
// `test_set` holds the planes, their squarenesses, each axis's per-plane values with their
// agreement, and each plane's own diagnosis (docs/diagnosis-json.md).
inline constexpr const char* test_set = "test_set";
inline constexpr const char* planes = "planes";
inline constexpr const char* diagnoses = "diagnoses";
inline constexpr const char* agreement = "agreement";
inline constexpr const char* axis_lag_ms = "axis_lag_ms";  // per axis: its own following lag
inline constexpr const char* value = "value";
inline constexpr const char* chi2 = "chi2";
inline constexpr const char* dof = "dof";
inline constexpr const char* consistent = "consistent";
// How a test set's joint values were found: "one model across the set" (the planes' normal
// equations solved as one) or "planes joined" (the inverse-variance mean of the planes' own).
inline constexpr const char* method = "method";
}  // namespace key

// Checks a document's "version" (absent in documents written before it existed: 1.0). Throws
// ParseError naming SOURCE for a text that is not MAJOR.MINOR, a major other than the schema's
// older one, and a newer major, which READER ("circcomp") cannot read.
inline void check_version(std::string_view version, const std::string& source,
                          std::string_view reader) {
  const auto digits = [](std::string_view text, int& out) {
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
    return ec == std::errc() && end == text.data() + text.size() && !text.empty() &&
           text.size() <= 6 && text.find_first_not_of("0123456789") == std::string_view::npos;
  };
  const std::size_t dot = version.find('.');
  int major = 0, minor = 0;
  if (dot == std::string_view::npos || !digits(version.substr(0, dot), major) ||
      !digits(version.substr(dot + 1), minor)) {
    throw ParseError(source, 0,
                     std::string("\"") + key::version + "\": expected MAJOR.MINOR (\"" + kVersion +
                         "\"), got '" + printable_ascii(version.substr(0, 40)) + "'");
  }
  if (major > kVersionMajor) {
    throw ParseError(source, 0,
                     std::string("\"") + key::version + "\": " + printable_ascii(version) +
                         " is newer than this " + std::string(reader) + " reads (" +
                         std::to_string(kVersionMajor) + ".x): use the " + std::string(reader) +
                         " of the circana that wrote it");
  }
  if (major < kVersionMajor) {
    throw ParseError(source, 0,
                     std::string("\"") + key::version + "\": " + printable_ascii(version) +
                         " does not match the schema " + kSchema + " (expected " +
                         std::to_string(kVersionMajor) + ".x)");
  }
}

}  // namespace circtest::diagnosis_json
