#include "circtest/core/numbers.hpp"

#include <fast_float/fast_float.h>
#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <string>

#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"

namespace circtest {

std::optional<double> parse_number(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) {
    text.remove_suffix(1);
  }
  if (text.empty()) return std::nullopt;
  const char* first = text.data();
  const char* last = first + text.size();
  if (*first == '+') ++first;  // from_chars rejects a leading '+', people write it
  double v = 0.0;
  const auto res = fast_float::from_chars(first, last, v);
  if (res.ec != std::errc() || res.ptr != last) return std::nullopt;
  return v;
}

std::optional<double> parse_finite(std::string_view text) {
  const auto v = parse_number(text);
  if (!v || !std::isfinite(*v)) return std::nullopt;
  return v;
}

double parse_option_number(std::string_view option, std::string_view text) {
  const auto v = parse_finite(text);
  if (!v) throw UsageError(fmt::format("{}: expected a number, got '{}'", option, text));
  return *v;
}

double parse_option_number(std::string_view option, std::string_view text,
                           const NumberRange& range) {
  const auto v = parse_finite(text);
  if (!v || !range.contains(*v)) {
    throw UsageError(fmt::format("{}: expected {}, got '{}'", option, range.expected, text));
  }
  return *v;
}

std::vector<double> parse_option_list(std::string_view option, std::string_view text,
                                      std::size_t count) {
  std::vector<double> out;
  std::size_t pos = 0;
  while (true) {
    const std::size_t comma = text.find(',', pos);
    const std::string_view item =
        text.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos);
    const auto v = parse_finite(item);
    if (!v) {
      throw UsageError(fmt::format("{}: expected {} comma-separated numbers, got '{}'", option,
                                   count ? std::to_string(count) : std::string("one or more"),
                                   text));
    }
    out.push_back(*v);
    if (comma == std::string_view::npos) break;
    pos = comma + 1;
  }
  if (count && out.size() != count) {
    throw UsageError(
        fmt::format("{}: expected {} comma-separated numbers, got '{}'", option, count, text));
  }
  return out;
}

int parse_option_index(std::string_view option, std::string_view text) {
  const std::string_view value = trim(text);
  int index = 0;
  const char* last = value.data() + value.size();
  const auto result = std::from_chars(value.data(), last, index);
  if (value.empty() || result.ec != std::errc{} || result.ptr != last || index < 0) {
    throw UsageError(fmt::format("{}: expected a non-negative integer, got '{}'", option, text));
  }
  return index;
}

}  // namespace circtest
