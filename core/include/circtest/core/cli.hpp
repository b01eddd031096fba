#pragma once
// The common frame of every circtest executable: run the body, turn exceptions into one
// line on stderr ("prog: error: ...") and the documented exit code.
#include <functional>

namespace circtest {

// Runs body(); returns its result, or the exit code of the circtest::Error it threw
// (ExitCode::internal for any other exception). Prints nothing on success.
int run_cli(const char* program_name, const std::function<int()>& body);

}  // namespace circtest
