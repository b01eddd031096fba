#pragma once
// circlog-record's command line: the option words, their help and their checks, turned into
// the recorder's RecordRequest (recorder.hpp).
#include <cstdio>
#include <optional>

#include "recorder.hpp"

namespace circtest::circlog_record {

// Parses the command line; nullopt when --help or --version was given (printed to `out`).
// Reads the --program header, so a program that cannot be used is refused before any HAL
// work. Throws UsageError, IoError and ParseError.
std::optional<RecordRequest> parse_options(int argc, const char* const* argv, std::FILE* out);

}  // namespace circtest::circlog_record
