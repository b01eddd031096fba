// The diagnosis document: written and read in one place (diagnosis_document.hpp).
#include "circtest/core/diagnosis_document.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/strings.hpp"

namespace circtest {

namespace {

using json = nlohmann::ordered_json;
namespace K = diagnosis_json::key;

json per_axis(const Diagnosis& d, const std::array<Estimate, 2>& e, bool se = false) {
  json j = json::object();
  for (std::size_t k = 0; k < 2; ++k) {
    j[std::string(1, d.axes[k])] = json_number_or_null(se ? e[k].standard_error : e[k].value);
  }
  return j;
}

}  // namespace

json diagnosis_document_head(const std::string& plane, const std::vector<char>& axes,
                             const std::vector<double>& feeds_mm_per_min) {
  json j;
  j[K::units] = "mm";
  j[K::schema] = diagnosis_json::kSchema;
  j[K::version] = diagnosis_json::kVersion;
  j[K::plane] = plane;
  json names = json::array();
  for (const char a : axes) names.push_back(std::string(1, a));
  j[K::axes] = names;
  j[K::feeds_mm_per_min] = feeds_mm_per_min;
  return j;
}

json to_json(const Diagnosis& d) {
  json j = diagnosis_document_head(std::string(plane_name(d.plane)), {d.axes[0], d.axes[1]},
                                   d.feeds_mm_per_min);
  j[K::backlash_mm] = per_axis(d, d.backlash_mm);
  // The step at each end of the axis' travel on its own (added in circtest.diagnosis/1).
  json ends = json::object();
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& e = d.backlash_reversals_mm[k];
    ends[std::string(1, d.axes[k])] =
        e ? json{{K::positive_end, (*e)[0]}, {K::negative_end, (*e)[1]}} : json(nullptr);
  }
  j[K::backlash_reversals_mm] = ends;
  j[K::reversal_spike_mm] = per_axis(d, d.spike_mm);
  j[K::reversal_spike_ms] = per_axis(d, d.spike_ms);
  j[K::reversal_spike_peak_ms] = per_axis(d, d.spike_peak_ms);
  j[K::scale_ppm] = per_axis(d, d.scale_ppm);
  j[K::scale_mismatch_ppm] = json_number_or_null(d.scale_mismatch_ppm.value);
  j[K::squareness_urad] = json_number_or_null(d.squareness_urad.value);
  j[K::servo_mismatch_ms] = json_number_or_null(d.servo_mismatch_ms.value);
  json rc = json::array();
  for (const auto& fr : d.radius_change) {
    rc.push_back(
        {{K::feed_mm_per_min, fr.feed_mm_per_min}, {K::dr, json_number_or_null(fr.dr_mm.value)}});
  }
  j[K::radius_change_mm] = rc;
  j[K::kv_per_s] = json_number_or_null(d.kv_per_s.value);
  json cyc = json::object();
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& c = d.cyclic[k];
    cyc[std::string(1, d.axes[k])] =
        c ? json{{K::amplitude_mm, c->amplitude_mm},
                 {K::pitch_mm, c->pitch_mm},
                 {K::phase_rad, c->phase_rad},
                 {K::pitch_source, c->pitch_source},
                 {K::peak_to_median_power, json_number_or_null(c->peak_to_median_power)}}
          : json(nullptr);
  }
  j[K::cyclic] = cyc;
  j[K::centre_offset_mm] = {json_number_or_null(d.centre_offset_mm[0].value),
                            json_number_or_null(d.centre_offset_mm[1].value)};
  json con = json::array();
  for (const auto& c : d.contributions) {
    con.push_back({{K::source, c.source},
                   {K::g_mm, c.g_mm},
                   {K::percent, c.percent},
                   {K::share_mm, c.share_mm}});
  }
  j[K::contributions] = con;
  j[K::model_g_mm] = d.model_g_mm;
  j[K::residual] = {{K::rms_mm, d.residual_rms_mm}, {K::g_mm, d.residual_g_mm}};
  if (d.measured_g_mm) {
    j[K::residual][K::measured_g_mm] = *d.measured_g_mm;
    if (d.measured_g_u_mm) j[K::residual][K::measured_g_u_mm] = *d.measured_g_u_mm;
    j[K::residual][K::percent] = json_number_or_null(
        *d.measured_g_mm > 0 ? std::optional(d.residual_g_mm / *d.measured_g_mm * 100.0)
                             : std::nullopt);
  }
  json se;
  se[K::backlash_mm] = per_axis(d, d.backlash_mm, true);
  se[K::reversal_spike_mm] = per_axis(d, d.spike_mm, true);
  se[K::reversal_spike_ms] = per_axis(d, d.spike_ms, true);
  se[K::scale_ppm] = per_axis(d, d.scale_ppm, true);
  se[K::scale_mismatch_ppm] = json_number_or_null(d.scale_mismatch_ppm.standard_error);
  se[K::squareness_urad] = json_number_or_null(d.squareness_urad.standard_error);
  se[K::servo_mismatch_ms] = json_number_or_null(d.servo_mismatch_ms.standard_error);
  json rcs = json::array();
  for (const auto& fr : d.radius_change) {
    rcs.push_back({{K::feed_mm_per_min, fr.feed_mm_per_min},
                   {K::dr, json_number_or_null(fr.dr_mm.standard_error)}});
  }
  se[K::radius_change_mm] = rcs;
  se[K::kv_per_s] = json_number_or_null(d.kv_per_s.standard_error);
  json cse = json::object();
  for (std::size_t k = 0; k < 2; ++k) {
    cse[std::string(1, d.axes[k])] =
        d.cyclic[k] ? json{{K::amplitude_mm, d.cyclic[k]->amplitude_se_mm}} : json(nullptr);
  }
  se[K::cyclic] = cse;
  se[K::centre_offset_mm] = {json_number_or_null(d.centre_offset_mm[0].standard_error),
                             json_number_or_null(d.centre_offset_mm[1].standard_error)};
  j[K::standard_error] = se;
  j[K::kv_source] = d.kv_source.empty() ? json(nullptr) : json(d.kv_source);
  j[K::lag_ms] = json_number_or_null(d.lag_ms.value);
  json lag = json::object(), kv = json::object(), src = json::object(), lag_se = json::object();
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string a(1, d.axes[k]);
    const AxisLag& al = d.axis_lag[k];
    lag[a] = json_number_or_null(al.lag_ms.value);
    lag_se[a] = json_number_or_null(al.lag_ms.standard_error);
    kv[a] = json_number_or_null(al.kv_per_s);
    src[a] = al.source.empty() ? json(nullptr) : json(al.source);
  }
  j[K::axis_lag_ms] = lag;
  j[K::axis_kv_per_s] = kv;
  j[K::axis_lag_source] = src;
  j[K::axis_lag_mismatch_ms] = json_number_or_null(d.axis_lag_mismatch_ms.value);
  j[K::standard_error][K::axis_lag_ms] = lag_se;
  j[K::standard_error][K::axis_lag_mismatch_ms] =
      json_number_or_null(d.axis_lag_mismatch_ms.standard_error);
  json shares = json::array();
  for (const ServoShare& sh : d.servo_share) {
    shares.push_back({{K::feed_mm_per_min, sh.feed_mm_per_min},
                      {K::g_mm, sh.g_mm},
                      {K::measured_g_mm, json_number_or_null(sh.measured_g_mm)},
                      {K::percent, json_number_or_null(sh.percent)}});
  }
  j[K::servo_share] = shares;
  j[K::nominal_radius_mm] = d.radius_mm;
  j[K::absolute_channels] = d.absolute_channels;
  j[K::runs] = d.runs;
  j[K::samples] = d.samples;
  j[K::ini_sha256] = d.ini_sha256 ? json(*d.ini_sha256) : json(nullptr);
  j[K::source] = d.source;
  j[K::unseparable] = d.unseparable;
  j[K::notes] = d.notes;
  return j;
}

