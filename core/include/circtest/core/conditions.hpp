#pragma once
// The test conditions a person states rather than a sensor measures (ISO 230-4 clauses 4.4
// and 6): the same options on circlog-record, circtest-run and circana, each written as one
// trace metadata key, so a report can name machine, instrument, operator and temperatures.
#include <span>
#include <string>
#include <string_view>

#include "circtest/core/numbers.hpp"

namespace circtest {

// A temperature of the test (--t-machine, --t-instrument): from absolute zero to 1000 deg C,
// the bounds the trace metadata of the same quantities has (docs/trace-format.md).
inline constexpr NumberRange kTemperatureRangeC{-273.15, 1000.0, false,
                                                "a temperature in deg C from -273.15 to 1000"};

struct ConditionOption {
  const char* option;      // without the dashes: "machine" is --machine
  const char* key;         // the trace metadata key it is written as
  const char* value_name;  // for --help
  const char* help;
  bool numeric;  // a temperature in deg C: must be a finite number
};

// --machine, --serial, --instrument, --operator, --location, --t-machine, --t-instrument,
// --notes, in that order.
std::span<const ConditionOption> condition_options() noexcept;

// A value as it goes into the metadata: trimmed, one line (a metadata line cannot hold a
// newline), UTF-8 text, not empty, a temperature within kTemperatureRangeC. Throws
// UsageError naming --option.
std::string condition_value(const ConditionOption& option, std::string_view value);

}  // namespace circtest
