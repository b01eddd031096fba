#include "circtest/core/cli.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>
#include <string>
#include <string_view>

#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"

namespace circtest {

namespace {

// What the program printed must have reached its destination: a full disk or a closed pipe
// under `> out.json` would otherwise leave a truncated document behind an exit status of 0.
// Returns the error's text, or "" when standard output took everything. cout shares stdio's
// buffer, so its flush writes what is left and a full disk fails it again with the reason.
std::string standard_output_failure() {
  errno = 0;
  std::cout.flush();
  int reason = errno;
  const bool stream_failed = !std::cout.good();
  const bool flush_failed = std::fflush(stdout) != 0 || std::ferror(stdout) != 0;
  if (reason == 0) reason = errno;
  if (!stream_failed && !flush_failed) return {};
  return reason != 0 ? std::string("write failed: ") + std::strerror(reason) : "write failed";
}

}  // namespace

int run_cli(const char* program_name, const std::function<int()>& body) {
  try {
    const int code = body();
    const std::string failure = standard_output_failure();
    if (!failure.empty()) {
      std::fprintf(stderr, "%s: error: standard output: %s\n", program_name, failure.c_str());
      return static_cast<int>(ExitCode::io);
    }
    return code;
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: error: %s\n", program_name, e.what());
    return static_cast<int>(e.code());
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: error: out of memory\n", program_name);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: internal error: %s\n", program_name, e.what());
  }
  return static_cast<int>(ExitCode::internal);
}

namespace {
void refuse_placeholders_in(std::string_view arg, std::size_t index) {
  static constexpr std::string_view kPlaceholders[] = {"%canonical_option%", "%option%",
                                                       "%original_token%", "%value%", "%prefix%"};
  for (const std::string_view p : kPlaceholders) {
    if (arg.find(p) != std::string_view::npos) {
      throw UsageError("argument " + std::to_string(index) + ": '" + std::string(p) +
                       "' is not accepted in an argument");
    }
  }
}
}  // namespace

void refuse_option_placeholders(int argc, const char* const* argv) {
  for (int i = 1; i < argc; ++i) refuse_placeholders_in(argv[i], static_cast<std::size_t>(i));
}

void refuse_option_placeholders(const std::vector<std::string>& args) {
  for (std::size_t i = 0; i < args.size(); ++i) refuse_placeholders_in(args[i], i + 1);
}

void require_utf8_option(std::string_view option, std::string_view value) {
  const std::size_t bad = invalid_utf8_offset(value);
  if (bad == std::string_view::npos) return;
  char byte[8];
  std::snprintf(byte, sizeof byte, "0x%02X", static_cast<unsigned char>(value[bad]));
  throw UsageError(std::string(option) + ": not UTF-8 text (byte " + byte + " at " +
                   std::to_string(bad + 1) + "): give it in UTF-8");
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  // One row of the dynamic programme: row[j] is the distance of a[0, i) and b[0, j).
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({above + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string closest_name(std::string_view given, std::span<const std::string> candidates) {
  std::string best;
  std::size_t best_distance = 0;
  for (const std::string& c : candidates) {
    const std::size_t d = edit_distance(given, c);
    const std::size_t allowed = std::max<std::size_t>(1, std::max(given.size(), c.size()) / 3);
    if (d <= allowed && (best.empty() || d < best_distance)) {
      best = c;
      best_distance = d;
    }
  }
  return best;
}

std::string unknown_option_message(std::string_view given,
                                   std::span<const std::string> candidates) {
  std::string message = "unknown option " + std::string(given);
  const std::string guess = closest_name(given, candidates);
  if (!guess.empty()) message += "; did you mean " + guess + "?";
  return message;
}

}  // namespace circtest
