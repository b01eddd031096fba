// The whole evaluation on a text trace: segmentation, the four fits, H, G, F and the report.
// Beyond the common rules (fuzz_main_common.hpp), a report must never carry a non-finite
// number: the JSON document is checked for NaN and infinities.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/report.hpp"
#include "circtest/core/trace.hpp"
#include "fuzz_main_common.hpp"

namespace {
void check_finite(const nlohmann::ordered_json& j) {
  if (j.is_number_float() && !std::isfinite(j.get<double>())) std::abort();
  if (j.is_structured()) {
    for (const auto& v : j) check_finite(v);
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 64 * 1024) return 0;  // the fits are linear; long inputs only slow the search
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  circtest::fuzz::expect_documented_outcome([&] {
    const circtest::Trace t = circtest::parse_trace(text, "fuzz.csv");
    const circtest::Evaluation ev = circtest::evaluate(t, {});
    check_finite(circtest::to_json(ev));
    (void)circtest::text_report(ev);
  });
  return 0;
}
