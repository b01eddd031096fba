#pragma once
// circlog-record without HAL: option parsing, the G-code header, and the loop that drains a
// circlog ring into a trace. The executable supplies the ring (shared memory of the loaded
// module) and the clock; the unit tests supply a ring in heap memory and a fake clock.
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "circlog_kernel.hpp"

namespace circtest::circlog_record {

struct Options {
  std::string output;
  std::vector<std::string> columns;                               // empty: in-00, in-01, ...
  std::vector<std::pair<std::string, std::string>> descriptions;  // channel name, text
  std::optional<double> duration_s;
  std::optional<double> idle_s;  // --until-idle
  std::string program;           // G-code file whose (key: value) header is copied
  std::string ini;               // the machine's INI: its path and SHA-256 go into the metadata
  // --machine, --operator, ...: metadata key and value; they win over the program header.
  std::vector<std::pair<std::string, std::string>> conditions;
  int decimals = 6;
  double poll_s = 0.005;
};

// Parses the command line; nullopt when --help or --version was given (printed to `out`).
// Throws UsageError.
std::optional<Options> parse_options(int argc, const char* const* argv, std::FILE* out);

// The `(key: value)` comments at the top of a G-code program (before its first line of
// code), in file order. Throws IoError.
std::vector<std::pair<std::string, std::string>> read_program_header(const std::string& path);

// What the loop needs from the world outside the ring.
class Environment {
 public:
  virtual ~Environment() = default;
  virtual void sleep(double seconds) = 0;
  virtual double monotonic_s() = 0;
  virtual bool stop_requested() = 0;  // SIGINT/SIGTERM arrived
  virtual bool process_alive(std::int32_t pid) = 0;
  virtual std::string utc_now_iso8601() = 0;
};

struct Summary {
  std::size_t rows = 0;
  std::uint64_t runs = 0;
  std::uint64_t overruns = 0;  // the module's overrun counter over the recording
  std::uint64_t gaps = 0;      // places where records are missing
  std::uint64_t lost = 0;      // records missing in all
  std::string stop_reason;
};

// Claims the ring, writes options.output (an unnamed temporary that appears there when complete)
// and returns what happened. Lost records are reported on `log` and in the trailer metadata; the
// caller decides the exit code. Throws HalError when the ring cannot be used (no servo thread,
// another reader), IoError for the file.
Summary record(circlog::Consumer& ring, std::int32_t pid, const Options& options, Environment& env,
               std::FILE* log);

}  // namespace circtest::circlog_record
