// circcomp's reader of a configuration's HAL files (compensation/friction: the nets, setp,
// addf and delf it follows to splice circfric): arbitrary text as a HAL file, with an INI
// whose values replace [SECTION]KEY words. What parses keeps its maps consistent: every pin
// on a signal is on exactly that one, each once, and every thread lists each addf'ed function
// at a place halcmd's addf positions allow.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "circtest/compensation/friction.hpp"
#include "circtest/core/ini.hpp"
#include "fuzz_main_common.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  static const circtest::IniDocument ini = circtest::IniDocument::parse(
      "[KINS]\nKINEMATICS = trivkins\nJOINTS = 3\n[JOINT_0]\nP = 50\n[A]\nB = x y\n", "f.ini");
  circtest::fuzz::expect_documented_outcome([&] {
    const auto w = circtest::compensation::parse_hal_text(text, "fuzz.hal", ini);
    for (const auto& [pin, signal] : w.pin_signal) {
      const auto it = w.signals.find(signal);
      check(it != w.signals.end());
      check(it->second.pins.count(pin) == 1);
    }
    for (const auto& [name, signal] : w.signals) {
      for (const auto& pin : signal.pins) {
        const auto it = w.pin_signal.find(pin);
        check(it != w.pin_signal.end() && it->second == name);
      }
    }
    for (const auto& [thread, functions] : w.threads) {
      for (const auto& f : functions) check(w.addf.count(f) == 1);
    }
  });
  return 0;
}
