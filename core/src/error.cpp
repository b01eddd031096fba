#include "circtest/core/error.hpp"

#include <fmt/format.h>

namespace circtest {

const char* exit_code_name(ExitCode code) noexcept {
  switch (code) {
    case ExitCode::ok:
      return "ok";
    case ExitCode::internal:
      return "internal";
    case ExitCode::usage:
      return "usage";
    case ExitCode::io:
      return "io";
    case ExitCode::parse:
      return "parse";
    case ExitCode::data:
      return "data";
    case ExitCode::limit:
      return "limit";
    case ExitCode::hal:
      return "hal";
    case ExitCode::data_loss:
      return "data-loss";
    case ExitCode::stale:
      return "stale";
    case ExitCode::tolerance:
      return "tolerance";
    case ExitCode::database:
      return "database";
    case ExitCode::unsafe_path:
      return "unsafe-path";
  }
  return "unknown";
}

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
