#include "circtest/compensation/diagnosis_input.hpp"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"

namespace circtest::compensation {

namespace {

using json = nlohmann::json;

struct Reader {
  const std::string& source;

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw ParseError(source, 0, fmt::format("\"{}\": {}", key, what));
  }
  std::optional<double> number(const json& j, const std::string& key) const {
    if (j.is_null()) return std::nullopt;
    if (!j.is_number()) fail(key, "expected a number or null");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(key, "not finite");
    return v;
  }
  const json& member(const json& j, const std::string& key, const std::string& path) const {
    static const json null_value;
    if (!j.is_object()) fail(path, "expected an object");
    const auto it = j.find(key);
    return it == j.end() ? null_value : *it;
  }
  // {"X": v, "Y": v} for the plane's axes.
  std::array<std::optional<double>, 2> per_axis(const json& doc, const std::string& key,
                                                const std::array<char, 2>& axes) const {
    std::array<std::optional<double>, 2> out;
    const json& j = member(doc, key, key);
    if (j.is_null()) return out;
    for (int k = 0; k < 2; ++k) {
      const std::string a(1, axes[k]);
      out[k] = number(member(j, a, key), key + "." + a);
    }
    return out;
  }
};

}  // namespace

DiagnosisInput parse_diagnosis(const std::string& text, const std::string& source) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    throw ParseError(source, 0, std::string("not JSON: ") + e.what());
  }
  const Reader r{source};
  if (!doc.is_object() || doc.value("schema", "") != "circtest.diagnosis/1") {
    throw ParseError(source, 0,
                     "expected a circtest.diagnosis/1 document (circana diagnose --json)");
  }
  if (doc.value("units", "mm") != "mm") r.fail("units", "expected mm");
  DiagnosisInput d;
  d.source = source;
  const json& plane = doc["plane"];
  if (!plane.is_string()) r.fail("plane", "expected XY, YZ or ZX");
  d.plane = plane.get<std::string>();
  if (d.plane == "XY")
    d.axes = {'X', 'Y'};
  else if (d.plane == "YZ")
    d.axes = {'Y', 'Z'};
  else if (d.plane == "ZX")
    d.axes = {'Z', 'X'};
  else
    r.fail("plane", "expected XY, YZ or ZX, got '" + d.plane + "'");

  const json null_value;
  const json& se = doc.contains("standard_error") ? doc["standard_error"] : null_value;
  auto se_axis = [&](const std::string& key) {
    return se.is_object() ? r.per_axis(se, key, d.axes) : std::array<std::optional<double>, 2>{};
  };
  auto se_scalar = [&](const std::string& key) {
    return se.is_object() && se.contains(key) ? r.number(se[key], "standard_error." + key)
                                              : std::nullopt;
  };
  const auto backlash = r.per_axis(doc, "backlash_mm", d.axes);
  const auto backlash_se = se_axis("backlash_mm");
  const auto spike = r.per_axis(doc, "reversal_spike_mm", d.axes);
  const auto spike_se = se_axis("reversal_spike_mm");
  const auto spike_ms = r.per_axis(doc, "reversal_spike_ms", d.axes);
  const auto scale = r.per_axis(doc, "scale_ppm", d.axes);
  const auto scale_se = se_axis("scale_ppm");
  for (int k = 0; k < 2; ++k) {
    d.backlash_mm[k] = {backlash[k], backlash_se[k]};
    d.reversal_spike_mm[k] = {spike[k], spike_se[k]};
    d.reversal_spike_ms[k] = spike_ms[k];
    d.scale_ppm[k] = {scale[k], scale_se[k]};
  }
  auto scalar = [&](const std::string& key) {
    return Measured{r.number(doc.contains(key) ? doc[key] : null_value, key), se_scalar(key)};
  };
  d.scale_mismatch_ppm = scalar("scale_mismatch_ppm");
  d.squareness_urad = scalar("squareness_urad");
  d.servo_mismatch_ms = scalar("servo_mismatch_ms");
  d.kv_per_s = r.number(doc.contains("kv_per_s") ? doc["kv_per_s"] : null_value, "kv_per_s");
  if (doc.contains("cyclic") && doc["cyclic"].is_object()) {
    for (int k = 0; k < 2; ++k) {
      const std::string a(1, d.axes[k]);
      const json& c = r.member(doc["cyclic"], a, "cyclic");
      if (c.is_null()) continue;
      const auto amplitude = r.number(r.member(c, "amplitude_mm", "cyclic." + a), "cyclic." + a);
      const auto pitch = r.number(r.member(c, "pitch_mm", "cyclic." + a), "cyclic." + a);
      if (!amplitude || !pitch || *pitch <= 0)
        r.fail("cyclic." + a, "expected amplitude_mm, pitch_mm > 0");
      Cyclic cy;
      cy.amplitude_mm = *amplitude;
      cy.pitch_mm = *pitch;
      cy.phase_rad = r.number(r.member(c, "phase_rad", "cyclic." + a), "cyclic." + a).value_or(0.0);
      if (se.is_object() && se.contains("cyclic") && se["cyclic"].is_object()) {
        const json& cs = r.member(se["cyclic"], a, "standard_error.cyclic");
        if (cs.is_object()) {
          cy.amplitude_se_mm = r.number(r.member(cs, "amplitude_mm", "standard_error.cyclic"),
                                        "standard_error.cyclic." + a);
        }
      }
      d.cyclic[k] = cy;
    }
  }
  if (doc.contains("ini_sha256") && doc["ini_sha256"].is_string()) {
    d.ini_sha256 = doc["ini_sha256"].get<std::string>();
  }
  return d;
}

DiagnosisInput read_diagnosis(const std::string& path) {
  return parse_diagnosis(read_file(path), path);
}

}  // namespace circtest::compensation
