#include "circtest/core/conditions.hpp"

#include <array>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"

namespace circtest {

namespace {

constexpr std::array<ConditionOption, 8> kOptions = {{
    {"machine", "machine", "NAME", "machine name (the history is kept per machine)", false},
    {"serial", "machine_serial", "TEXT", "machine serial number", false},
    {"instrument", "instrument", "TEXT", "instrument (type and serial number)", false},
    {"operator", "operator", "NAME", "who ran the test", false},
    {"location", "location", "TEXT", "where the machine stands", false},
    {"t-machine", "temperature_machine_C", "C", "machine temperature, deg C", true},
    {"t-instrument", "temperature_instrument_C", "C", "instrument temperature, deg C", true},
    {"notes", "notes", "TEXT", "free text for the report", false},
}};

}  // namespace

std::span<const ConditionOption> condition_options() noexcept {
  return kOptions;
}

const ConditionOption* condition_option_for_key(std::string_view key) noexcept {
  for (const auto& o : kOptions) {
    if (key == o.key) return &o;
  }
  return nullptr;
}

std::string condition_value(const ConditionOption& option, std::string_view value) {
  const std::string name = std::string("--") + option.option;
  const auto b = value.find_first_not_of(" \t");
  if (b == std::string_view::npos) throw UsageError(name + ": expected a value, got nothing");
  const auto e = value.find_last_not_of(" \t");
  const std::string_view v = value.substr(b, e - b + 1);
  if (v.find_first_of("\r\n") != std::string_view::npos) {
    throw UsageError(name + ": expected one line, got a line break");
  }
  if (option.numeric) {
    parse_option_number(name, v);  // throws UsageError on anything but a finite number
  }
  return std::string(v);
}

}  // namespace circtest
