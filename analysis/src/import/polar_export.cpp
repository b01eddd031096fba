// circana export-polar: a trace's measured runs as an instrument's polar file (angle,
// deviation, run), read back by the import.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/analysis/instrument_export.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace_keys.hpp"
#include "export_columns.hpp"

namespace circtest {

namespace {

using import_detail::kDegPerRad;

// The metadata of a test an export carries: what it was, how it ran and on what machine;
// not the recorder's bookkeeping, which describes a file the export is not.
constexpr std::array kExportedKeys{
    meta_key::generator,
    meta_key::test,
    meta_key::date,
    meta_key::start_time,
    meta_key::feed_mm_per_min,
    meta_key::feeds_mm_per_min,
    meta_key::directions,
    meta_key::direction_labels,
    meta_key::arc_deg,
    meta_key::segments,
    meta_key::ini,
    meta_key::ini_sha256,
    meta_key::machine,
    meta_key::machine_serial,
    meta_key::instrument,
    meta_key::operator_name,
    meta_key::location,
    meta_key::notes,
    meta_key::temperature_air_C,
    meta_key::temperature_machine_C,
    meta_key::temperature_instrument_C,
    meta_key::expansion_machine_per_K,
    meta_key::expansion_instrument_per_K,
    meta_key::compensation,
    meta_key::other_axes,
};

}  // namespace

std::string polar_export_text(const Trace& trace, const Evaluation& ev) {
  if (ev.runs.empty()) throw DataError(trace.source, 0, "no measured run to export");
  const PlanePoint centre = ev.centre.value_or(
      PlanePoint{ev.runs.front().lsc.centre_a_mm, ev.runs.front().lsc.centre_b_mm});
  const double radius_mm = ev.nominal_radius_mm.value_or(ev.runs.front().lsc.radius_mm);
  // The runs keep their segment ids when those tell them apart, so that the announced runs
  // (`segments`) still match; else they are numbered and the announcement is left out.
  std::vector<long> ids;
  for (const RunResult& r : ev.runs) ids.push_back(r.run.segment_id);
  std::vector<long> sorted = ids;
  std::sort(sorted.begin(), sorted.end());
  const bool own_ids =
      sorted.front() > 0 && std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end();
  if (!own_ids) std::iota(ids.begin(), ids.end(), 1L);

  std::string out = fmt::format("# {}: {}\n", kExportedByKey, kExportedByPolar);
  out += fmt::format("# {}: {}\n", meta_key::plane, plane_name(ev.plane));
  out += fmt::format("# {}: {}\n", meta_key::radius_mm, radius_mm);
  for (const char* key : kExportedKeys) {
    if (!own_ids && (std::string_view(key) == meta_key::segments)) continue;
    if (const std::string* v = trace.metadata.find(key)) {
      out += fmt::format("# {}: {}\n", key, *v);
    }
  }
  out += "angle_deg,dev_um,run\n";
  const auto& a = trace.values[ev.columns.a];
  const auto& b = trace.values[ev.columns.b];
  for (std::size_t k = 0; k < ev.runs.size(); ++k) {
    const Run& run = ev.runs[k].run;
    double previous = 0.0;
    for (std::size_t i = run.begin; i < run.end; ++i) {
      const double da = a[i] - centre.a_mm, db = b[i] - centre.b_mm;
      double angle = std::atan2(db, da) * kDegPerRad;
      if (i > run.begin) {
        // Unwrapped: a run's angles continue past +-180 deg, so its sense stays readable.
        angle = previous + std::remainder(angle - previous, 360.0);
      }
      previous = angle;
      out +=
          fmt::format("{:.7f},{:.5f},{}\n", angle, (std::hypot(da, db) - radius_mm) * 1e3, ids[k]);
    }
  }
  return out;
}

}  // namespace circtest
