#pragma once
// The common frame of every circtest executable: run the body, turn exceptions into one
// line on stderr ("prog: error: ...") and the documented exit code.
#include <functional>
#include <string>
#include <vector>

namespace circtest {

// Runs body(); returns its result, or the exit code of the circtest::Error it threw
// (ExitCode::internal for any other exception). Prints nothing on success. Standard output
// is flushed before returning: a write that failed (a full disk, a closed pipe) is
// ExitCode::io with a message, whatever body() returned.
int run_cli(const char* program_name, const std::function<int()>& body);

// Throws UsageError when an argument holds one of Boost.Program_options' message
// placeholders (%option%, %original_token%, ...): its error text substitutes them again and
// again, so such an argument in a bad command line never returns (found by fuzz_circgen_args).
void refuse_option_placeholders(int argc, const char* const* argv);
void refuse_option_placeholders(const std::vector<std::string>& args);  // args[0] included

}  // namespace circtest
