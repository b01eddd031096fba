#pragma once
// The small text helpers every part needs, once.
#include <string>
#include <string_view>

namespace circtest {

// The text without leading and trailing blanks (space, tab, CR, LF).
constexpr std::string_view trim(std::string_view text) noexcept {
  constexpr std::string_view kBlanks = " \t\r\n";
  const auto first = text.find_first_not_of(kBlanks);
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(kBlanks);
  return text.substr(first, last - first + 1);
}

// The items with `separator` between them ("a,b,c"); any range of things that convert to
// std::string_view.
template <typename Range>
std::string join(const Range& items, std::string_view separator = ",") {
  std::string out;
  bool first = true;
  for (const auto& item : items) {
    if (!first) out += separator;
    out += std::string_view(item);
    first = false;
  }
  return out;
}

// The text with &, <, > and " replaced by their entities: safe inside XML/HTML text and
// double-quoted attribute values (SVG plots, the HTML report).
inline std::string xml_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace circtest
