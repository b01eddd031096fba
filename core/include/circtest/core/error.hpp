#pragma once
// One error hierarchy for every part of circtest. Each CLI maps Error::code() to its exit
// status; the table with a message for each code lives in README.md ("Exit codes").
#include <cstddef>
#include <stdexcept>
#include <string>

namespace circtest {

enum class ExitCode : int {
  ok = 0,
  internal = 1,      // a bug or an unexpected failure (std::bad_alloc, ...)
  usage = 2,         // bad command-line options or option values
  io = 3,            // a file cannot be opened, read, written or renamed
  parse = 4,         // an input file is malformed (file and line in the message)
  data = 5,          // input well-formed but unusable (too few points, arc under 90 deg, ...)
  limit = 6,         // a request violates a machine limit (soft limits, velocity, acceleration)
  hal = 7,           // HAL/LinuxCNC not available or the component is not loaded
  data_loss = 8,     // the recorder lost samples (overruns or gaps); the file is still complete
  tolerance = 9,     // a checked limit was breached (circana history --limits); not an error
  stale = 10,        // circcomp apply: the INI changed since the measurement
  database = 11,     // the history database cannot be opened, read or written
  unsafe_path = 12,  // circcomp: a path outside the configuration, a link or not a regular file
  unreported = 13,   // circcomp apply/revert: the change IS made, standard output failed after it
};

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const noexcept { return code_; }

 private:
  ExitCode code_;
};

class UsageError : public Error {
 public:
  explicit UsageError(const std::string& message) : Error(ExitCode::usage, message) {}
};

class IoError : public Error {
 public:
  IoError(const std::string& path, const std::string& message)
      : Error(ExitCode::io, path + ": " + message), path_(path) {}
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
};

// An error tied to a place in an input file. line 0 means "the file as a whole".
// what() reads "file:line: message" (or "file: message" for line 0).
class InputError : public Error {
 public:
  InputError(ExitCode code, const std::string& file, std::size_t line, const std::string& message);
  const std::string& file() const noexcept { return file_; }
  std::size_t line() const noexcept { return line_; }
  const std::string& detail() const noexcept { return detail_; }

 private:
  std::string file_;
  std::size_t line_;
  std::string detail_;
};

class ParseError : public InputError {
 public:
  ParseError(const std::string& file, std::size_t line, const std::string& message)
      : InputError(ExitCode::parse, file, line, message) {}
};

class DataError : public InputError {
 public:
  DataError(const std::string& file, std::size_t line, const std::string& message)
      : InputError(ExitCode::data, file, line, message) {}
};

class LimitError : public Error {
 public:
  explicit LimitError(const std::string& message) : Error(ExitCode::limit, message) {}
};

class StaleError : public Error {
 public:
  explicit StaleError(const std::string& message) : Error(ExitCode::stale, message) {}
};

class DatabaseError : public Error {
 public:
  explicit DatabaseError(const std::string& message) : Error(ExitCode::database, message) {}
};

// A file circcomp was asked to read back, write, rename or remove that lies outside the
// configuration directory, is reached through a symbolic link, or is not a regular file.
class UnsafePathError : public Error {
 public:
  UnsafePathError(const std::string& path, const std::string& message)
      : Error(ExitCode::unsafe_path, path + ": " + message), path_(path) {}
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
};

class HalError : public Error {
 public:
  explicit HalError(const std::string& message) : Error(ExitCode::hal, message) {}
};

}  // namespace circtest
