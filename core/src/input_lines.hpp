#pragma once
// Internal: the line-length cap shared by the text readers of core, and the shortening of a
// value quoted in their messages; not installed.
#include <cstddef>
#include <cstring>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"

namespace circtest::detail {

inline std::string line_too_long_message() {
  return fmt::format("line longer than {} bytes (1 MiB): expected one record per line",
                     kMaxInputLineBytes);
}

// A value quoted in a message, cut to 40 characters.
inline std::string shorten(std::string_view s) {
  if (s.size() > 40) return std::string(s.substr(0, 37)) + "...";
  return std::string(s);
}

}  // namespace circtest::detail

namespace circtest {

// Counts lines of a stream fed in pieces and throws ParseError at the first line longer than
// kMaxInputLineBytes, before the caller has buffered more than that of it.
class LineLengthGuard {
 public:
  explicit LineLengthGuard(std::string path) : path_(std::move(path)) {}
  void feed(std::string_view piece) {
    while (!piece.empty()) {
      const void* nl = std::memchr(piece.data(), '\n', piece.size());
      const std::size_t len =
          nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - piece.data()) : piece.size();
      current_ += len;
      if (current_ > kMaxInputLineBytes) {
        throw ParseError(path_, line_, detail::line_too_long_message());
      }
      if (!nl) return;
      ++line_;
      current_ = 0;
      piece.remove_prefix(len + 1);
    }
  }

 private:
  std::string path_;
  std::size_t line_ = 1;
  std::size_t current_ = 0;
};

}  // namespace circtest
