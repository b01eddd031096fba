#include "circtest/core/conditions.hpp"

#include <array>

#include "circtest/core/cli.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest {

namespace {

constexpr std::array<ConditionOption, 8> kOptions = {{
    {"machine", meta_key::machine, "NAME", "machine name (the history is kept per machine)", false},
    {"serial", meta_key::machine_serial, "TEXT", "machine serial number", false},
    {"instrument", meta_key::instrument, "TEXT", "instrument (type and serial number)", false},
    {"operator", meta_key::operator_name, "NAME", "who ran the test", false},
    {"location", meta_key::location, "TEXT", "where the machine stands", false},
    {"t-machine", meta_key::temperature_machine_C, "C", "machine temperature, deg C", true},
    {"t-instrument", meta_key::temperature_instrument_C, "C", "instrument temperature, deg C",
     true},
    {"notes", meta_key::notes, "TEXT", "free text for the report", false},
}};

}  // namespace

std::span<const ConditionOption> condition_options() noexcept {
  return kOptions;
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
  require_utf8_option(name, v);
  if (option.numeric) parse_option_number(name, v, kTemperatureRangeC);
  return std::string(v);
}

}  // namespace circtest
