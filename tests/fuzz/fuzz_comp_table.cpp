// The COMP_FILE reader (LinuxCNC joint compensation tables, compensation/comp_table): the
// first byte picks COMP_FILE_TYPE (its low bit: 0 or 1), the rest is the table's text. What
// parses holds LinuxCNC's rules (1..256 entries, nominal strictly increasing, every value
// finite), gives finite trims anywhere, and what circcomp writes back from it reads back as
// the same table (circcomp rewrites a machine's own table when it adds trims).
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "circtest/compensation/comp_table.hpp"
#include "circtest/core/error.hpp"
#include "fuzz_main_common.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

void check_table(const circtest::compensation::CompTable& t) {
  check(!t.entries.empty() && t.entries.size() <= circtest::compensation::kMaxCompEntries);
  for (std::size_t i = 0; i < t.entries.size(); ++i) {
    const auto& e = t.entries[i];
    check(std::isfinite(e.nominal) && std::isfinite(e.forward_trim) &&
          std::isfinite(e.reverse_trim));
    if (i > 0) check(e.nominal > t.entries[i - 1].nominal);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const int type = data[0] & 1;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  circtest::fuzz::expect_documented_outcome([&] {
    using namespace circtest::compensation;
    const CompTable t = parse_comp_table(text, type, "fuzz.comp");
    check(t.type == type);
    check_table(t);
    for (const CompEntry& e : t.entries) {
      for (double p : {e.nominal, std::nextafter(e.nominal, 0.0)}) {
        const CompEntry at = t.at(p);
        check(std::isfinite(at.forward_trim) && std::isfinite(at.reverse_trim));
      }
    }
    // What circcomp writes back reads back: the same nominals and, for type 1, the same
    // trims; for type 0 the trims are differences, so within one rounding of the larger
    // position.
    CompTable back;
    try {
      back = parse_comp_table(render_comp_table(t), type, "rendered.comp");
    } catch (const circtest::Error& e) {
      std::fprintf(stderr, "the rendered table does not read back: %s\n", e.what());
      std::abort();
    }
    check(back.entries.size() == t.entries.size());
    for (std::size_t i = 0; i < t.entries.size(); ++i) {
      const CompEntry& a = t.entries[i];
      const CompEntry& b = back.entries[i];
      check(a.nominal == b.nominal);
      const double tol =
          type == 1 ? 0.0
                    : 4 * DBL_EPSILON *
                          std::max({std::fabs(a.nominal), std::fabs(a.nominal - a.forward_trim),
                                    std::fabs(a.nominal - a.reverse_trim)});
      check(std::fabs(a.forward_trim - b.forward_trim) <= tol &&
            std::fabs(a.reverse_trim - b.reverse_trim) <= tol);
    }
  });
  return 0;
}
