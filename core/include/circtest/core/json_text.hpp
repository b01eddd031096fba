#pragma once
// JSON documents read and written the same way by every part: a document given by the user
// (a result, a diagnosis) is refused with a ParseError naming the file, the line and what is
// wrong, never with the JSON library's own exception (exit 1, no file named); a document
// written never throws on text that is not UTF-8.
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>

#include "circtest/core/error.hpp"

namespace circtest {

// A document read whole is at most this large (a result or diagnosis is a few hundred kB).
inline constexpr std::size_t kMaxJsonDocumentBytes = std::size_t{16} << 20;
// Arrays and objects nested deeper than this are refused (circtest writes at most 4 levels).
inline constexpr std::size_t kMaxJsonDepth = 64;

// Parses the document `text` of `source` (for messages). Throws ParseError naming source and
// the line for: text that is not JSON (including bytes that are not UTF-8 in a string), a
// number beyond the range of a double (1e400), nesting deeper than kMaxJsonDepth.
nlohmann::json parse_json_text(std::string_view text, const std::string& source);
nlohmann::ordered_json parse_ordered_json_text(std::string_view text, const std::string& source);
// The same for a file, read with read_input_text(path, max_bytes): IoError over the limit.
nlohmann::json read_json_file(const std::string& path,
                              std::size_t max_bytes = kMaxJsonDocumentBytes);
nlohmann::ordered_json read_ordered_json_file(const std::string& path,
                                              std::size_t max_bytes = kMaxJsonDocumentBytes);

// The document as text (dump(indent)); a string that is not UTF-8 (a file name) has each
// bad byte replaced by U+FFFD instead of the library throwing.
std::string json_text(const nlohmann::json& document, int indent = -1);
std::string json_text(const nlohmann::ordered_json& document, int indent = -1);

// An optional number as JSON: the number, or null when there is none.
inline nlohmann::json json_number_or_null(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

// Reads the keys of a parsed document: a missing key or one of the wrong type is a ParseError
// "<file>: <document> '<key path>': expected <what>", a number beyond its magnitude a
// DataError naming the key, so a document of another shape is refused instead of read as
// zeros. J is nlohmann::json or nlohmann::ordered_json.
template <class J>
class JsonReader {
 public:
  // `document` names the kind in messages ("result JSON"); `max_magnitude` bounds every number.
  JsonReader(std::string source, std::string document, double max_magnitude)
      : source_(std::move(source)), document_(std::move(document)), max_(max_magnitude) {}

  const std::string& source() const { return source_; }

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw ParseError(source_, 0, document_ + " '" + path + "': expected " + what);
  }
  static std::string key_path(const std::string& path, const char* key) {
    return path.empty() ? std::string(key) : path + "." + key;
  }
  const J& at(const J& j, const char* key, const std::string& path) const {
    if (!j.is_object()) fail(path.empty() ? std::string("(top)") : path, "an object");
    const auto it = j.find(key);
    if (it == j.end()) fail(key_path(path, key), "a value (missing)");
    return *it;
  }
  // A number at `path`, within +-max_magnitude.
  double number(const J& v, const std::string& path) const {
    if (!v.is_number()) fail(path, "a number");
    const double x = v.template get<double>();
    if (!(std::abs(x) <= max_)) {
      char text[128];
      std::snprintf(text, sizeof text, "%g is not a usable number (at most %g in size)", x, max_);
      throw DataError(source_, 0, document_ + " '" + path + "': " + text);
    }
    return x;
  }
  double number(const J& j, const char* key, const std::string& path) const {
    return number(at(j, key, path), key_path(path, key));
  }
  std::optional<double> optional_number(const J& j, const char* key,
                                        const std::string& path) const {
    const J& v = at(j, key, path);
    if (v.is_null()) return std::nullopt;
    if (!v.is_number()) fail(key_path(path, key), "a number or null");
    return number(v, key_path(path, key));
  }
  std::size_t count(const J& j, const char* key, const std::string& path) const {
    const J& v = at(j, key, path);
    if (!v.is_number_unsigned()) fail(key_path(path, key), "a non-negative integer");
    return v.template get<std::size_t>();
  }
  std::string text(const J& j, const char* key, const std::string& path) const {
    const J& v = at(j, key, path);
    if (!v.is_string()) fail(key_path(path, key), "a string");
    return v.template get<std::string>();
  }
  bool boolean(const J& j, const char* key, const std::string& path) const {
    const J& v = at(j, key, path);
    if (!v.is_boolean()) fail(key_path(path, key), "true or false");
    return v.template get<bool>();
  }
  const J& array(const J& j, const char* key, const std::string& path) const {
    const J& v = at(j, key, path);
    if (!v.is_array()) fail(key_path(path, key), "an array");
    return v;
  }

 private:
  std::string source_;
  std::string document_;
  double max_;
};

}  // namespace circtest
