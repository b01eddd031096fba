#pragma once
// The test conditions a person states rather than a sensor measures (ISO 230-4 clauses 4.4
// and 6): the same options on circlog-record, circtest-run and circana, each written as one
// trace metadata key, so a report can name machine, instrument, operator and temperatures.
#include <span>
#include <string>
#include <string_view>

namespace circtest {

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

// The option that writes `key`, or nullptr.
const ConditionOption* condition_option_for_key(std::string_view key) noexcept;

// A value as it goes into the metadata: trimmed, one line (a metadata line cannot hold a
// newline), not empty, a finite number for temperatures. Throws UsageError naming --option.
std::string condition_value(const ConditionOption& option, std::string_view value);

}  // namespace circtest