// ------------------------------------------------------------------ reading

namespace {

// A cyclic error's pitch: finer than 1 um or coarser than 10 m is no lead screw, rack or
// encoder period (and the pitch sizes circcomp's compensation table).
constexpr double kMinPitchMm = 1e-3;
constexpr double kMaxPitchMm = 1e4;

// Parses TEXT, refusing a document nested deeper than kMaxDiagnosisDepth; every library error
// becomes a ParseError naming SOURCE and, where it is known, the key being read.
nlohmann::json parse_limited(const std::string& text, const std::string& source) {
  using pjson = nlohmann::json;
  std::vector<std::string> keys;  // the key at each depth, down to the value being read
  const auto where = [&keys] {
    std::string path;
    for (const auto& k : keys) path += (path.empty() ? "" : ".") + k;
    return path.empty() ? std::string() : "\"" + path + "\": ";
  };
  pjson::parser_callback_t track = [&](int depth, pjson::parse_event_t event, pjson& parsed) {
    if (depth > kMaxDiagnosisDepth) {
      throw ParseError(source, 0,
                       fmt::format("nested deeper than {} levels: not a circtest diagnosis",
                                   kMaxDiagnosisDepth));
    }
    if (event == pjson::parse_event_t::key) {
      keys.resize(static_cast<std::size_t>(std::max(depth, 1)));
      keys.back() = parsed.get<std::string>();
    } else if (event == pjson::parse_event_t::object_end ||
               event == pjson::parse_event_t::array_end) {
      keys.resize(static_cast<std::size_t>(std::max(depth, 0)));
    }
    return true;
  };
  try {
    return pjson::parse(text, track);
  } catch (const pjson::parse_error& e) {
    throw ParseError(source, 0, where() + "not JSON: " + printable_ascii(e.what()));
  } catch (const pjson::out_of_range& e) {
    throw ParseError(source, 0,
                     where() + "a number beyond a double's range: " + printable_ascii(e.what()));
  } catch (const pjson::exception& e) {
    throw ParseError(source, 0, where() + printable_ascii(e.what()));
  }
}

using pjson = nlohmann::json;

// Reads the keys of a document: "FILE: \"key.path\": expected ..." for a wrong type; an absent
// key or null is an absent value.
struct Reader {
  const std::string& source;

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw ParseError(source, 0, fmt::format("\"{}\": {}", key, what));
  }
  std::optional<double> number(const pjson& j, const std::string& key) const {
    if (j.is_null()) return std::nullopt;
    if (!j.is_number()) fail(key, "expected a number or null");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(key, "not finite");
    return v;
  }
  std::optional<std::string> text(const pjson& j, const std::string& key) const {
    if (j.is_null()) return std::nullopt;
    if (!j.is_string()) fail(key, "expected a string or null");
    return j.get<std::string>();
  }
  const pjson& member(const pjson& j, const std::string& key, const std::string& path) const {
    static const pjson null_value;
    if (j.is_null()) return null_value;
    if (!j.is_object()) fail(path, "expected an object");
    const auto it = j.find(key);
    return it == j.end() ? null_value : *it;
  }
  const pjson& array(const pjson& j, const std::string& key) const {
    static const pjson empty = pjson::array();
    const pjson& v = member(j, key, key);
    if (v.is_null()) return empty;
    if (!v.is_array()) fail(key, "expected an array or null");
    return v;
  }
  // {"X": v, "Y": v} for the plane's axes.
  std::array<std::optional<double>, 2> per_axis(const pjson& doc, const std::string& key,
                                                const std::array<char, 2>& axes,
                                                const std::string& prefix = {}) const {
    std::array<std::optional<double>, 2> out;
    const pjson& j = member(doc, key, prefix + key);
    if (j.is_null()) return out;
    for (int k = 0; k < 2; ++k) {
      const std::string a(1, axes[static_cast<std::size_t>(k)]);
      out[static_cast<std::size_t>(k)] = number(member(j, a, prefix + key), prefix + key + "." + a);
    }
    return out;
  }
};

