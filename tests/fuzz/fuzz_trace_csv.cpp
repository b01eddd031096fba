// The text trace reader: any bytes give a Trace or a ParseError/DataError, nothing else.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "circtest/core/trace.hpp"
#include "fuzz_main_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  circtest::fuzz::expect_documented_outcome([&] {
    const circtest::Trace t = circtest::parse_trace(text, "fuzz.csv");
    // What the reader promises its users: one value per row in every column, finite.
    for (const auto& column : t.values) {
      if (column.size() != t.rows()) std::abort();
    }
  });
  return 0;
}
