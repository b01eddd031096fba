#include "circtest/core/error.hpp"

namespace circtest {

const char* exit_code_name(ExitCode code) noexcept {
  switch (code) {
    case ExitCode::ok: return "ok";
    case ExitCode::internal: return "internal";
    case ExitCode::usage: return "usage";
    case ExitCode::io: return "io";
    case ExitCode::parse: return "parse";
    case ExitCode::data: return "data";
    case ExitCode::limit: return "limit";
    case ExitCode::hal: return "hal";
    case ExitCode::data_loss: return "data-loss";
  }
  return "unknown";
}

namespace {
std::string place(const std::string& file, std::size_t line) {
  std::string out = file.empty() ? std::string("<input>") : file;
  if (line > 0) out += ":" + std::to_string(line);
  return out;
}
}  // namespace

InputError::InputError(ExitCode code, const std::string& file, std::size_t line,
                       const std::string& message)
    : Error(code, place(file, line) + ": " + message), file_(file), line_(line), detail_(message) {}

}  // namespace circtest
