#include "circtest/analysis/result_json.hpp"

#include <fmt/format.h>

#include "circtest/analysis/result_checks.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"

namespace circtest {

namespace {

using json = nlohmann::ordered_json;

// Reading a document back: every key where to_json puts it, else a ParseError naming the
// key, so a document of another shape is refused instead of read as zeros; a number beyond
// what an evaluation can report is a DataError naming the key.
class Reader : public JsonReader<json> {
 public:
  explicit Reader(const std::string& source)
      : JsonReader<json>(source, "result JSON", kMaxReportedMagnitude) {}

  PlanePoint point(const json& v, const std::string& path) const {
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number()) {
      fail(path, "two numbers [a, b]");
    }
    return {number(v[0], path + "[0]"), number(v[1], path + "[1]")};
  }
  PlanePoint point(const json& j, const char* key, const std::string& path) const {
    return point(at(j, key, path), key_path(path, key));
  }
  std::vector<std::size_t> indices(const json& j, const char* key, const std::string& path) const {
    const json& v = at(j, key, path);
    if (!v.is_array()) fail(key_path(path, key), "an array of indices");
    std::vector<std::size_t> out;
    for (const json& e : v) {
      if (!e.is_number_unsigned()) fail(key_path(path, key), "an array of indices");
      out.push_back(e.get<std::size_t>());
    }
    return out;
  }
};

// The stated inputs of the budget, as given (null: the profile's default or measured).
json options_json(const UncertaintyOptions& o) {
  return {{"profile", instrument_profile_name(o.profile)},
          {"calibration_mm", json_number_or_null(o.calibration_mm)},
          {"resolution_mm", json_number_or_null(o.resolution_mm)},
          {"centring_mm", json_number_or_null(o.centring_mm)},
          {"unseen_mm", json_number_or_null(o.unseen_mm)},
          {"thermometer_K", o.thermometer_K},
          {"assumed_temperature_half_width_K", o.assumed_temperature_half_width_K},
          {"expansion_relative", o.expansion_relative},
          {"assumed_drift_K_per_h", o.assumed_drift_K_per_h},
          {"repeatability_G_mm", json_number_or_null(o.repeatability_g_mm)},
          {"repeatability_F_mm", json_number_or_null(o.repeatability_f_mm)},
          {"repeatability_H_mm", json_number_or_null(o.repeatability_h_mm)}};
}

UncertaintyOptions options_from_json(const Reader& rd, const json& j) {
  const std::string path = "uncertainty.options";
  UncertaintyOptions o;
  const auto profile = parse_instrument_profile(rd.text(j, "profile", path));
  if (!profile) rd.fail(path + ".profile", "auto, ballbar, grid-encoder or scales");
  o.profile = *profile;
  o.calibration_mm = rd.optional_number(j, "calibration_mm", path);
  o.resolution_mm = rd.optional_number(j, "resolution_mm", path);
  o.centring_mm = rd.optional_number(j, "centring_mm", path);
  o.unseen_mm = rd.optional_number(j, "unseen_mm", path);
  o.thermometer_K = rd.number(j, "thermometer_K", path);
  o.assumed_temperature_half_width_K = rd.number(j, "assumed_temperature_half_width_K", path);
  o.expansion_relative = rd.number(j, "expansion_relative", path);
  // A document written before the drift was in the budget: the default.
  if (j.contains("assumed_drift_K_per_h")) {
    o.assumed_drift_K_per_h = rd.number(j, "assumed_drift_K_per_h", path);
  }
  o.repeatability_g_mm = rd.optional_number(j, "repeatability_G_mm", path);
  o.repeatability_f_mm = rd.optional_number(j, "repeatability_F_mm", path);
  o.repeatability_h_mm = rd.optional_number(j, "repeatability_H_mm", path);
  return o;
}

// What the budget measured in the trace (BudgetMeasurements).
json measured_json(const BudgetMeasurements& m) {
  return {{"drift_source", m.drift_source},
          {"machine_run_K", m.machine_run_K},
          {"machine_pair_K", m.machine_pair_K},
          {"machine_from_corrected_K", m.machine_from_corrected_K},
          {"instrument_run_K", m.instrument_run_K},
          {"instrument_pair_K", m.instrument_pair_K},
          {"instrument_from_corrected_K", m.instrument_from_corrected_K},
          {"run_s", json_number_or_null(m.run_s)},
          {"pair_s", json_number_or_null(m.pair_s)},
          {"test_s", json_number_or_null(m.test_s)},
          {"noise_mm", m.noise_mm},
          {"noise_G_mm", m.noise_g_mm},
          {"noise_F_mm", m.noise_f_mm},
          {"noise_H_mm", m.noise_h_mm},
          {"noise_samples_top", m.noise_samples_top},
          {"noise_samples_bottom", m.noise_samples_bottom}};
}

BudgetMeasurements measured_from_json(const Reader& rd, const json& j) {
  const std::string path = "uncertainty.measured";
  BudgetMeasurements m;
  m.drift_source = rd.text(j, "drift_source", path);
  m.machine_run_K = rd.number(j, "machine_run_K", path);
  m.machine_pair_K = rd.number(j, "machine_pair_K", path);
  m.machine_from_corrected_K = rd.number(j, "machine_from_corrected_K", path);
  m.instrument_run_K = rd.number(j, "instrument_run_K", path);
  m.instrument_pair_K = rd.number(j, "instrument_pair_K", path);
  m.instrument_from_corrected_K = rd.number(j, "instrument_from_corrected_K", path);
  m.run_s = rd.optional_number(j, "run_s", path);
  m.pair_s = rd.optional_number(j, "pair_s", path);
  m.test_s = rd.optional_number(j, "test_s", path);
  m.noise_mm = rd.number(j, "noise_mm", path);
  m.noise_g_mm = rd.number(j, "noise_G_mm", path);
  m.noise_f_mm = rd.number(j, "noise_F_mm", path);
  m.noise_h_mm = rd.number(j, "noise_H_mm", path);
  m.noise_samples_top = rd.count(j, "noise_samples_top", path);
  m.noise_samples_bottom = rd.count(j, "noise_samples_bottom", path);
  return m;
}

}  // namespace

