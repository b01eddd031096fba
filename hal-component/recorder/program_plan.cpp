// circlog-record --program: the program's header read as circgen writes it (its keys for the
// trace's metadata, the runs it announces and the operator's pauses before them).
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "recorder.hpp"

namespace circtest::circlog_record {

std::vector<std::string> split_on(const std::string& text, char separator) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(text);
  while (std::getline(in, item, separator)) out.push_back(item);
  if (!text.empty() && text.back() == separator) out.emplace_back();
  return out;
}

namespace {

// circgen's header keys: lowercase snake case. Prose comments such as "(Note: ...)" or
// "(Mode: G17)" are left out.
bool valid_header_key(const std::string& key) {
  if (key.empty() || !std::islower(static_cast<unsigned char>(key[0]))) return false;
  return std::all_of(key.begin(), key.end(), [](char c) {
    return std::islower(static_cast<unsigned char>(c)) ||
           std::isdigit(static_cast<unsigned char>(c)) || c == '_' || c == '.';
  });
}

struct HeaderLine {
  std::string key;
  std::string value;
  std::size_t line = 0;
};

// A header is a few dozen short comment lines, and LinuxCNC reads lines of at most 256
// characters: past these limits the file is not a program (a device such as /dev/zero, or
// endless blank lines, would otherwise be read without end).
constexpr std::size_t kMaxLineBytes = 4096;
constexpr std::size_t kMaxHeaderLines = 10000;

// The bytes of a program opened through core (a regular file only: a FIFO would wait for a
// writer), one at a time from a buffer.
class ProgramBytes {
 public:
  explicit ProgramBytes(const std::string& path) : in_(path) {}
  // The next byte, or EOF at the end of the file.
  int get() {
    if (next_ == end_) {
      ssize_t n = 0;
      do {
        n = ::read(in_.fd(), buffer_.data(), buffer_.size());
      } while (n < 0 && errno == EINTR);
      if (n < 0) throw IoError(in_.path(), std::string("read failed: ") + std::strerror(errno));
      if (n == 0) return EOF;
      next_ = 0;
      end_ = static_cast<std::size_t>(n);
    }
    return static_cast<unsigned char>(buffer_[next_++]);
  }