// The schema and version checks of a document (a whole one, or a test set's plane).
void check_schema(const pjson& doc, const Reader& r, std::string_view reader) {
  const std::string& source = r.source;
  const std::string expected =
      fmt::format("expected a {} document (circana diagnose --json)", diagnosis_json::kSchema);
  if (!doc.is_object()) throw ParseError(source, 0, expected);
  const auto schema = r.text(r.member(doc, K::schema, K::schema), K::schema);
  if (schema && schema->starts_with(diagnosis_json::kSchemaFamily) &&
      *schema != diagnosis_json::kSchema) {
    r.fail(K::schema, fmt::format("{} is a version this {} does not read (it reads {}): use the {} "
                                  "of the circana that wrote it",
                                  *schema, reader, diagnosis_json::kSchema, reader));
  }
  if (schema != diagnosis_json::kSchema) throw ParseError(source, 0, expected);
  // Absent in the documents written before the field: those are 1.0.
  if (const auto version = r.text(r.member(doc, K::version, K::version), K::version)) {
    diagnosis_json::check_version(*version, source, reader);
  }
  if (r.text(r.member(doc, K::units, K::units), K::units).value_or("mm") != "mm") {
    r.fail(K::units, "expected mm");
  }
}

std::array<Estimate, 2> estimates(const Reader& r, const pjson& doc, const pjson& se,
                                  const char* key, const std::array<char, 2>& axes) {
  const auto v = r.per_axis(doc, key, axes);
  const auto e = r.per_axis(se, key, axes, std::string(K::standard_error) + ".");
  return {Estimate{v[0], e[0]}, Estimate{v[1], e[1]}};
}