json uncertainty_json(const UncertaintyBudget& b, const UncertaintyOptions& options) {
  json contributions = json::array();
  for (const auto& c : b.contributions) {
    contributions.push_back({{"name", c.name},
                             {"value_mm", c.value_mm},
                             {"distribution", distribution_name(c.distribution)},
                             {"standard_mm", c.standard_mm()},
                             {"source", c.source},
                             {"c_G", c.c_g},
                             {"c_H", c.c_h},
                             {"c_F", c.c_f},
                             {"note", c.note}});
  }
  return {{"method", "ISO/TR 230-9 (GUM): root sum of squares, expanded"},
          {"k", b.k},
          {"profile", instrument_profile_name(b.profile)},
          {"profile_note", b.profile_note},
          {"U_G", b.u_g_mm},
          {"U_H", b.u_h_mm},
          {"U_F", b.u_f_mm},
          {"decision_rule", kDecisionRule},
          {"contributions", contributions},
          {"options", options_json(options)}};
}

const char* g_method_name(GMethod method) noexcept {
  return method == GMethod::min_zone ? "min-zone" : "least-squares";
}

json to_json(const Evaluation& ev) {
  json j;
  j["schema"] = kEvaluationSchema;
  j["units"] = "mm";
  j["source"] = ev.source;
  j["plane"] = std::string(plane_name(ev.plane));
  j["channels"] = json::array({ev.channel_a, ev.channel_b});
  j["segmentation"] = segmentation_method_name(ev.segmentation);
  j["g_method"] = g_method_name(ev.g_method);
  j["nominal_radius"] = json_number_or_null(ev.nominal_radius_mm);
  j["nominal_radius_source"] = value_source_name(ev.nominal_radius_source);
  j["nominal_centre"] = ev.centre ? json::array({ev.centre->a_mm, ev.centre->b_mm}) : json(nullptr);
  j["nominal_centre_source"] = value_source_name(ev.centre_source);
  j["temperature"] = {{"corrected", ev.temperatures.available()},
                      {"machine_C", json_number_or_null(ev.temperatures.machine_C)},
                      {"instrument_C", json_number_or_null(ev.temperatures.instrument_C)},
                      {"machine_expansion_per_K", ev.temperatures.machine_expansion_per_K},
                      {"instrument_expansion_per_K", ev.temperatures.instrument_expansion_per_K},
                      {"radius_factor", ev.temperature_factor}};
  j["H"] = ev.hysteresis.empty() ? json(nullptr) : json(ev.hysteresis.front().h_mm);
  json pairs = json::array();
  for (const auto& h : ev.hysteresis) {
    pairs.push_back({{"runs", {h.run_ccw, h.run_cw}},
                     {"H", h.h_mm},
                     {"angle_deg", h.at_angle_deg},
                     {"overlap_deg", h.overlap_deg},
                     {"centre", {h.common_lsc.centre_a_mm, h.common_lsc.centre_b_mm}}});
  }
  j["pairs"] = pairs;
  json runs = json::array();
  for (const auto& r : ev.runs) {
    json contacts_outer = r.mzc.outer_contacts;
    json contacts_inner = r.mzc.inner_contacts;
    runs.push_back({
        {"direction", std::string(direction_name(r.run.direction))},
        {"label", r.label},
        {"segment", r.run.segment_id},
        {"G", r.g_mzc_mm},
        {"G_lsc", r.g_lsc_mm},
        {"F_max", json_number_or_null(r.f_max_mm)},
        {"F_min", json_number_or_null(r.f_min_mm)},
        {"F_centre", f_centre_method_name(r.f_centre_method)},
        {"F_centre_point", {r.f_centre.a_mm, r.f_centre.b_mm}},
        {"centre", {r.lsc.centre_a_mm, r.lsc.centre_b_mm}},
        {"radius", r.lsc.radius_mm},
        {"points", r.run.size()},
        {"arc_deg", r.run.sweep_deg},
        {"start_deg", r.run.start_deg},
        {"lines", {r.first_line, r.last_line}},
        {"feed_mm_per_min", json_number_or_null(r.feed_mm_per_min)},
        {"mzc",
         {{"centre", {r.mzc.centre_a_mm, r.mzc.centre_b_mm}},
          {"inner_radius", r.mzc.inner_radius_mm},
          {"outer_radius", r.mzc.outer_radius_mm},
          {"zone_width", r.mzc.zone_width_mm},
          {"certified", r.mzc.certified},
          {"outer_contacts", contacts_outer},
          {"inner_contacts", contacts_inner}}},
    });
  }
  j["runs"] = runs;
  j["notes"] = ev.notes;
  // Each key once (its last value), appended: the object's operator[] searches its keys one by
  // one, which made 80,000 keys take seconds.
  json::object_t conditions;
  for (const std::size_t i : ev.conditions.distinct()) {
    const auto& [k, v] = ev.conditions.entries()[i];
    conditions.emplace_back(k, v);
  }
  j["conditions"] = std::move(conditions);
  // The uncertainty (k = 2), after every other key: a reader of the keys above sees them as
  // they were.
  const UncertaintyBudget budget = uncertainty_budget(ev, ev.uncertainty_options);
  for (auto& r : j["runs"]) {
    r["U_G"] = budget.u_g_mm;
    r["U_F"] = r["F_max"].is_null() ? json(nullptr) : json(budget.u_f_mm);
  }
  for (auto& p : j["pairs"]) p["U_H"] = budget.u_h_mm;
  j["U_H"] = ev.hysteresis.empty() ? json(nullptr) : json(budget.u_h_mm);
  j["uncertainty"] = uncertainty_json(budget, ev.uncertainty_options);
  j["uncertainty"]["measured"] = measured_json(ev.budget_inputs);
  return j;
}

