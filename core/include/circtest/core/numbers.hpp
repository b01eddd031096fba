#pragma once
// Strict number parsing for command-line values and text formats (fast_float underneath).
#include <optional>
#include <string_view>
#include <vector>

namespace circtest {

// The whole text as one number (leading '+' and surrounding blanks allowed); nan and inf
// are numbers here, so callers can tell "not a number" from "not finite".
std::optional<double> parse_number(std::string_view text);
// The same, refusing nan and inf.
std::optional<double> parse_finite(std::string_view text);

// Option values for every CLI, one message style: UsageError "<option>: expected <what>,
// got '<text>'". `option` is the name as the user typed it ("--radius"), or an environment
// variable's name.
// A finite number, the whole text.
double parse_option_number(std::string_view option, std::string_view text);
// The plausible range of an option's value: [min, max], min itself excluded when above_min.
// `expected` says it in words for the message ("a radius in mm above 0 and at most 100000").
struct NumberRange {
  double min;
  double max;
  bool above_min;
  std::string_view expected;
  bool contains(double v) const { return (above_min ? v > min : v >= min) && v <= max; }
};
// A finite number within `range`: UsageError "<option>: expected <range.expected>, got
// '<text>'" for anything else.
double parse_option_number(std::string_view option, std::string_view text,
                           const NumberRange& range);
// "a,b,c" of finite numbers with exactly `count` of them (count 0: any number, at least one).
std::vector<double> parse_option_list(std::string_view option, std::string_view text,
                                      std::size_t count = 0);
// A non-negative integer (an output number, an index), the whole text.
int parse_option_index(std::string_view option, std::string_view text);

}  // namespace circtest
