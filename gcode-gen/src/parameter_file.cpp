#include "circtest/gcode/parameter_file.hpp"

#include <fmt/format.h>
#include <locale.h>
#include <sys/stat.h>

#include <cctype>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <vector>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/numbers.hpp"

namespace circtest {

namespace {

// RS274NGC_MAX_PARAMETERS (interp_parameter_def.hh): LinuxCNC refuses a file with a number
// at or above it, or at or below 0.
constexpr long kMaxParameters = 5602;
// restore_parameters reads a line with fgets into 256 bytes: a longer line is read in pieces,
// each then taken as a line of its own.
constexpr std::size_t kMaxLineChars = 254;

struct Parameter {
  long number = 0;
  double value = 0.0;
};

// What LinuxCNC reads from a line: sscanf("%d %lf") in the C locale, as FORCE_LC_NUMERIC_C
// makes it.
std::optional<Parameter> linuxcnc_reading(const std::string& line) {
  static const locale_t c_locale = ::newlocale(LC_ALL_MASK, "C", nullptr);
  const locale_t previous = ::uselocale(c_locale);
  int number = 0;
  double value = 0.0;
  const int matched = std::sscanf(line.c_str(), "%d %lf", &number, &value);
  ::uselocale(previous);
  if (matched != 2) return std::nullopt;
  return Parameter{number, value};
}

// The line's first `count` words, split at white space as sscanf splits them.
std::vector<std::string> first_words(const std::string& line, std::size_t count) {
  std::vector<std::string> words;
  std::size_t pos = 0;
  auto space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  while (pos < line.size() && words.size() < count) {
    while (pos < line.size() && space(line[pos])) ++pos;
    const std::size_t start = pos;
    while (pos < line.size() && !space(line[pos])) ++pos;
    if (pos > start) words.push_back(line.substr(start, pos - start));
  }
  return words;
}

// What the line says to a reader: a whole number and a number, as its first two words.
std::optional<Parameter> plain_reading(const std::string& line) {
  const std::vector<std::string> words = first_words(line, 2);
  if (words.size() < 2) return std::nullopt;
  const std::string& n = words[0];
  const std::size_t sign = n[0] == '+' || n[0] == '-' ? 1 : 0;
  if (n.size() == sign || n.size() - sign > 9) return std::nullopt;
  for (std::size_t i = sign; i < n.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(n[i]))) return std::nullopt;
  const auto value = parse_finite(words[1]);
  if (!value) return std::nullopt;
  return Parameter{std::stol(n), *value};
}

// The line's parameter, when it sets one; ParseError when LinuxCNC would read it otherwise
// than it reads.
std::optional<Parameter> read_line(const std::string& line, const std::string& path,
                                   std::size_t line_no) {
  auto refuse = [&](const std::string& why) { throw ParseError(path, line_no, why); };
  if (line.size() > kMaxLineChars) {
    refuse(
        fmt::format("a line of {} characters: LinuxCNC reads lines of up to {} characters "
                    "and takes the rest as a line of its own",
                    line.size(), kMaxLineChars));
  }
  if (line.find('\0') != std::string::npos) refuse("a NUL byte, where LinuxCNC's line ends");
  const auto theirs = linuxcnc_reading(line);
  const auto plain = plain_reading(line);
  if (theirs && !std::isfinite(theirs->value)) {
    const std::vector<std::string> words = first_words(line, 2);
    refuse(fmt::format("#{}: '{}' is not a finite number", theirs->number,
                       words.size() == 2 ? words[1] : line));
  }
  if (!theirs && !plain) return std::nullopt;
  if (theirs && plain && theirs->number == plain->number && theirs->value == plain->value) {
    return theirs;
  }
  const std::string shown = line.size() > 60 ? line.substr(0, 60) + "..." : line;
  if (!theirs) {
    refuse(
        fmt::format("'{}': LinuxCNC skips this line (it reads \"%d %lf\": a whole number, "
                    "then a number)",
                    shown));
  }
  refuse(
      fmt::format("'{}' is #{} = {} to LinuxCNC (it reads \"%d %lf\": a whole number, then "
                  "a number, and ignores the rest); write the line as NUMBER VALUE",
                  shown, theirs->number, theirs->value));
  return std::nullopt;
}

}  // namespace

int work_offset_index(std::string_view code) {
  static constexpr std::string_view kCodes[] = {"G54", "G55",   "G56",   "G57",  "G58",
                                                "G59", "G59.1", "G59.2", "G59.3"};
  for (int i = 0; i < 9; ++i)
    if (code == kCodes[i]) return i + 1;
  return 0;
}

WorkOffsets parse_work_offsets(const std::string& text, const std::string& path, double mm_per_unit,
                               G92Persistence g92) {
  WorkOffsets w;
  w.path = path;
  std::map<long, double> values;
  long previous = 0;
  std::size_t line_no = 0;
  for (std::size_t begin = 0; begin < text.size();) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(begin, end - begin);
    begin = end + 1;
    ++line_no;
    const auto parameter = read_line(line, path, line_no);
    if (!parameter) continue;
    const long number = parameter->number;
    if (number <= 0 || number >= kMaxParameters) {
      throw ParseError(path, line_no,
                       fmt::format("#{}: LinuxCNC refuses a parameter number outside 1..{}", number,
                                   kMaxParameters - 1));
    }
    if (number <= previous) {
      throw ParseError(path, line_no,
                       fmt::format("#{} after #{}: LinuxCNC refuses a parameter file whose "
                                   "numbers are not increasing",
                                   number, previous));
    }
    previous = number;
    values[number] = parameter->value;
  }
  auto at = [&values](long n) {
    const auto it = values.find(n);
    return it == values.end() ? 0.0 : it->second;
  };
  for (int n = 1; n <= 9; ++n) {
    for (int i = 0; i < 3; ++i) w.origin_mm[n][i] = at(5201 + 20 * n + i) * mm_per_unit;
    w.rotation_deg[n] = at(5210 + 20 * n);
  }
  // LinuxCNC: origin_index = (int) (#5220 + 0.0001), 1 when outside 1..9.
  const double selected = at(5220) + 0.0001;
  w.selected = selected >= 1.0 && selected < 10.0 ? static_cast<int>(selected) : 1;
  if (g92 == G92Persistence::kept) {
    w.g92_applied = at(5210) != 0.0;
    for (int i = 0; i < 3; ++i) w.g92_mm[i] = at(5211 + i) * mm_per_unit;
  }
  return w;
}

std::optional<WorkOffsets> read_work_offsets(const std::string& path, double mm_per_unit,
                                             G92Persistence g92) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    // LinuxCNC: "it's OK if the parameter file doesn't exist yet".
    if (errno == ENOENT) return std::nullopt;
    throw IoError(path, std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    throw IoError(
        path, fmt::format("is {}, expected a regular parameter file", file_kind_name(st.st_mode)));
  }
  return parse_work_offsets(read_file(path), path, mm_per_unit, g92);
}

}  // namespace circtest