Evaluation evaluation_from_json(const json& j, const std::string& source) {
  const Reader rd(source);
  if (!j.is_object()) rd.fail("", "an object");
  const std::string schema = rd.text(j, "schema", "");
  if (schema != kEvaluationSchema)
    rd.fail("schema", fmt::format("'{}', got '{}'", kEvaluationSchema, schema));
  Evaluation ev;
  ev.source = rd.text(j, "source", "");
  const std::string plane = rd.text(j, "plane", "");
  const auto parsed_plane = parse_plane(plane);
  if (!parsed_plane) rd.fail("plane", "XY, YZ or ZX");
  ev.plane = *parsed_plane;
  const json& channels = rd.at(j, "channels", "");
  if (!channels.is_array() || channels.size() != 2 || !channels[0].is_string() ||
      !channels[1].is_string()) {
    rd.fail("channels", "two column names [a, b]");
  }
  ev.channel_a = channels[0].get<std::string>();
  ev.channel_b = channels[1].get<std::string>();
  const std::string seg = rd.text(j, "segmentation", "");
  const auto parsed_seg = parse_segmentation_method(seg);
  if (!parsed_seg) rd.fail("segmentation", "marker, segment or automatic");
  ev.segmentation = *parsed_seg;
  const std::string g = rd.text(j, "g_method", "");
  if (g == g_method_name(GMethod::min_zone)) {
    ev.g_method = GMethod::min_zone;
  } else if (g == g_method_name(GMethod::least_squares)) {
    ev.g_method = GMethod::least_squares;
  } else {
    rd.fail("g_method", "min-zone or least-squares");
  }
  ev.nominal_radius_mm = rd.optional_number(j, "nominal_radius", "");
  const auto radius_source = parse_value_source(rd.text(j, "nominal_radius_source", ""));
  if (!radius_source) rd.fail("nominal_radius_source", "option, metadata, commanded or empty");
  ev.nominal_radius_source = *radius_source;
  if (const json& c = rd.at(j, "nominal_centre", ""); !c.is_null()) {
    ev.centre = rd.point(c, "nominal_centre");
  }
  const auto centre_source = parse_value_source(rd.text(j, "nominal_centre_source", ""));
  if (!centre_source) rd.fail("nominal_centre_source", "option, metadata, commanded or empty");
  ev.centre_source = *centre_source;
  const json& t = rd.at(j, "temperature", "");
  ev.temperatures.machine_C = rd.optional_number(t, "machine_C", "temperature");
  ev.temperatures.instrument_C = rd.optional_number(t, "instrument_C", "temperature");
  ev.temperatures.machine_expansion_per_K = rd.number(t, "machine_expansion_per_K", "temperature");
  ev.temperatures.instrument_expansion_per_K =
      rd.number(t, "instrument_expansion_per_K", "temperature");
  ev.temperature_factor = rd.number(t, "radius_factor", "temperature");

  const json& runs = rd.at(j, "runs", "");
  if (!runs.is_array()) rd.fail("runs", "an array");
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const json& r = runs[i];
    const std::string path = fmt::format("runs[{}]", i);
    RunResult rr;
    const auto dir = parse_direction(rd.text(r, "direction", path));
    if (!dir) rd.fail(path + ".direction", "CCW or CW");
    rr.run.direction = *dir;
    rr.label = rd.text(r, "label", path);
    const json& segment = rd.at(r, "segment", path);
    if (!segment.is_number_integer()) rd.fail(path + ".segment", "an integer");
    rr.run.segment_id = segment.get<long>();
    rr.g_mzc_mm = rd.number(r, "G", path);
    rr.g_lsc_mm = rd.number(r, "G_lsc", path);
    rr.f_max_mm = rd.optional_number(r, "F_max", path);
    rr.f_min_mm = rd.optional_number(r, "F_min", path);
    const auto f_centre = parse_f_centre_method(rd.text(r, "F_centre", path));
    if (!f_centre) rd.fail(path + ".F_centre", "lsc or nominal");
    rr.f_centre_method = *f_centre;
    rr.f_centre = rd.point(r, "F_centre_point", path);
    const PlanePoint centre = rd.point(r, "centre", path);
    rr.lsc = {centre.a_mm, centre.b_mm, rd.number(r, "radius", path)};
    rr.run.begin = 0;
    rr.run.end = rd.count(r, "points", path);
    rr.run.sweep_deg = rd.number(r, "arc_deg", path);
    rr.run.start_deg = rd.number(r, "start_deg", path);
    const json& lines = rd.at(r, "lines", path);
    if (!lines.is_array() || lines.size() != 2 || !lines[0].is_number_unsigned() ||
        !lines[1].is_number_unsigned()) {
      rd.fail(path + ".lines", "two line numbers [first, last]");
    }
    rr.first_line = lines[0].get<std::size_t>();
    rr.last_line = lines[1].get<std::size_t>();
    rr.feed_mm_per_min = rd.optional_number(r, "feed_mm_per_min", path);
    const json& m = rd.at(r, "mzc", path);
    const std::string mp = path + ".mzc";
    const PlanePoint mc = rd.point(m, "centre", mp);
    rr.mzc.centre_a_mm = mc.a_mm;
    rr.mzc.centre_b_mm = mc.b_mm;
    rr.mzc.inner_radius_mm = rd.number(m, "inner_radius", mp);
    rr.mzc.outer_radius_mm = rd.number(m, "outer_radius", mp);
    rr.mzc.zone_width_mm = rd.number(m, "zone_width", mp);
    rr.mzc.certified = rd.boolean(m, "certified", mp);
    rr.mzc.outer_contacts = rd.indices(m, "outer_contacts", mp);
    rr.mzc.inner_contacts = rd.indices(m, "inner_contacts", mp);
    ev.runs.push_back(std::move(rr));
  }

  const json& pairs = rd.at(j, "pairs", "");
  if (!pairs.is_array()) rd.fail("pairs", "an array");
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const json& p = pairs[i];
    const std::string path = fmt::format("pairs[{}]", i);
    HysteresisResult h;
    const json& idx = rd.at(p, "runs", path);
    if (!idx.is_array() || idx.size() != 2 || !idx[0].is_number_unsigned() ||
        !idx[1].is_number_unsigned() || idx[0].get<std::size_t>() >= ev.runs.size() ||
        idx[1].get<std::size_t>() >= ev.runs.size()) {
      rd.fail(path + ".runs", "two run indices [ccw, cw]");
    }
    h.run_ccw = idx[0].get<std::size_t>();
    h.run_cw = idx[1].get<std::size_t>();
    h.h_mm = rd.number(p, "H", path);
    h.at_angle_deg = rd.number(p, "angle_deg", path);
    h.overlap_deg = rd.number(p, "overlap_deg", path);
    const PlanePoint c = rd.point(p, "centre", path);
    h.common_lsc.centre_a_mm = c.a_mm;
    h.common_lsc.centre_b_mm = c.b_mm;
    ev.hysteresis.push_back(h);
  }

  const json& notes = rd.at(j, "notes", "");
  if (!notes.is_array()) rd.fail("notes", "an array of strings");
  for (const json& n : notes) {
    if (!n.is_string()) rd.fail("notes", "an array of strings");
    ev.notes.push_back(n.get<std::string>());
  }
  const json& conditions = rd.at(j, "conditions", "");
  if (!conditions.is_object()) rd.fail("conditions", "an object of strings");
  for (const auto& [k, v] : conditions.items()) {
    if (!v.is_string()) rd.fail("conditions." + k, "a string");
    ev.conditions.set(k, v.get<std::string>());
  }
  // A document written before the budget has none: the defaults.
  if (j.contains("uncertainty")) {
    const json& u = rd.at(j, "uncertainty", "");
    ev.uncertainty_options = options_from_json(rd, rd.at(u, "options", "uncertainty"));
    // Written before the budget measured drift and noise: none measured.
    if (u.contains("measured")) {
      ev.budget_inputs = measured_from_json(rd, rd.at(u, "measured", "uncertainty"));
    }
  }
  return ev;
}

}  // namespace circtest
