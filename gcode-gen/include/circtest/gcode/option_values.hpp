#pragma once
// Strict parsing of circgen's option values, so a malformed number is refused with the
// option's name instead of being read as a prefix.
#include <string>
#include <vector>

namespace circtest {

// A finite number, the whole text; UsageError "--<option>: '<text>' is not a number".
double parse_option_number(const std::string& option, const std::string& text);

// Comma-separated finite numbers, at least one; `count` > 0 demands exactly that many.
std::vector<double> parse_option_numbers(const std::string& option, const std::string& text,
                                         std::size_t count = 0);

// A non-negative integer (an output number).
int parse_option_index(const std::string& option, const std::string& text);

}  // namespace circtest