Estimate scalar(const Reader& r, const pjson& doc, const pjson& se, const char* key) {
  return {
      r.number(r.member(doc, key, key), key),
      r.number(r.member(se, key, K::standard_error), std::string(K::standard_error) + "." + key)};
}

void read_cyclic(const Reader& r, const pjson& doc, const pjson& se, Diagnosis& d) {
  const pjson& cyclic = r.member(doc, K::cyclic, K::cyclic);
  const pjson& se_cyclic = r.member(se, K::cyclic, K::standard_error);
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string a(1, d.axes[k]);
    const std::string at = std::string(K::cyclic) + "." + a;
    const pjson& c = r.member(cyclic, a, K::cyclic);
    if (c.is_null()) continue;
    const auto amplitude = r.number(r.member(c, K::amplitude_mm, at), at);
    const auto pitch = r.number(r.member(c, K::pitch_mm, at), at);
    if (!amplitude || !pitch || *pitch <= 0) r.fail(at, "expected amplitude_mm, pitch_mm > 0");
    if (*pitch < kMinPitchMm || *pitch > kMaxPitchMm) {
      throw DataError(r.source, 0,
                      fmt::format("\"{}.pitch_mm\": {} mm is no machine's pitch (expected {} to "
                                  "{} mm)",
                                  at, *pitch, kMinPitchMm, kMaxPitchMm));
    }
    CyclicEstimate ce;
    ce.amplitude_mm = *amplitude;
    ce.pitch_mm = *pitch;
    ce.phase_rad = r.number(r.member(c, K::phase_rad, at), at).value_or(0.0);
    ce.pitch_source = r.text(r.member(c, K::pitch_source, at), at).value_or("");
    ce.peak_to_median_power = r.number(r.member(c, K::peak_to_median_power, at), at);
    const pjson& cs = r.member(se_cyclic, a, "standard_error.cyclic");
    ce.amplitude_se_mm =
        r.number(r.member(cs, K::amplitude_mm, "standard_error.cyclic"), "standard_error." + at)
            .value_or(0.0);
    d.cyclic[k] = ce;
  }
}

void read_servo(const Reader& r, const pjson& doc, const pjson& se, Diagnosis& d) {
  d.kv_per_s = scalar(r, doc, se, K::kv_per_s);
  d.kv_source = r.text(r.member(doc, K::kv_source, K::kv_source), K::kv_source).value_or("");
  d.lag_ms.value = r.number(r.member(doc, K::lag_ms, K::lag_ms), K::lag_ms);
  const auto lag = estimates(r, doc, se, K::axis_lag_ms, d.axes);
  const auto kv = r.per_axis(doc, K::axis_kv_per_s, d.axes);
  const pjson& source = r.member(doc, K::axis_lag_source, K::axis_lag_source);
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string a(1, d.axes[k]);
    d.axis_lag[k].lag_ms = lag[k];
    d.axis_lag[k].kv_per_s = kv[k];
    d.axis_lag[k].source =
        r.text(r.member(source, a, K::axis_lag_source), std::string(K::axis_lag_source) + "." + a)
            .value_or("");
  }
  d.axis_lag_mismatch_ms = scalar(r, doc, se, K::axis_lag_mismatch_ms);
  for (const pjson& s : r.array(doc, K::servo_share)) {
    const std::string at = K::servo_share;
    ServoShare sh;
    sh.feed_mm_per_min = r.number(r.member(s, K::feed_mm_per_min, at), at).value_or(0.0);
    sh.g_mm = r.number(r.member(s, K::g_mm, at), at).value_or(0.0);
    sh.measured_g_mm = r.number(r.member(s, K::measured_g_mm, at), at);
    sh.percent = r.number(r.member(s, K::percent, at), at);
    d.servo_share.push_back(sh);
  }
}

