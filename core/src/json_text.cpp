#include "circtest/core/json_text.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "circtest/core/input_file.hpp"
#include "circtest/core/strings.hpp"

namespace circtest {

namespace {

// The 1-based line of byte `offset`.
std::size_t line_at(std::string_view text, std::size_t offset) {
  offset = std::min(offset, text.size());
  return 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + offset, '\n'));
}

// Refuses nesting deeper than kMaxJsonDepth before the library builds (and later walks,
// recursively) the tree: the line where the limit is passed.
void check_depth(std::string_view text, const std::string& source) {
  std::size_t depth = 0;
  bool in_string = false, escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (c == '\\') {
        escaped = true;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth) {
        throw ParseError(
            source, line_at(text, i),
            fmt::format("arrays and objects nested deeper than {} levels", kMaxJsonDepth));
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

// The library's DOM builder, keeping the position of the first error instead of throwing.
template <class J>
class PositionedParser : public nlohmann::detail::json_sax_dom_parser<J> {
 public:
  explicit PositionedParser(J& result) : nlohmann::detail::json_sax_dom_parser<J>(result, false) {}
  template <class Exception>
  bool parse_error(std::size_t position, const std::string& /*last_token*/, const Exception& ex) {
    error_position = position;
    error = ex.what();
    return false;
  }
  std::size_t error_position = 0;
  std::string error;
};

template <class J>
J parse_as(std::string_view text, const std::string& source) {
  check_depth(text, source);
  J result;
  PositionedParser<J> sax(result);
  const bool ok = J::sax_parse(text, &sax);
  if (ok && sax.error.empty()) return result;
  // "[json.exception.parse_error.101] parse error at line 1, column 5: syntax error ..."
  std::string what = sax.error.empty() ? std::string("incomplete document") : sax.error;
  if (const auto b = what.find("] "); what.starts_with("[json.exception.") && b != what.npos) {
    what.erase(0, b + 2);
  }
  if (what.starts_with("parse error")) {
    if (const auto colon = what.find(": "); colon != what.npos) what.erase(0, colon + 2);
  }
  // The position counts the characters read, the failing one included.
  const std::size_t at = sax.error_position > 0 ? sax.error_position - 1 : 0;
  const std::size_t line_start = text.rfind('\n', at == 0 ? 0 : at - 1);
  const std::size_t column = line_start == std::string_view::npos ? at + 1 : at - line_start;
  throw ParseError(
      source, line_at(text, at),
      fmt::format("not valid JSON (column {}): {}", column, utf8_replacing_invalid(what)));
}

}  // namespace

nlohmann::json parse_json_text(std::string_view text, const std::string& source) {
  return parse_as<nlohmann::json>(text, source);
}

nlohmann::ordered_json parse_ordered_json_text(std::string_view text, const std::string& source) {
  return parse_as<nlohmann::ordered_json>(text, source);
}

nlohmann::json read_json_file(const std::string& path, std::size_t max_bytes) {
  return parse_json_text(read_input_text(path, max_bytes), path);
}

nlohmann::ordered_json read_ordered_json_file(const std::string& path, std::size_t max_bytes) {
  return parse_ordered_json_text(read_input_text(path, max_bytes), path);
}

std::string json_text(const nlohmann::json& document, int indent) {
  return document.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string json_text(const nlohmann::ordered_json& document, int indent) {
  return document.dump(indent, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace circtest
