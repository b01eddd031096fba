// circana summary: the figures of several runs of one machine side by side, from their
// evaluations (analyze --json) and diagnoses (diagnose --json), read through the documents'
// own readers (result_json.hpp, core/diagnosis_document.hpp): a script never spells a key.
#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "circtest/analysis/diagnosis.hpp"
#include "circtest/analysis/result_json.hpp"
#include "circtest/circana/commands.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"

namespace circtest {

namespace {

struct RunDocuments {
  std::string name;
  Evaluation evaluation;
  Diagnosis diagnosis;
};

struct Row {
  std::string label;
  std::string unit;
  std::vector<std::optional<double>> values;  // per run, in the row's unit
};

// A row of one value per run.
Row row(const std::vector<RunDocuments>& runs, std::string label, std::string unit, double scale,
        const std::function<std::optional<double>(const RunDocuments&)>& value) {
  Row r{std::move(label), std::move(unit), {}};
  for (const RunDocuments& run : runs) {
    const std::optional<double> v = value(run);
    r.values.push_back(v ? std::optional<double>(*v * scale) : std::nullopt);
  }
  return r;
}

// The modelled G less the shares of the servo and friction terms (the geometric part).
std::optional<double> geometric_g(const Diagnosis& d) {
  double g = d.model_g_mm;
  for (const Contribution& c : d.contributions) {
    if (c.source == "servo mismatch" || c.source == "radius change" ||
        c.source.starts_with("reversal spike"))
      g -= c.share_mm;
  }
  return g;
}

std::vector<Row> rows(const std::vector<RunDocuments>& runs) {
  const RunDocuments& first = runs.front();
  const auto axes = first.diagnosis.axes;
  std::vector<Row> out;
  out.push_back(row(runs, "H", "um", 1e3, [](const RunDocuments& r) -> std::optional<double> {
    if (r.evaluation.hysteresis.empty()) return std::nullopt;
    return r.evaluation.hysteresis.front().h_mm;
  }));
  for (std::size_t i = 0; i < first.evaluation.runs.size(); ++i) {
    out.push_back(row(runs, "G " + first.evaluation.runs[i].label, "um", 1e3,
                      [i](const RunDocuments& r) -> std::optional<double> {
                        if (i >= r.evaluation.runs.size()) return std::nullopt;
                        return r.evaluation.runs[i].g_mzc_mm;
                      }));
  }
  out.push_back(row(runs, "G worst", "um", 1e3, [](const RunDocuments& r) -> std::optional<double> {
    std::optional<double> g;
    for (const RunResult& rr : r.evaluation.runs)
      g = std::max(g.value_or(rr.g_mzc_mm), rr.g_mzc_mm);
    return g;
  }));
  // The expanded uncertainty of each run's H and G above (one budget per trace, as circana
  // analyze states it).
  const auto u_row = [&](const char* label, double UncertaintyBudget::*field, bool h) {
    out.push_back(row(runs, label, "um", 1e3, [=](const RunDocuments& r) -> std::optional<double> {
      if (h ? r.evaluation.hysteresis.empty() : r.evaluation.runs.empty()) return std::nullopt;
      return uncertainty_budget(r.evaluation, r.evaluation.uncertainty_options).*field;
    }));
  };
  u_row("U of H (k = 2)", &UncertaintyBudget::u_h_mm, true);
  u_row("U of G (k = 2)", &UncertaintyBudget::u_g_mm, false);
  const auto per_axis = [&](const char* what, const char* unit, double scale, auto field) {
    for (std::size_t k = 0; k < 2; ++k) {
      out.push_back(row(runs, fmt::format("{} {}", what, axes[k]), unit, scale,
                        [&](const RunDocuments& r) { return field(r.diagnosis, k); }));
    }
  };
  per_axis("backlash", "um", 1e3,
           [](const Diagnosis& d, std::size_t k) { return d.backlash_mm[k].value; });
  per_axis("reversal spike", "um", 1e3,
           [](const Diagnosis& d, std::size_t k) { return d.spike_mm[k].value; });
  per_axis("scale", "ppm", 1.0,
           [](const Diagnosis& d, std::size_t k) { return d.scale_ppm[k].value; });
  per_axis("cyclic", "um", 1e3, [](const Diagnosis& d, std::size_t k) -> std::optional<double> {
    if (!d.cyclic[k]) return std::nullopt;
    return d.cyclic[k]->amplitude_mm;
  });
  out.push_back(row(runs, "squareness", "urad", 1.0,
                    [](const RunDocuments& r) { return r.diagnosis.squareness_urad.value; }));
  out.push_back(row(runs, "servo: mean lag", "ms", 1.0,
                    [](const RunDocuments& r) { return r.diagnosis.lag_ms.value; }));
  out.push_back(row(runs, "servo: mismatch", "ms", 1.0,
                    [](const RunDocuments& r) { return r.diagnosis.servo_mismatch_ms.value; }));
  out.push_back(row(runs, "servo: Kv", "1/s", 1.0,
                    [](const RunDocuments& r) { return r.diagnosis.kv_per_s.value; }));
  per_axis("servo: lag", "ms", 1.0,
           [](const Diagnosis& d, std::size_t k) { return d.axis_lag[k].lag_ms.value; });
  out.push_back(
      row(runs, "modelled G", "um", 1e3,
          [](const RunDocuments& r) -> std::optional<double> { return r.diagnosis.model_g_mm; }));
  out.push_back(row(runs, "  without servo and friction", "um", 1e3,
                    [](const RunDocuments& r) { return geometric_g(r.diagnosis); }));
  return out;
}

std::string table(const std::vector<RunDocuments>& runs, const std::vector<Row>& rs) {
  std::string s = fmt::format("{:30}", "");
  for (const RunDocuments& r : runs) s += fmt::format("{:>14}", r.name);
  s += '\n';
  for (const Row& r : rs) {
    s += fmt::format("{:30}", r.unit.empty() ? r.label : fmt::format("{} ({})", r.label, r.unit));
    for (const auto& v : r.values) {
      std::string value = "-";
      if (v) value = r.unit == "ms" ? fmt::format("{:.3f}", *v) : fmt::format("{:.2f}", *v);
      s += fmt::format("{:>14}", value);
    }
    s += '\n';
  }
  return s;
}

}  // namespace

int run_summary(const SummaryRequest& request, std::ostream& out) {
  if (request.runs.empty())
    throw UsageError("circana summary: no run (--name N --result R --diagnosis D)");
  std::vector<RunDocuments> runs;
  for (const SummaryRun& in : request.runs) {
    RunDocuments r;
    r.name = in.name;
    r.evaluation = evaluation_from_json(read_ordered_json_file(in.result_path), in.result_path);
    const DiagnosisDocument doc = read_diagnosis_document(in.diagnosis_path, "circana");
    if (doc.planes.size() != 1) {
      throw DataError(in.diagnosis_path, 0, "a test set's diagnosis: give one plane's");
    }
    r.diagnosis = doc.planes.front();
    runs.push_back(std::move(r));
  }
  const std::vector<Row> rs = rows(runs);
  if (!request.json_path.empty()) {
    nlohmann::ordered_json j;
    j["runs"] = nlohmann::ordered_json::array();
    for (const RunDocuments& r : runs) j["runs"].push_back(r.name);
    j["rows"] = nlohmann::ordered_json::array();
    for (const Row& r : rs) {
      nlohmann::ordered_json values = nlohmann::ordered_json::array();
      for (const auto& v : r.values) values.push_back(v ? nlohmann::ordered_json(*v) : nullptr);
      j["rows"].push_back({{"label", r.label}, {"unit", r.unit}, {"values", values}});
    }
    write_file_atomic(request.json_path, json_text(j, 1) + "\n");
  }
  out << table(runs, rs);
  out.flush();
  return 0;
}

}  // namespace circtest
