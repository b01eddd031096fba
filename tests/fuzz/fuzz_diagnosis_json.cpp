// The diagnosis reader of circcomp (compensation/diagnosis_input): any bytes parse or give a
// documented input error (ParseError, DataError), never a JSON library exception. What parses
// holds finite numbers only, a known plane, and a cyclic pitch within the range that sizes a
// compensation table.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>

#include "circtest/compensation/diagnosis_input.hpp"
#include "fuzz_main_common.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

void check_finite(const std::optional<double>& v) {
  check(!v || std::isfinite(*v));
}

void check_measured(const circtest::compensation::Measured& m) {
  check_finite(m.value);
  check_finite(m.standard_error);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace circtest::compensation;
  const std::string text(reinterpret_cast<const char*>(data), size);
  circtest::fuzz::expect_documented_outcome([&] {
    const DiagnosisInput in = parse_diagnosis(text, "fuzz.json");
    const circtest::Diagnosis& d = in.diagnosis;
    check(d.plane == circtest::Plane::XY || d.plane == circtest::Plane::YZ ||
          d.plane == circtest::Plane::ZX);
    for (int k = 0; k < 2; ++k) {
      check_measured(d.backlash_mm[k]);
      check_measured(d.spike_mm[k]);
      check_measured(d.scale_ppm[k]);
      check_finite(d.spike_ms[k].value);
      if (d.cyclic[k]) {
        const Cyclic& c = *d.cyclic[k];
        check(std::isfinite(c.amplitude_mm) && std::isfinite(c.phase_rad));
        check(c.pitch_mm >= 1e-3 && c.pitch_mm <= 1e4);
        check_finite(c.amplitude_se_mm);
      }
    }
    check_measured(d.scale_mismatch_ppm);
    check_measured(d.squareness_urad);
    check_measured(d.servo_mismatch_ms);
    check_finite(d.kv_per_s.value);
  });
  return 0;
}