 private:
  InputFile in_;
  std::array<char, 1 << 16> buffer_{};
  std::size_t next_ = 0;
  std::size_t end_ = 0;
};

// One line without its '\n'; false at the end of the input.
bool read_line(ProgramBytes& in, std::string& line, const std::string& path, std::size_t line_no) {
  line.clear();
  for (int c = in.get(); c != EOF; c = in.get()) {
    if (c == '\n') return true;
    if (line.size() == kMaxLineBytes) {
      throw ParseError(
          path, line_no,
          fmt::format("a line longer than {} bytes: not a G-code program", kMaxLineBytes));
    }
    line.push_back(static_cast<char>(c));
  }
  return !line.empty();
}

std::vector<HeaderLine> read_header_lines(const std::string& path) {
  ProgramBytes in(path);
  std::vector<HeaderLine> out;
  std::string line;
  std::size_t line_no = 0;
  while (read_line(in, line, path, line_no + 1)) {
    if (++line_no > kMaxHeaderLines) {
      throw ParseError(path, line_no,
                       fmt::format("more than {} lines before the first line of code: not a "
                                   "G-code program header",
                                   kMaxHeaderLines));
    }
    const std::string s(trim(line));
    if (s.empty() || s == "%") continue;
    if (s.front() != '(' || s.back() != ')') break;  // the first line of code ends the header
    const std::string inner = s.substr(1, s.size() - 2);
    const auto colon = inner.find(':');
    if (colon == std::string::npos) continue;
    std::string key(trim(inner.substr(0, colon)));
    std::string value(trim(inner.substr(colon + 1)));
    // circgen writes "(circtest: key: value)": the prefix marks its lines, the key follows.
    if (key == "circtest") {
      const auto second = value.find(':');
      if (second == std::string::npos) continue;
      key = std::string(trim(value.substr(0, second)));
      value = std::string(trim(value.substr(second + 1)));
    }
    if (!valid_header_key(key)) continue;
    out.push_back({std::move(key), std::move(value), line_no});
  }
  return out;
}

const HeaderLine* find_line(const std::vector<HeaderLine>& lines, std::string_view key) {
  for (const HeaderLine& l : lines)
    if (l.key == key) return &l;
  return nullptr;
}

// "1:CCW:F500,2:CW:F500": each run's segment id, direction and feed word, in program order.
std::vector<AnnouncedRun> parse_segments(const std::string& path, const HeaderLine& line) {
  std::vector<AnnouncedRun> runs;
  std::set<int> ids;
  // An empty value announces nothing, which a program that writes the key never means.
  const std::vector<std::string> items =
      line.value.empty() ? std::vector<std::string>{""} : split_on(line.value, ',');
  for (const std::string& item : items) {
    const std::vector<std::string> parts = split_on(std::string(trim(item)), ':');
    int id = 0;
    const std::string id_text = parts.empty() ? std::string() : parts[0];
    const auto [end, ec] = std::from_chars(id_text.data(), id_text.data() + id_text.size(), id);
    // Three fields (id:DIR:Ffeed), or four with the plane (id:DIR:Ffeed:PLANE), as circgen writes.
    const bool fields = parts.size() == 3 || (parts.size() == 4 && parse_plane(parts[3]));
    const auto direction = fields ? parse_direction(parts[1]) : std::nullopt;
    const double feed = fields && parts[2].size() > 1 && parts[2][0] == 'F'
                            ? parse_finite(parts[2].substr(1)).value_or(0.0)
                            : 0.0;
    const bool ok = fields && ec == std::errc() && end == id_text.data() + id_text.size() &&
                    id > 0 && direction && feed > 0.0;
    if (!ok) {
      throw ParseError(path, line.line,
                       fmt::format("segments: '{}' is not ID:DIRECTION:FFEED[:PLANE] (e.g. "
                                   "1:CCW:F500:XY, ID a whole number from 1)",
                                   std::string(trim(item))));
    }
    if (!ids.insert(id).second) {
      throw ParseError(path, line.line,
                       fmt::format("segments: run {} is announced twice: the recorder could not "
                                   "tell the runs apart",
                                   id));
    }
    // circgen's entries name their plane.
    const std::optional<Plane> plane = parts.size() == 4 ? parse_plane(parts[3]) : std::nullopt;
    runs.push_back({id, *direction, feed, fmt::format("{} {}", parts[1], parts[2]), plane});
  }
  // A test set's runs (more than one plane) say their plane where the recorder names them.
  const bool set = std::any_of(runs.begin(), runs.end(), [&](const AnnouncedRun& r) {
    return r.plane != runs.front().plane;
  });
  if (set) {
    for (AnnouncedRun& r : runs) {
      if (r.plane) r.label += fmt::format(" {}", plane_name(*r.plane));
    }
  }
  return runs;
}

// The header's number for `key`, if it has one.
std::optional<double> header_number(const std::vector<HeaderLine>& lines, std::string_view key) {
  const HeaderLine* l = find_line(lines, key);
  if (!l) return std::nullopt;
  const auto v = parse_finite(l->value);
  if (!v || *v < 0.0) return std::nullopt;
  return v;
}

// circgen's moves between the end of one measured arc and the start of the next
// (docs/circgen.md "Program layout"): the lead-out at the first run's feed, a ballbar's
// feed-out and feed-in at the approach feed, the way back over the circle at the next run's
// feed when both runs turn the same way, the dwell where the direction reverses, and the
// lead-in. nullopt when the header lacks a number it needs.
std::optional<double> longest_pause_s(const std::vector<HeaderLine>& lines,
                                      const std::vector<AnnouncedRun>& runs) {
  if (runs.size() < 2) return 0.0;
  const auto radius = header_number(lines, meta_key::radius_mm);
  const auto lead = header_number(lines, meta_key::lead_deg);
  const auto arc = header_number(lines, meta_key::arc_deg);
  const HeaderLine* units = find_line(lines, meta_key::units);
  if (!radius || !lead || !arc || !units) return std::nullopt;
  const double mm_per_unit = units->value == "inch" ? 25.4 : 1.0;
  const HeaderLine* profile = find_line(lines, "instrument_profile");
  const bool ballbar = profile && profile->value == "ballbar";
  const double feed_in_mm = ballbar ? header_number(lines, "feed_in_mm").value_or(0.0) : 0.0;
  const double approach = header_number(lines, "approach_feed_mm_per_min").value_or(0.0);
  if (ballbar && !(approach > 0.0)) return std::nullopt;
  const double dwell_s = header_number(lines, meta_key::dwell_s).value_or(0.0);
  const double lead_mm = 2.0 * std::numbers::pi * *radius * *lead / 360.0;
  double gap_deg = std::fmod(*arc + 2.0 * *lead, 360.0);
  if (gap_deg > 360.0 - 1e-9) gap_deg = 0.0;
  const double back_mm = 2.0 * std::numbers::pi * (*radius + feed_in_mm) * gap_deg / 360.0;
  double longest = 0.0;
  for (std::size_t i = 1; i < runs.size(); ++i) {
    // Between a set's planes the program pauses for the operator: no planned length.
    if (runs[i - 1].plane != runs[i].plane) continue;
    const double from = runs[i - 1].feed_per_min * mm_per_unit / 60.0;
    const double to = runs[i].feed_per_min * mm_per_unit / 60.0;
    const bool same_way = runs[i - 1].direction == runs[i].direction;
    double t = lead_mm / from + lead_mm / to;
    if (ballbar) t += 2.0 * feed_in_mm / (approach / 60.0);
    t += same_way ? back_mm / to : dwell_s;
    longest = std::max(longest, t);
  }
  return longest;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> read_program_header(const std::string& path) {
  std::vector<std::pair<std::string, std::string>> out;
  for (HeaderLine& l : read_header_lines(path)) out.emplace_back(std::move(l.key), l.value);
  return out;
}

ProgramPlan read_program_plan(const std::string& path) {
  const std::vector<HeaderLine> lines = read_header_lines(path);
  ProgramPlan plan;
  for (const HeaderLine& l : lines) plan.header.emplace_back(l.key, l.value);
  if (const HeaderLine* segments = find_line(lines, meta_key::segments)) {
    plan.runs = parse_segments(path, *segments);
    plan.longest_pause_s = longest_pause_s(lines, plan.runs);
  }
  return plan;
}

double run_wait_s(const RecordRequest& options) {
  if (options.run_wait_s) return *options.run_wait_s;
  if (options.program_plan.longest_pause_s) {
    return 2.0 * *options.program_plan.longest_pause_s + 10.0;
  }
  return kDefaultRunWait_s;
}

bool operator_pause_before(const ProgramPlan& plan, std::size_t k) {
  return k > 0 && k < plan.runs.size() && plan.runs[k].plane != plan.runs[k - 1].plane;
}

double run_wait_s(const RecordRequest& options, std::size_t k) {
  if (!operator_pause_before(options.program_plan, k)) return run_wait_s(options);
  return options.run_wait_s.value_or(kMaxWait_s);
}

}  // namespace circtest::circlog_record
