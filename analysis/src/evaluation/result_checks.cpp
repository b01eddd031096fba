#include "circtest/analysis/result_checks.hpp"

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <string>

#include "circtest/analysis/report.hpp"
#include "circtest/core/error.hpp"

namespace circtest {

namespace {
// The JSON path of the first float that is not finite or too large.
std::optional<std::pair<std::string, double>> first_bad(const nlohmann::ordered_json& j,
                                                        const std::string& path) {
  if (j.is_number_float()) {
    const double v = j.get<double>();
    if (!(std::abs(v) <= kMaxReportedMagnitude)) return std::make_pair(path, v);
    return std::nullopt;
  }
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) {
      if (auto bad = first_bad(value, path.empty() ? key : path + "." + key)) return bad;
    }
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) {
      if (auto bad = first_bad(j[i], fmt::format("{}[{}]", path, i))) return bad;
    }
  }
  return std::nullopt;
}
}  // namespace

void require_finite_results(const Evaluation& evaluation, RemedyWords words) {
  const auto bad = first_bad(to_json(evaluation), "");
  if (!bad) return;
  throw DataError(
      evaluation.source, 0,
      fmt::format("the result {} = {} is not a usable number (finite, at most {:g} in size); "
                  "check what it is computed from: the nominal radius (radius_mm, diameter_mm, "
                  "{}), the temperatures and expansion coefficients, the positions",
                  bad->first, bad->second, kMaxReportedMagnitude, words(Remedy::give_radius)));
}

}  // namespace circtest