void read_fit(const Reader& r, const pjson& doc, const pjson& se, Diagnosis& d) {
  const pjson& ends = r.member(doc, K::backlash_reversals_mm, K::backlash_reversals_mm);
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string a(1, d.axes[k]);
    const std::string at = std::string(K::backlash_reversals_mm) + "." + a;
    const pjson& e = r.member(ends, a, K::backlash_reversals_mm);
    if (e.is_null()) continue;
    const auto pos = r.number(r.member(e, K::positive_end, at), at);
    const auto neg = r.number(r.member(e, K::negative_end, at), at);
    if (!pos || !neg) r.fail(at, "expected positive_end and negative_end");
    d.backlash_reversals_mm[k] = std::array<double, 2>{*pos, *neg};
  }
  const pjson& rc = r.array(doc, K::radius_change_mm);
  const pjson& rcs = r.array(se, K::radius_change_mm);
  for (std::size_t i = 0; i < rc.size(); ++i) {
    const std::string at = fmt::format("{}[{}]", K::radius_change_mm, i);
    FeedRadius fr;
    fr.feed_mm_per_min = r.number(r.member(rc[i], K::feed_mm_per_min, at), at).value_or(0.0);
    fr.dr_mm.value = r.number(r.member(rc[i], K::dr, at), at);
    if (i < rcs.size()) fr.dr_mm.standard_error = r.number(r.member(rcs[i], K::dr, at), at);
    d.radius_change.push_back(fr);
  }
  const pjson& centre = r.member(doc, K::centre_offset_mm, K::centre_offset_mm);
  const pjson& centre_se = r.member(se, K::centre_offset_mm, K::standard_error);
  for (std::size_t k = 0; k < 2; ++k) {
    if (!centre.is_null() && (!centre.is_array() || centre.size() != 2))
      r.fail(K::centre_offset_mm, "expected two numbers or nulls");
    if (centre.is_array()) d.centre_offset_mm[k].value = r.number(centre[k], K::centre_offset_mm);
    if (centre_se.is_array() && centre_se.size() == 2)
      d.centre_offset_mm[k].standard_error = r.number(centre_se[k], K::centre_offset_mm);
  }
  for (std::size_t i = 0; const pjson& c : r.array(doc, K::contributions)) {
    const std::string at = fmt::format("{}[{}]", K::contributions, i++);
    Contribution k;
    k.source = r.text(r.member(c, K::source, at), at + "." + K::source).value_or("");
    k.g_mm = r.number(r.member(c, K::g_mm, at), at + "." + K::g_mm).value_or(0.0);
    k.percent = r.number(r.member(c, K::percent, at), at + "." + K::percent).value_or(0.0);
    k.share_mm = r.number(r.member(c, K::share_mm, at), at + "." + K::share_mm).value_or(0.0);
    d.contributions.push_back(std::move(k));
  }
  d.model_g_mm = r.number(r.member(doc, K::model_g_mm, K::model_g_mm), K::model_g_mm).value_or(0.0);
  const pjson& residual = r.member(doc, K::residual, K::residual);
  const std::string at = K::residual;
  d.residual_rms_mm =
      r.number(r.member(residual, K::rms_mm, at), at + "." + K::rms_mm).value_or(0.0);
  d.residual_g_mm = r.number(r.member(residual, K::g_mm, at), at + "." + K::g_mm).value_or(0.0);
  d.measured_g_mm = r.number(r.member(residual, K::measured_g_mm, at), at + "." + K::measured_g_mm);
  d.measured_g_u_mm =
      r.number(r.member(residual, K::measured_g_u_mm, at), at + "." + K::measured_g_u_mm);
}

