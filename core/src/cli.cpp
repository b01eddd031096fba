#include "circtest/core/cli.hpp"

#include <cstdio>
#include <exception>
#include <new>

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

}  // namespace circtest
