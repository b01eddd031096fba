#pragma once
// The circtest release, CMake's project version: every program's --version prints it, and
// circgen writes it into the program header.
#include <string_view>

namespace circtest {

// "0.1.0"
std::string_view version() noexcept;

// "<program> <version>", the line --version prints.
std::string version_line(std::string_view program);

}  // namespace circtest
