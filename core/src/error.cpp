#include "circtest/core/error.hpp"

#include <fmt/format.h>

namespace circtest {

namespace {
std::string place(const std::string& file, std::size_t line) {
  const std::string& name = file.empty() ? std::string("<input>") : file;
  return line > 0 ? fmt::format("{}:{}", name, line) : name;
}
}  // namespace

InputError::InputError(ExitCode code, const std::string& file, std::size_t line,
                       const std::string& message)
    : Error(code, place(file, line) + ": " + message), file_(file), line_(line), detail_(message) {}

}  // namespace circtest
