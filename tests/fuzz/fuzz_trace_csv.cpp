// The text trace reader: any bytes give a Trace or a ParseError/DataError, nothing else; and
// the text read in stretches on three threads gives the same trace, or the same error, as one.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "circtest/core/trace.hpp"
#include "fuzz_main_common.hpp"

namespace {

// The trace, or the error's code and message, as one comparable string.
std::string outcome(std::string_view text, const circtest::TraceReadOptions& options) {
  std::string out;
  circtest::fuzz::expect_documented_outcome([&] {
    try {
      const circtest::Trace t = circtest::parse_trace(text, "fuzz.csv", options);
      // What the reader promises its users: one value per row in every column, finite.
      for (const auto& column : t.values) {
        if (column.size() != t.rows()) std::abort();
      }
      for (const auto& column : t.values) {
        out.append(reinterpret_cast<const char*>(column.data()), column.size() * sizeof(double));
      }
      for (const std::uint32_t line : t.line_of_row) out += std::to_string(line) + ',';
      for (std::size_t i = 0; i < t.metadata.entries().size(); ++i) {
        const auto& [key, value] = t.metadata.entries()[i];
        out += key + '=' + value + '@' + std::to_string(t.metadata.line_at(i)) + ';';
      }
    } catch (const circtest::Error& e) {
      out = "error " + std::to_string(static_cast<int>(e.code())) + ' ' + e.what();
      throw;
    }
  });
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  circtest::TraceReadOptions one;
  one.threads = 1;
  circtest::TraceReadOptions three;
  three.threads = 3;
  three.parallel_min_bytes = 0;  // split even the smallest input
  if (outcome(text, one) != outcome(text, three)) {
    std::fprintf(stderr, "one thread and three threads read this input differently\n");
    std::abort();
  }
  return 0;
}
