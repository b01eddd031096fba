#include "circtest/gcode/option_values.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"

namespace circtest {

namespace {
std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return {};
  const auto last = text.find_last_not_of(" \t");
  return text.substr(first, last - first + 1);
}
}  // namespace

double parse_option_number(const std::string& option, const std::string& text) {
  const auto number = parse_finite(text);
  if (!number) throw UsageError(fmt::format("--{}: '{}' is not a number", option, text));
  return *number;
}

std::vector<double> parse_option_numbers(const std::string& option, const std::string& text,
                                         std::size_t count) {
  std::vector<double> numbers;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = text.find(',', begin);
    numbers.push_back(parse_option_number(option, text.substr(begin, comma - begin)));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  if (count > 0 && numbers.size() != count) {
    throw UsageError(fmt::format("--{}: '{}' needs {} comma-separated numbers, got {}", option,
                                 text, count, numbers.size()));
  }
  return numbers;
}

int parse_option_index(const std::string& option, const std::string& text) {
  const std::string value = trim(text);
  int index = 0;
  const auto result = std::from_chars(value.data(), value.data() + value.size(), index);
  if (value.empty() || result.ec != std::errc{} || result.ptr != value.data() + value.size() ||
      index < 0) {
    throw UsageError(fmt::format("--{}: '{}' is not an output number", option, text));
  }
  return index;
}

}  // namespace circtest
