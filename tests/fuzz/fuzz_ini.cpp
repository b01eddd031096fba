// The INI reader (IniDocument): any bytes parse or give a ParseError; what parsed can be
// read back and edited, and an unedited document writes back the bytes it read (lossless).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "circtest/core/ini.hpp"
#include "fuzz_main_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  circtest::fuzz::expect_documented_outcome([&] {
    circtest::IniDocument doc = circtest::IniDocument::parse(text, "fuzz.ini");
    if (doc.render() != text) std::abort();  // lossless
    for (const std::string& section : doc.sections()) {
      for (const auto& e : doc.entries(section)) (void)doc.get(e.section, e.key);
    }
    doc.set("FUZZ", "KEY", "1");
    (void)doc.get("FUZZ", "KEY");
  });
  return 0;
}
