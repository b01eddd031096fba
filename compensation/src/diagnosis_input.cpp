#include "circtest/compensation/diagnosis_input.hpp"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

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

DiagnosisInput parse_diagnosis(const std::string& text, const std::string& source) {
  const json doc = parse_json(text, source);
  const Reader r{source};
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
  const auto scale = r.per_axis(doc, K::scale_ppm, d.axes);
  const auto scale_se = se_axis(K::scale_ppm);
  for (int k = 0; k < 2; ++k) {
    d.backlash_mm[k] = {backlash[k], backlash_se[k]};
    d.reversal_spike_mm[k] = {spike[k], spike_se[k]};
    d.reversal_spike_ms[k] = spike_ms[k];
    d.reversal_spike_se_ms[k] = spike_ms_se[k];
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
  return d;
}

DiagnosisInput read_diagnosis(const std::string& path) {
  return parse_diagnosis(read_input_text(path, kMaxDiagnosisBytes), path);
}

}  // namespace circtest::compensation