std::vector<std::string> texts(const Reader& r, const pjson& doc, const char* key) {
  std::vector<std::string> out;
  for (const pjson& item : r.array(doc, key)) {
    const auto t = r.text(item, key);
    if (!t) r.fail(key, "expected an array of strings");
    out.push_back(*t);
  }
  return out;
}

// A term listed as unseparable has no value, whatever stands beside it.
void clear_unseparable(Diagnosis& d) {
  for (const std::string& key : d.unseparable) {
    for (std::size_t k = 0; k < 2; ++k) {
      const std::string a = std::string(".") + d.axes[k];
      if (key == K::backlash_mm + a) {
        d.backlash_mm[k] = {};
        d.backlash_reversals_mm[k].reset();
      }
      if (key == K::reversal_spike_mm + a) {
        d.spike_mm[k] = {};
        d.spike_ms[k] = {};
        d.spike_peak_ms[k] = {};
      }
      if (key == K::scale_ppm + a) d.scale_ppm[k] = {};
      if (key == K::cyclic + a) d.cyclic[k].reset();
    }
    if (key == K::scale_mismatch_ppm) d.scale_mismatch_ppm = {};
    if (key == K::squareness_urad) d.squareness_urad = {};
    if (key == K::servo_mismatch_ms) d.servo_mismatch_ms = {};
  }
}

// One plane's document, its schema checked.
Diagnosis read_plane(const pjson& doc, const Reader& r) {
  Diagnosis d;
  const auto plane_text = r.text(r.member(doc, K::plane, K::plane), K::plane);
  if (!plane_text) r.fail(K::plane, "expected XY, YZ or ZX");
  const auto plane = parse_plane(*plane_text);
  if (!plane || *plane_text != plane_name(*plane))
    r.fail(K::plane, "expected XY, YZ or ZX, got '" + printable_ascii(*plane_text) + "'");
  d.plane = *plane;
  const PlaneAxes pa = plane_axes(d.plane);
  d.axes = {static_cast<char>(pa.first - 'a' + 'A'), static_cast<char>(pa.second - 'a' + 'A')};
  const pjson& se = r.member(doc, K::standard_error, K::standard_error);
  if (!se.is_null() && !se.is_object()) r.fail(K::standard_error, "expected an object or null");
  for (const pjson& f : r.array(doc, K::feeds_mm_per_min)) {
    if (const auto v = r.number(f, K::feeds_mm_per_min)) d.feeds_mm_per_min.push_back(*v);
  }
  d.backlash_mm = estimates(r, doc, se, K::backlash_mm, d.axes);
  d.spike_mm = estimates(r, doc, se, K::reversal_spike_mm, d.axes);
  d.spike_ms = estimates(r, doc, se, K::reversal_spike_ms, d.axes);
  d.spike_peak_ms = estimates(r, doc, se, K::reversal_spike_peak_ms, d.axes);
  d.scale_ppm = estimates(r, doc, se, K::scale_ppm, d.axes);
  d.scale_mismatch_ppm = scalar(r, doc, se, K::scale_mismatch_ppm);
  d.squareness_urad = scalar(r, doc, se, K::squareness_urad);
  d.servo_mismatch_ms = scalar(r, doc, se, K::servo_mismatch_ms);
  read_cyclic(r, doc, se, d);
  read_servo(r, doc, se, d);
  read_fit(r, doc, se, d);
  d.radius_mm =
      r.number(r.member(doc, K::nominal_radius_mm, K::nominal_radius_mm), K::nominal_radius_mm)
          .value_or(0.0);
  const pjson& absolute = r.member(doc, K::absolute_channels, K::absolute_channels);
  if (!absolute.is_null() && !absolute.is_boolean())
    r.fail(K::absolute_channels, "expected true, false or null");
  d.absolute_channels = absolute.is_boolean() ? absolute.get<bool>() : true;
  for (const auto& [key, field] :
       {std::pair{K::runs, &d.runs}, std::pair{K::samples, &d.samples}}) {
    const pjson& v = r.member(doc, key, key);
    if (!v.is_null() && !v.is_number_unsigned()) r.fail(key, "expected a count or null");
    *field = v.is_null() ? 0 : v.get<std::size_t>();
  }
  d.ini_sha256 = r.text(r.member(doc, K::ini_sha256, K::ini_sha256), K::ini_sha256);
  d.source = r.text(r.member(doc, K::source, K::source), K::source).value_or("");
  d.unseparable = texts(r, doc, K::unseparable);
  d.notes = texts(r, doc, K::notes);
  clear_unseparable(d);
  return d;
}

