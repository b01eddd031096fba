#pragma once
// SHA-256 of a configuration, for provenance (trace metadata ini_sha256, circcomp apply).
#include <string>
#include <string_view>

namespace circtest {

// Lower-case hex digest of DATA.
std::string sha256_hex(std::string_view data);
// Of a whole file; throws IoError.
std::string sha256_of_file(const std::string& path);

}  // namespace circtest
