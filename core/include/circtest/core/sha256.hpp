#pragma once
// SHA-256 of a configuration, for provenance (trace metadata ini_sha256, circcomp apply).
#include <string>
#include <string_view>

#include "circtest/core/trace.hpp"

namespace circtest {

// Lower-case hex digest of DATA.
std::string sha256_hex(std::string_view data);
// Of a whole file; throws IoError.
std::string sha256_of_file(const std::string& path);

// The machine's INI the test ran with: its path (`ini`) and the SHA-256 of its bytes
// (`ini_sha256`), which circcomp apply compares with the INI it is about to change. Every
// writer of a trace (circlog-record, circana import) records it through this one function.
// Throws IoError.
void record_ini_provenance(TraceMetadata& metadata, const std::string& ini_path);

}  // namespace circtest
