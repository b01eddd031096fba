#pragma once
// The common frame of every circtest executable: run the body, turn exceptions into one
// line on stderr ("prog: error: ...") and the documented exit code.
#include <cstddef>
#include <functional>
#include <span>
#include <string>
#include <string_view>
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

// Throws UsageError "<option>: not UTF-8 text (byte 0xFC at 2): give it in UTF-8" when
// `value` is not UTF-8: option values go into JSON documents, XML and the history, which hold
// UTF-8 only.
void require_utf8_option(std::string_view option, std::string_view value);

// The Levenshtein distance of two texts (insertions, deletions, substitutions of one byte).
std::size_t edit_distance(std::string_view a, std::string_view b);

// The candidate closest to `given` by edit distance when it is close enough to be a typing
// slip (at most a third of the longer name's length, at least 1), else "". Ties go to the
// earlier candidate. For "unknown option --radus; did you mean --radius?".
std::string closest_name(std::string_view given, std::span<const std::string> candidates);

// "unknown option --radus; did you mean --radius?" (without the question when nothing is
// close). `given` and the candidates as the user types them ("--radius").
std::string unknown_option_message(std::string_view given, std::span<const std::string> candidates);

}  // namespace circtest
