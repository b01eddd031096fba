#include "circtest/core/cli.hpp"

#include <cstdio>
#include <exception>
#include <new>
#include <string>
#include <string_view>

#include "circtest/core/error.hpp"

namespace circtest {

int run_cli(const char* program_name, const std::function<int()>& body) {
  try {
    return body();
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
