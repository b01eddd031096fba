#pragma once
// The small text helpers every part needs, once.
#include <cstddef>
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

// The byte offset of the first byte of `text` that does not belong to a well-formed UTF-8
// sequence (overlong forms, surrogates and code points above U+10FFFF are not), or npos.
std::size_t invalid_utf8_offset(std::string_view text) noexcept;

// The text with each byte that is not part of well-formed UTF-8 replaced by U+FFFD, the way
// circtest writes text it cannot refuse (a file name) into JSON, XML and the history.
std::string utf8_replacing_invalid(std::string_view text);

// The text with &, <, > and " replaced by their entities, bytes that are not UTF-8 and the
// control characters XML 1.0 forbids replaced by U+FFFD: safe inside XML/HTML text and
// double-quoted attribute values (SVG plots, the HTML report), whatever the text held.
std::string xml_escape(std::string_view text);

// The text with every byte outside printable ASCII written as \xNN: an error line that quotes
// its input never carries the invalid UTF-8 or control bytes that caused it.
std::string printable_ascii(std::string_view text);

}  // namespace circtest
