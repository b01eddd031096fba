// The INI reader (IniDocument): any bytes parse or give a ParseError; what parsed can be
// read back and edited, and an unedited document writes back the bytes it read (lossless).
// Each lookup walks the document (a machine's INI is a few hundred lines and read a few dozen
// times), so the read-back is bounded: every key of every section once made this harness
// quadratic in the input and ran it at ~10 inputs/s on the 4 KB inputs it grows to.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "circtest/core/ini.hpp"
#include "fuzz_main_common.hpp"

namespace {
constexpr std::size_t kSections = 8;  // read back per input
constexpr std::size_t kKeys = 8;      // per section
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  circtest::fuzz::expect_documented_outcome([&] {
    circtest::IniDocument doc = circtest::IniDocument::parse(text, "fuzz.ini");
    if (doc.render() != text) std::abort();  // lossless
    const auto sections = doc.sections();
    for (std::size_t s = 0; s < sections.size() && s < kSections; ++s) {
      const auto entries = doc.entries(sections[s]);
      for (std::size_t k = 0; k < entries.size() && k < kKeys; ++k) {
        const auto& e = entries[k];
        // The first entry of a key wins (LinuxCNC's rule); "KEY =" is absent.
        std::size_t first = 0;
        while (entries[first].key != e.key) ++first;
        const auto got = doc.get(e.section, e.key);
        if (entries[first].value.empty() ? got.has_value() : got != entries[first].value) {
          std::abort();
        }
      }
    }
    doc.set("FUZZ", "KEY", "1");
    if (doc.get("FUZZ", "KEY") != "1") std::abort();
  });
  return 0;
}
