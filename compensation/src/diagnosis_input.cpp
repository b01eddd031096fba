#include "circtest/compensation/diagnosis_input.hpp"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/strings.hpp"

namespace circtest::compensation {

namespace {

using json = nlohmann::json;

namespace K = diagnosis_json::key;
using diagnosis_json::kSchema;
using diagnosis_json::kSchemaFamily;
// A diagnosis is a few kB with objects three levels deep.
constexpr int kMaxDepth = 16;
// A cyclic error's pitch: finer than 1 um or coarser than 10 m is no lead screw, rack or
// encoder period, and the pitch sizes the compensation table.
constexpr double kMinPitchMm = 1e-3;
constexpr double kMaxPitchMm = 1e4;

// Parses TEXT, refusing a document nested deeper than kMaxDepth; every library error becomes
// a ParseError naming SOURCE and, where it is known, the key being read.
json parse_json(const std::string& text, const std::string& source) {
  std::vector<std::string> keys;  // the key at each depth, down to the value being read
  const auto where = [&keys] {
    std::string path;
    for (const auto& k : keys) path += (path.empty() ? "" : ".") + k;
    return path.empty() ? std::string() : "\"" + path + "\": ";
  };
  json::parser_callback_t track = [&](int depth, json::parse_event_t event, json& parsed) {
    if (depth > kMaxDepth) {
      throw ParseError(
          source, 0,
          fmt::format("nested deeper than {} levels: not a circtest diagnosis", kMaxDepth));
    }
    if (event == json::parse_event_t::key) {
      keys.resize(static_cast<std::size_t>(std::max(depth, 1)));
      keys.back() = parsed.get<std::string>();
    } else if (event == json::parse_event_t::object_end ||
               event == json::parse_event_t::array_end) {
      keys.resize(static_cast<std::size_t>(std::max(depth, 0)));
    }
    return true;
  };
  try {
    return json::parse(text, track);
  } catch (const json::parse_error& e) {
    throw ParseError(source, 0, where() + "not JSON: " + printable_ascii(e.what()));
  } catch (const json::out_of_range& e) {
    throw ParseError(source, 0,
                     where() + "a number beyond a double's range: " + printable_ascii(e.what()));
  } catch (const json::exception& e) {
    throw ParseError(source, 0, where() + printable_ascii(e.what()));
  }
}

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
  std::optional<std::string> text(const json& j, const std::string& key) const {
    if (j.is_null()) return std::nullopt;
    if (!j.is_string()) fail(key, "expected a string or null");
    return j.get<std::string>();
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

namespace {

// The schema and version checks of a document (a whole one, or a test set's plane).
void check_schema(const json& doc, const Reader& r) {
  const std::string& source = r.source;
  if (!doc.is_object()) {
    throw ParseError(source, 0,
                     fmt::format("expected a {} document (circana diagnose --json)", kSchema));
  }
  const auto schema = r.text(r.member(doc, K::schema, K::schema), K::schema);
  if (schema && schema->starts_with(kSchemaFamily) && *schema != kSchema) {
    r.fail(K::schema, fmt::format("{} is a version this circcomp does not read (it reads {}): "
                                  "use the circcomp of the circana that wrote it",
                                  *schema, kSchema));
  }
  if (schema != kSchema) {
    throw ParseError(source, 0,
                     fmt::format("expected a {} document (circana diagnose --json)", kSchema));
  }
  // Absent in the documents written before the field: those are 1.0.
  if (const auto version = r.text(r.member(doc, K::version, K::version), K::version)) {
    diagnosis_json::check_version(*version, source, "circcomp");
  }
  if (r.text(r.member(doc, K::units, K::units), K::units).value_or("mm") != "mm") {
    r.fail(K::units, "expected mm");
  }
}

// The terms the diagnosis could not tell apart ("unseparable": ["backlash_mm.X", ...]) give
// the planner no number, whatever value stands beside them.
void clear_unseparable(const json& doc, const Reader& r, DiagnosisInput& d) {
  const json& list = r.member(doc, K::unseparable, K::unseparable);
  if (list.is_null()) return;
  if (!list.is_array()) r.fail(K::unseparable, "expected an array of keys or null");
  for (const json& item : list) {
    const auto name = r.text(item, K::unseparable);
    if (!name) r.fail(K::unseparable, "expected an array of keys");
    d.unseparable.push_back(*name);
    const std::string& key = *name;
    for (int k = 0; k < 2; ++k) {
      const std::string a = std::string(".") + d.axes[k];
      if (key == K::backlash_mm + a) d.backlash_mm[k] = {};
      if (key == K::reversal_spike_mm + a) {
        d.reversal_spike_mm[k] = {};
        d.reversal_spike_ms[k] = std::nullopt;
        d.reversal_spike_se_ms[k] = std::nullopt;
        d.reversal_spike_peak_ms[k] = std::nullopt;
      }
      if (key == K::scale_ppm + a) d.scale_ppm[k] = {};
      if (key == K::cyclic + a) d.cyclic[k] = std::nullopt;
    }
    if (key == K::scale_mismatch_ppm) d.scale_mismatch_ppm = {};
    if (key == K::squareness_urad) d.squareness_urad = {};
    if (key == K::servo_mismatch_ms) d.servo_mismatch_ms = {};
  }
}

// One plane's document, its schema checked.
DiagnosisInput parse_plane_document(const json& doc, const Reader& r) {
  const std::string& source = r.source;
  DiagnosisInput d;
  d.source = source;
  const auto plane = r.text(r.member(doc, K::plane, K::plane), K::plane);
  if (!plane) r.fail(K::plane, "expected XY, YZ or ZX");
  d.plane = *plane;
  if (d.plane == "XY")
    d.axes = {'X', 'Y'};
  else if (d.plane == "YZ")
    d.axes = {'Y', 'Z'};
  else if (d.plane == "ZX")
    d.axes = {'Z', 'X'};
  else
    r.fail(K::plane, "expected XY, YZ or ZX, got '" + d.plane + "'");

  const json null_value;
  const json& se = r.member(doc, K::standard_error, K::standard_error);
  if (!se.is_null() && !se.is_object()) r.fail(K::standard_error, "expected an object or null");
  auto se_axis = [&](const std::string& key) {
    return se.is_object() ? r.per_axis(se, key, d.axes) : std::array<std::optional<double>, 2>{};
  };
  auto se_scalar = [&](const std::string& key) {
    return se.is_object() ? r.number(r.member(se, key, K::standard_error), "standard_error." + key)
                          : std::nullopt;
  };
  const auto backlash = r.per_axis(doc, K::backlash_mm, d.axes);
  const auto backlash_se = se_axis(K::backlash_mm);
  const auto spike = r.per_axis(doc, K::reversal_spike_mm, d.axes);
  const auto spike_se = se_axis(K::reversal_spike_mm);
  const auto spike_ms = r.per_axis(doc, K::reversal_spike_ms, d.axes);
  const auto spike_ms_se = se_axis(K::reversal_spike_ms);
  const auto spike_peak_ms = r.per_axis(doc, K::reversal_spike_peak_ms, d.axes);
  const auto scale = r.per_axis(doc, K::scale_ppm, d.axes);
  const auto scale_se = se_axis(K::scale_ppm);
  for (int k = 0; k < 2; ++k) {
    d.backlash_mm[k] = {backlash[k], backlash_se[k]};
    d.reversal_spike_mm[k] = {spike[k], spike_se[k]};
    d.reversal_spike_ms[k] = spike_ms[k];
    d.reversal_spike_se_ms[k] = spike_ms_se[k];
    d.reversal_spike_peak_ms[k] = spike_peak_ms[k];
    d.scale_ppm[k] = {scale[k], scale_se[k]};
  }
  auto scalar = [&](const std::string& key) {
    return Measured{r.number(r.member(doc, key, key), key), se_scalar(key)};
  };
  d.scale_mismatch_ppm = scalar(K::scale_mismatch_ppm);
  d.squareness_urad = scalar(K::squareness_urad);
  d.servo_mismatch_ms = scalar(K::servo_mismatch_ms);
  d.kv_per_s = r.number(r.member(doc, K::kv_per_s, K::kv_per_s), K::kv_per_s);
  const auto lag = r.per_axis(doc, K::axis_lag_ms, d.axes);
  const auto lag_se = se_axis(K::axis_lag_ms);
  const json& lag_source = r.member(doc, K::axis_lag_source, K::axis_lag_source);
  for (int k = 0; k < 2; ++k) {
    d.axis_lag_ms[k] = {lag[k], lag_se[k]};
    if (lag_source.is_null()) continue;
    const std::string a(1, d.axes[k]);
    const std::string path = std::string(K::axis_lag_source) + "." + a;
    d.axis_lag_source[k] = r.text(r.member(lag_source, a, K::axis_lag_source), path).value_or("");
  }
  const json& cyclic = r.member(doc, K::cyclic, K::cyclic);
  if (!cyclic.is_null()) {
    for (int k = 0; k < 2; ++k) {
      const std::string a(1, d.axes[k]);
      const json& c = r.member(cyclic, a, K::cyclic);
      if (c.is_null()) continue;
      const auto amplitude = r.number(r.member(c, K::amplitude_mm, "cyclic." + a), "cyclic." + a);
      const auto pitch = r.number(r.member(c, K::pitch_mm, "cyclic." + a), "cyclic." + a);
      if (!amplitude || !pitch || *pitch <= 0)
        r.fail("cyclic." + a, "expected amplitude_mm, pitch_mm > 0");
      if (*pitch < kMinPitchMm || *pitch > kMaxPitchMm) {
        throw DataError(source, 0,
                        fmt::format("\"cyclic.{}.pitch_mm\": {} mm is no machine's pitch "
                                    "(expected {} to {} mm)",
                                    a, *pitch, kMinPitchMm, kMaxPitchMm));
      }
      Cyclic cy;
      cy.amplitude_mm = *amplitude;
      cy.pitch_mm = *pitch;
      cy.phase_rad =
          r.number(r.member(c, K::phase_rad, "cyclic." + a), "cyclic." + a).value_or(0.0);
      const json& se_cyclic =
          se.is_object() ? r.member(se, K::cyclic, K::standard_error) : null_value;
      if (se_cyclic.is_object()) {
        const json& cs = r.member(se_cyclic, a, "standard_error.cyclic");
        if (cs.is_object()) {
          cy.amplitude_se_mm = r.number(r.member(cs, K::amplitude_mm, "standard_error.cyclic"),
                                        "standard_error.cyclic." + a);
        }
      }
      d.cyclic[k] = cy;
    }
  }
  d.ini_sha256 = r.text(r.member(doc, K::ini_sha256, K::ini_sha256), K::ini_sha256);
  clear_unseparable(doc, r, d);
  return d;
}

// A test set's document: each plane's own (test_set.diagnoses) with the per-axis values the
// set joined (the top-level objects, keyed by every axis); an axis an earlier plane carries has
// its per-axis values cleared in the later ones, so that each axis is corrected once.
std::vector<DiagnosisInput> parse_set_document(const json& doc, const Reader& r,
                                               const std::string& planes) {
  const json& set = r.member(doc, K::test_set, K::test_set);
  const json& diagnoses = r.member(set, K::diagnoses, K::test_set);
  if (!diagnoses.is_array() || diagnoses.empty()) {
    r.fail(std::string(K::test_set) + "." + K::diagnoses,
           fmt::format("expected each plane's diagnosis (the planes {})", planes));
  }
  const json& se = r.member(doc, K::standard_error, K::standard_error);
  std::vector<DiagnosisInput> out;
  std::string seen;
  std::set<char> carried;
  for (const json& plane_doc : diagnoses) {
    check_schema(plane_doc, r);
    DiagnosisInput d = parse_plane_document(plane_doc, r);
    seen += (seen.empty() ? "" : ",") + d.plane;
    const auto joint = [&](const char* key) { return r.per_axis(doc, key, d.axes); };
    const auto joint_se = [&](const char* key) {
      return se.is_object() ? r.per_axis(se, key, d.axes) : std::array<std::optional<double>, 2>{};
    };
    const auto backlash = joint(K::backlash_mm), backlash_se = joint_se(K::backlash_mm);
    const auto spike = joint(K::reversal_spike_mm), spike_se = joint_se(K::reversal_spike_mm);
    const auto spike_ms = joint(K::reversal_spike_ms), spike_ms_se = joint_se(K::reversal_spike_ms);
    const auto scale = joint(K::scale_ppm), scale_se = joint_se(K::scale_ppm);
    for (int k = 0; k < 2; ++k) {
      if (!carried.insert(d.axes[k]).second) {
        d.axis_in_earlier_plane[k] = true;
        d.backlash_mm[k] = {};
        d.reversal_spike_mm[k] = {};
        d.reversal_spike_ms[k] = std::nullopt;
        d.reversal_spike_se_ms[k] = std::nullopt;
        d.scale_ppm[k] = {};
        d.cyclic[k] = std::nullopt;
        continue;
      }
      d.backlash_mm[k] = {backlash[k], backlash_se[k]};
      d.reversal_spike_mm[k] = {spike[k], spike_se[k]};
      d.reversal_spike_ms[k] = spike_ms[k];
      d.reversal_spike_se_ms[k] = spike_ms_se[k];
      d.scale_ppm[k] = {scale[k], scale_se[k]};
    }
    // The plane's squareness from the set's joint fit (test_set.squareness_urad) where the
    // document has it; a document without it keeps the plane's own.
    const json& squareness = r.member(set, K::squareness_urad, K::test_set);
    if (!squareness.is_null() && !squareness.is_object())
      r.fail(std::string(K::test_set) + "." + K::squareness_urad, "expected an object or null");
    if (squareness.is_object() && squareness.contains(d.plane)) {
      const json& e = squareness[d.plane];
      const std::string path = std::string(K::test_set) + "." + K::squareness_urad + "." + d.plane;
      if (!e.is_object()) r.fail(path, "expected an object with value and standard_error");
      const auto value = r.number(r.member(e, K::value, path), path + "." + K::value);
      if (value) {
        d.squareness_urad = {
            value, r.number(r.member(e, K::standard_error, path), path + "." + K::standard_error)};
      }
    }
    out.push_back(std::move(d));
  }
  if (seen != planes) {
    r.fail(std::string(K::test_set) + "." + K::diagnoses,
           fmt::format("the planes' diagnoses are {}, the document's plane says {}", seen, planes));
  }
  return out;
}

}  // namespace

DiagnosisInput parse_diagnosis(const std::string& text, const std::string& source) {
  std::vector<DiagnosisInput> planes = parse_diagnosis_planes(text, source);
  if (planes.size() > 1) {
    throw ParseError(source, 0,
                     fmt::format("\"{}\": a test set ({} planes): read it plane by plane", K::plane,
                                 planes.size()));
  }
  return std::move(planes.front());
}

std::vector<DiagnosisInput> parse_diagnosis_planes(const std::string& text,
                                                   const std::string& source) {
  const json doc = parse_json(text, source);
  const Reader r{source};
  check_schema(doc, r);
  const auto plane = r.text(r.member(doc, K::plane, K::plane), K::plane);
  if (plane && plane->find(',') != std::string::npos) {
    std::vector<DiagnosisInput> set = parse_set_document(doc, r, *plane);
    const auto sha = r.text(r.member(doc, K::ini_sha256, K::ini_sha256), K::ini_sha256);
    for (DiagnosisInput& d : set) d.ini_sha256 = sha;
    return set;
  }
  return {parse_plane_document(doc, r)};
}

DiagnosisInput read_diagnosis(const std::string& path) {
  return parse_diagnosis(read_input_text(path, kMaxDiagnosisBytes), path);
}

std::vector<DiagnosisInput> read_diagnosis_planes(const std::string& path) {
  return parse_diagnosis_planes(read_input_text(path, kMaxDiagnosisBytes), path);
}

}  // namespace circtest::compensation
