#include "circtest/core/cli.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>
#include <string>
#include <string_view>

#include "circtest/core/error.hpp"

namespace circtest {

namespace {

// What the program printed must have reached its destination: a full disk or a closed pipe
// under `> out.json` would otherwise leave a truncated document behind an exit status of 0.
// Returns the error's text, or "" when standard output took everything. The reason is known
// only when this last flush fails; an earlier failed write left no errno behind.
std::string standard_output_failure() {
  std::cout.flush();
  const bool stream_failed = !std::cout.good();
  errno = 0;
  const bool flush_failed = std::fflush(stdout) != 0 || std::ferror(stdout) != 0;
  if (!stream_failed && !flush_failed) return {};
  return errno != 0 ? std::string("write failed: ") + std::strerror(errno) : "write failed";
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

}  // namespace circtest