// A test set's document: each plane's own (test_set.diagnoses), the joint per-axis values (the
// top-level objects, keyed by every axis) and each plane's squareness of the joint fit.
void read_set(const pjson& doc, const Reader& r, std::string_view reader, const std::string& planes,
              DiagnosisDocument& out) {
  const std::string set_key = K::test_set;
  const pjson& set = r.member(doc, K::test_set, K::test_set);
  if (!set.is_object()) r.fail(set_key, "expected an object");
  const pjson& diagnoses = r.member(set, K::diagnoses, K::test_set);
  if (!diagnoses.is_array() || diagnoses.empty()) {
    r.fail(set_key + "." + K::diagnoses,
           fmt::format("expected each plane's diagnosis (the planes {})", planes));
  }
  std::string seen;
  for (const pjson& plane_doc : diagnoses) {
    check_schema(plane_doc, r, reader);
    out.planes.push_back(read_plane(plane_doc, r));
    seen += (seen.empty() ? "" : ",") + std::string(plane_name(out.planes.back().plane));
  }
  if (seen != planes) {
    r.fail(set_key + "." + K::diagnoses,
           fmt::format("the planes' diagnoses are {}, the document's plane says {}", seen, planes));
  }
  const pjson& se = r.member(doc, K::standard_error, K::standard_error);
  for (const Diagnosis& d : out.planes) {
    for (std::size_t k = 0; k < 2; ++k) {
      const char a = d.axes[k];
      if (out.joint.count(a)) continue;
      const std::array<char, 2> one{a, a};
      JointAxisValues& j = out.joint[a];
      j.backlash_mm = estimates(r, doc, se, K::backlash_mm, one)[0];
      j.spike_mm = estimates(r, doc, se, K::reversal_spike_mm, one)[0];
      j.spike_ms = estimates(r, doc, se, K::reversal_spike_ms, one)[0];
      j.scale_ppm = estimates(r, doc, se, K::scale_ppm, one)[0];
    }
  }
  const pjson& squareness = r.member(set, K::squareness_urad, K::test_set);
  const std::string sq_key = set_key + "." + K::squareness_urad;
  if (!squareness.is_null() && !squareness.is_object())
    r.fail(sq_key, "expected an object or null");
  for (const Diagnosis& d : out.planes) {
    const std::string p(plane_name(d.plane));
    if (!squareness.is_object() || !squareness.contains(p)) continue;
    const pjson& e = squareness[p];
    const std::string path = sq_key + "." + p;
    if (!e.is_object()) r.fail(path, "expected an object with value and standard_error");
    out.joint_squareness_urad[d.plane] = {
        r.number(r.member(e, K::value, path), path + "." + K::value),
        r.number(r.member(e, K::standard_error, path), path + "." + K::standard_error)};
  }
}

}  // namespace

DiagnosisDocument parse_diagnosis_document(const std::string& text, const std::string& source,
                                           std::string_view reader) {
  const pjson doc = parse_limited(text, source);
  const Reader r{source};
  check_schema(doc, r, reader);
  DiagnosisDocument out;
  out.ini_sha256 = r.text(r.member(doc, K::ini_sha256, K::ini_sha256), K::ini_sha256);
  const auto plane = r.text(r.member(doc, K::plane, K::plane), K::plane);
  if (plane && plane->find(',') != std::string::npos) {
    out.test_set = true;
    read_set(doc, r, reader, *plane, out);
  } else {
    out.planes.push_back(read_plane(doc, r));
    for (const char* key : {K::contributions, K::model_g_mm}) {
      if (r.member(doc, key, key).is_null()) out.absent.emplace_back(key);
    }
    if (r.member(r.member(doc, K::residual, K::residual), K::g_mm, K::residual).is_null())
      out.absent.push_back(std::string(K::residual) + "." + K::g_mm);
  }
  return out;
}

DiagnosisDocument read_diagnosis_document(const std::string& path, std::string_view reader) {
  return parse_diagnosis_document(read_input_text(path, kMaxDiagnosisBytes), path, reader);
}

}  // namespace circtest
