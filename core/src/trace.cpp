#include "circtest/core/trace.hpp"

#include <fast_float/fast_float.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iterator>
#include <memory>
#include <string>
#include <system_error>
#include <unordered_set>

#include <boost/iterator/counting_iterator.hpp>
#include <boost/iterator/transform_iterator.hpp>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/memory.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/parallel.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "input_lines.hpp"

namespace circtest {

// ---------------------------------------------------------------- metadata

void TraceMetadata::set(std::string key, std::string value) {
  last_.insert_or_assign(key, entries_.size());
  entries_.emplace_back(std::move(key), std::move(value));
  lines_.push_back(0);
}

void TraceMetadata::set_line(std::size_t index, std::size_t line) {
  if (index < lines_.size()) lines_[index] = line;
}

std::optional<std::size_t> TraceMetadata::last_index(std::string_view key) const {
  const auto it = last_.find(key);
  if (it == last_.end()) return std::nullopt;
  return it->second;
}

const std::string* TraceMetadata::find(std::string_view key) const {
  const auto i = last_index(key);
  return i ? &entries_[*i].second : nullptr;
}

std::size_t TraceMetadata::line_of(std::string_view key) const {
  const auto i = last_index(key);
  return i ? lines_[*i] : 0;
}

std::vector<std::size_t> TraceMetadata::distinct() const {
  std::vector<std::size_t> out;
  out.reserve(last_.size());
  // Each key at its first entry, as its last entry's index; marked there, so that the key's
  // later entries are passed over.
  std::vector<char> listed(entries_.size(), 0);
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    const std::size_t last = last_.find(entries_[i].first)->second;
    if (listed[last]) continue;
    listed[last] = 1;
    out.push_back(last);
  }
  return out;
}

namespace {

std::string shorten(std::string_view s) {
  if (s.size() > 40) return std::string(s.substr(0, 37)) + "...";
  return std::string(s);
}

}  // namespace

std::optional<double> TraceMetadata::number(std::string_view key, const std::string& source) const {
  const std::string* v = find(key);
  if (!v) return std::nullopt;
  const auto out = parse_finite(*v);
  if (!out) {
    throw ParseError(
        source, line_of(key),
        fmt::format("metadata '{}': expected a finite number, got '{}'", key, shorten(*v)));
  }
  return out;
}

// ---------------------------------------------------------------- trace

std::optional<std::size_t> Trace::column_index(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return i;
  }
  return std::nullopt;
}

const std::vector<double>* Trace::column(std::string_view name) const {
  const auto i = column_index(name);
  return i ? &values[*i] : nullptr;
}

// ---------------------------------------------------------------- reader

namespace {

constexpr char kBom[] = "\xEF\xBB\xBF";

bool blank(char c) {
  return c == ' ' || c == '\t';
}

// Whether a line where the header row belongs is a line of a G-code program (what circgen
// writes, or any RS274 text): `%`, a `(comment)` or `; comment` line, or words of a letter
// and a number (`N10 G1 X5 F300`, comments allowed) with at least one G, M or N word, or an
// O-code (`o100 sub`). A header row is column names separated by commas, none of which reads
// like that.
bool gcode_line(std::string_view text) {
  const std::string_view t = trim(text);
  if (t.empty()) return false;
  if (t.front() == '%' || t.front() == ';' || (t.front() == '(' && t.back() == ')')) return true;
  bool program_word = false;
  std::size_t i = 0;
  while (i < t.size()) {
    const char c = t[i];
    if (blank(c)) {
      ++i;
    } else if (c == '(') {
      const auto close = t.find(')', i);
      if (close == std::string_view::npos) return false;
      i = close + 1;
    } else if (c == ';') {
      break;
    } else if (std::isalpha(static_cast<unsigned char>(c))) {
      const char letter = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      ++i;
      while (i < t.size() && blank(t[i])) ++i;
      // An O-code (`o100 sub`, `o<probe> call`): a keyword follows the number or name.
      if (letter == 'O' && i < t.size() &&
          (t[i] == '<' || std::isdigit(static_cast<unsigned char>(t[i])))) {
        return true;
      }
      if (i < t.size() && (t[i] == '-' || t[i] == '+')) ++i;
      bool digits = false;
      for (; i < t.size() && (std::isdigit(static_cast<unsigned char>(t[i])) || t[i] == '.'); ++i) {
        digits = digits || t[i] != '.';
      }
      if (!digits) return false;
      program_word = program_word || letter == 'G' || letter == 'M' || letter == 'N';
    } else {
      return false;
    }
  }
  return program_word;
}

class TraceParser {
 public:
  TraceParser(std::string source, const TraceReadOptions& options) : options_(options) {
    trace_.source = std::move(source);
  }

  // Where a stretch's rows go when stretches are parsed side by side: rows [0, capacity) of
  // pointers into columns made for the whole file (column k of the trace at columns[k]), and
  // its lines numbered from line_base (the lines before the stretch).
  struct Slots {
    std::vector<double*> columns;
    std::uint32_t* lines = nullptr;
    std::size_t capacity = 0;
    std::size_t line_base = 0;
  };

  // A parser for a stretch of the rows: the same header, rows written into `slots`.
  TraceParser fork(Slots slots) const {
    TraceParser p(trace_.source, options_);
    p.trace_.columns = trace_.columns;
    p.trace_.values.assign(trace_.values.size(), {});
    p.trace_.header_line = trace_.header_line;
    p.have_header_ = have_header_;
    p.field_count_ = field_count_;
    p.target_ = target_;
    p.header_names_ = header_names_;
    p.time_column_ = time_column_;
    p.time_field_ = time_field_;
    p.row_values_.assign(field_count_, 0.0);
    p.first_line_ = false;
    p.slots_ = std::move(slots);
    p.in_slots_ = true;
    return p;
  }

  void reserve_rows(std::size_t n) {
    reserve_hint_ = n;
    if (!have_header_) return;
    for (auto& v : trace_.values) reserve_huge(v, n);
    reserve_huge(trace_.line_of_row, n);
  }
  std::size_t lines() const { return line_no_; }

  void line(std::string_view text) {
    ++line_no_;
    if (text.size() > kMaxInputLineBytes) fail(detail::line_too_long_message());
    if (first_line_) {
      first_line_ = false;
      if (text.substr(0, 3) == kBom) text.remove_prefix(3);  // a BOM some editors write
    }
    if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
    if (have_header_ && !metadata_only_) {
      // Rows are most lines: test for them before trimming.
      const char c0 = text.empty() ? '\0' : text.front();
      if (c0 != '#' && c0 != ' ' && c0 != '\t' && c0 != '\0') {
        row(text);
        return;
      }
    }
    const std::string_view t = trim(text);
    if (t.empty()) return;
    if (t.front() == '#') {
      metadata(t.substr(1));
      return;
    }
    if (!have_header_) {
      header(text);
      return;
    }
    if (metadata_only_) {
      throw ParseError(trace_.source, 0,
                       fmt::format("{}, line {}: expected only '# key: value' lines after the "
                                   "header row, got '{}'",
                                   metadata_only_, line_no_, shorten(t)));
    }
    row(text);
  }

  // Binary header and trailer text hold metadata and the header row, never rows.
  void metadata_only(const char* where) {
    metadata_only_ = where;
    line_no_ = 0;  // each text counts its own lines
  }

  // Takes the metadata lines and the line count of a stretch parsed by a fork(); its rows are
  // already in the columns (the caller sizes them).
  void absorb(const TraceParser& stretch) {
    const std::size_t offset = line_no_;
    const auto& entries = stretch.trace_.metadata.entries();
    for (std::size_t i = 0; i < entries.size(); ++i) {
      trace_.metadata.set(entries[i].first, entries[i].second);
      trace_.metadata.set_line(trace_.metadata.entries().size() - 1,
                               stretch.trace_.metadata.line_at(i) + offset);
    }
    line_no_ += stretch.line_no_;
  }

  Trace finish() {
    if (!have_header_) {
      throw ParseError(trace_.source, line_no_ == 0 ? 1 : line_no_,
                       line_no_ == 0 ? "empty file: expected a header row of column names"
                                     : "no header row: expected a line of column names");
    }
    check_metadata(trace_.metadata, trace_.source);
    return std::move(trace_);
  }

  std::size_t rows() const { return in_slots_ ? slot_rows_ : trace_.line_of_row.size(); }

 private:
  [[noreturn]] void fail(const std::string& message) const {
    if (binary_) throw ParseError(trace_.source, 0, record_prefix() + message);
    throw ParseError(trace_.source, line_no_, message);
  }

  void metadata(std::string_view body) {
    const auto colon = body.find(':');
    if (colon == std::string_view::npos) return;  // a plain comment
    const std::string_view key = trim(body.substr(0, colon));
    if (key.empty()) return;
    trace_.metadata.set(std::string(key), std::string(trim(body.substr(colon + 1))));
    trace_.metadata.set_line(trace_.metadata.entries().size() - 1, line_no_);
  }

  // Splits one line into fields, honouring double quotes ("a,b" and "" inside quotes).
  void split_quoted(std::string_view text, std::vector<std::string>& out) const {
    out.clear();
    std::size_t i = 0;
    const std::size_t n = text.size();
    while (true) {
      std::string field;
      while (i < n && blank(text[i])) ++i;
      if (i < n && text[i] == '"') {
        ++i;
        bool closed = false;
        while (i < n) {
          if (text[i] == '"') {
            if (i + 1 < n && text[i + 1] == '"') {
              field += '"';
              i += 2;
              continue;
            }
            closed = true;
            ++i;
            break;
          }
          field += text[i++];
        }
        if (!closed)
          fail(fmt::format("field {}: unterminated quoted field: expected a closing '\"'",
                           out.size() + 1));
        while (i < n && blank(text[i])) ++i;
        if (i < n && text[i] != ',') {
          fail(fmt::format("field {}: expected ',' after a closing quote, got '{}'", out.size() + 1,
                           text[i]));
        }
      } else {
        const std::size_t start = i;
        while (i < n && text[i] != ',') {
          if (text[i] == '"') {
            fail(fmt::format("field {}: unexpected '\"' inside an unquoted field", out.size() + 1));
          }
          ++i;
        }
        field = std::string(trim(text.substr(start, i - start)));
      }
      out.push_back(std::move(field));
      if (i >= n) break;
      ++i;  // the comma
    }
  }

  void header(std::string_view text) {
    if (gcode_line(text)) {
      fail(
          fmt::format("this is a G-code program, not a trace: run it and record with "
                      "circlog-record (docs/circlog.md); got '{}'",
                      shorten(trim(text))));
    }
    std::vector<std::string> names;
    split_quoted(text, names);
    const std::size_t n = names.size();
    target_.assign(n, -1);
    // Linear in the number of names: a header of 200,000 names is read in milliseconds.
    std::unordered_set<std::string_view> seen;
    seen.reserve(n);
    // The columns to keep may depend on the metadata above the header (the plane).
    const std::vector<std::string> chosen =
        options_.keep_for ? options_.keep_for(trace_.metadata) : options_.keep;
    std::unordered_set<std::string_view> keep(chosen.begin(), chosen.end());
    for (std::size_t i = 0; i < n; ++i) {
      if (names[i].empty()) fail(fmt::format("header: column {} has no name", i + 1));
      if (!seen.insert(names[i]).second) {
        fail(fmt::format("header: duplicate column '{}'", names[i]));
      }
      if (chosen.empty() || keep.count(names[i])) {
        target_[i] = static_cast<int>(trace_.columns.size());
        trace_.columns.push_back(names[i]);
      }
    }
    for (const std::string& req : options_.required) {
      if (!seen.count(req)) {
        fail(fmt::format("missing column '{}': expected it in the header (found: {})", req,
                         fmt::join(names, ",")));
      }
    }
    field_count_ = n;
    header_names_ = std::move(names);
    trace_.values.assign(trace_.columns.size(), {});
    trace_.header_line = line_no_;
    have_header_ = true;
    if (reserve_hint_ > 0) reserve_rows(reserve_hint_);
    time_column_ =
        options_.check_time_monotonic ? trace_.column_index(column_name::t) : std::nullopt;
    time_field_.reset();
    for (std::size_t i = 0; i < n; ++i) {
      if (time_column_ && target_[i] == static_cast<int>(*time_column_)) time_field_ = i;
    }
    row_values_.assign(n, 0.0);
  }

  // The common row: unquoted finite numbers. Any doubt (a quote, a field that is not a plain
  // number, a wrong count, time going back) goes to row_checked(), which parses the line again
  // field by field and reports the first problem exactly as it always has.
  void row(std::string_view text) {
    const char* p = text.data();
    const char* const end = p + text.size();
    // No scan for quotes up front: a quote fails the number parse or stops the skip of an
    // unkept field, and either sends the line to row_checked().
    const std::size_t last = field_count_ - 1;
    for (std::size_t f = 0; f <= last; ++f) {
      if (target_[f] < 0) {
        while (p < end && *p != ',' && *p != '"') ++p;
        if (p < end && *p == '"') return row_checked(text);
        if ((p == end) != (f == last)) return row_checked(text);
        if (p < end) ++p;
        continue;
      }
      while (p < end && blank(*p)) ++p;
      if (p < end && *p == '+') ++p;
      double v = 0.0;
      const auto r = fast_float::from_chars(p, end, v);
      if (r.ec != std::errc() || !std::isfinite(v)) return row_checked(text);
      p = r.ptr;
      while (p < end && (blank(*p) || *p == '\r')) ++p;
      if (f < last) {
        if (p == end || *p != ',') return row_checked(text);
        ++p;
      } else if (p != end) {
        return row_checked(text);
      }
      row_values_[f] = v;
    }
    if (time_field_) {
      const double* t = last_value(*time_column_);
      if (t && row_values_[*time_field_] < *t) return row_checked(text);
    }
    begin_row();
    for (std::size_t f = 0; f <= last; ++f) {
      if (target_[f] >= 0) put(static_cast<std::size_t>(target_[f]), row_values_[f]);
    }
    end_row(line_no_);
  }

  // A row's values go to the trace's columns, or to the slots of a stretch parsed in place.
  void begin_row() const {
    // Rows never outnumber the stretch's lines, which set its capacity.
    if (in_slots_ && slot_rows_ >= slots_.capacity) {
      throw Error(ExitCode::internal, trace_.source + ": more rows than lines in a stretch");
    }
  }
  void put(std::size_t column, double v) {
    if (in_slots_) {
      slots_.columns[column][slot_rows_] = v;
    } else {
      trace_.values[column].push_back(v);
    }
  }
  void end_row(std::size_t line) {
    if (in_slots_) {
      slots_.lines[slot_rows_++] = static_cast<std::uint32_t>(line + slots_.line_base);
    } else {
      trace_.line_of_row.push_back(static_cast<std::uint32_t>(line));
    }
  }
  // The column's value in the last complete row; none before the first.
  const double* last_value(std::size_t column) const {
    if (in_slots_) return slot_rows_ ? &slots_.columns[column][slot_rows_ - 1] : nullptr;
    const auto& v = trace_.values[column];
    return v.empty() ? nullptr : &v.back();
  }

  void row_checked(std::string_view text) {
    begin_row();
    const char* p = text.data();
    const char* end = p + text.size();
    std::size_t field = 0;
    bool quoted_line = std::memchr(p, '"', text.size()) != nullptr;
    if (quoted_line) {
      split_quoted(text, scratch_);
      if (scratch_.size() != field_count_) wrong_count(scratch_.size());
      for (std::size_t i = 0; i < field_count_; ++i) {
        if (target_[i] >= 0) store(i, scratch_[i]);
      }
    } else {
      while (true) {
        const char* comma = static_cast<const char*>(std::memchr(p, ',', end - p));
        const char* fend = comma ? comma : end;
        if (field >= field_count_) wrong_count(count_fields(text));
        if (target_[field] >= 0) store(field, std::string_view(p, fend - p));
        ++field;
        if (!comma) break;
        p = comma + 1;
      }
      if (field != field_count_) wrong_count(field);
    }
    end_row(line_no_);
  }

  static std::size_t count_fields(std::string_view text) {
    return static_cast<std::size_t>(std::count(text.begin(), text.end(), ',')) + 1;
  }

  [[noreturn]] void wrong_count(std::size_t got) const {
    fail(fmt::format("expected {} fields as in the header (line {}), got {}", field_count_,
                     trace_.header_line, got));
  }

  void store(std::size_t field, std::string_view text) {
    const auto v = parse_number(text);
    if (!v) {
      fail(fmt::format("column '{}': expected a number, got '{}'", header_names_[field],
                       shorten(trim(text))));
    }
    store_value(field, *v, text);
  }

  void store_value(std::size_t field, double v, std::string_view text) {
    if (!std::isfinite(v)) {
      fail(fmt::format("column '{}': expected a finite number, got '{}'", header_names_[field],
                       text.empty() ? fmt::format("{}", v) : shorten(trim(text))));
    }
    const auto col = static_cast<std::size_t>(target_[field]);
    if (col == time_column_) {
      const double* before = last_value(col);
      if (before && v < *before) {
        throw DataError(trace_.source, binary_ ? 0 : line_no_,
                        fmt::format("{}time goes backwards: t = {} after t = {}; expected "
                                    "non-decreasing time",
                                    record_prefix(), v, *before));
      }
    }
    put(col, v);
  }

 public:
  // Binary rows (docs/trace-format.md), checked value by value: record numbers stand in for
  // line numbers. The reference for what read_binary_rows() accepts.
  void binary_rows(const double* values, std::size_t rows, std::size_t first_record) {
    binary_ = true;
    for (std::size_t r = 0; r < rows; ++r) {
      record_ = first_record + r;
      const double* row = values + r * field_count_;
      for (std::size_t i = 0; i < field_count_; ++i) {
        if (target_[i] >= 0) store_value(i, row[i], {});
      }
      end_row(record_);
    }
  }
  Trace& trace() { return trace_; }
  const std::vector<int>& targets() const { return target_; }
  std::optional<std::size_t> time_column() const { return time_column_; }
  std::size_t field_count() const { return field_count_; }
  bool has_header() const { return have_header_; }
  void end_binary_rows() { binary_ = false; }

 private:
  std::string record_prefix() const {
    return binary_ ? fmt::format("record {}: ", record_) : std::string();
  }

  const TraceReadOptions& options_;
  Trace trace_;
  std::size_t line_no_ = 0;
  bool first_line_ = true;
  bool have_header_ = false;
  const char* metadata_only_ = nullptr;
  std::size_t field_count_ = 0;
  std::vector<int> target_;
  std::vector<std::string> header_names_;
  std::vector<std::string> scratch_;
  std::vector<double> row_values_;
  std::optional<std::size_t> time_column_;  // the `t` column when time must not go back
  std::optional<std::size_t> time_field_;   // its field in the header
  std::size_t reserve_hint_ = 0;
  bool binary_ = false;
  std::size_t record_ = 0;
  Slots slots_;  // with in_slots_: a stretch parsed in place (fork())
  bool in_slots_ = false;
  std::size_t slot_rows_ = 0;
};

constexpr char kBinaryMagic[8] = {'C', 'T', 'R', 'A', 'C', 'E', 'B', '1'};
constexpr char kBinaryEnd[4] = {'C', 'T', 'B', 'E'};
constexpr std::size_t kFooterBytes = 8 + 4 + 4;  // rows (u64), trailer bytes (u32), end magic

static_assert(std::endian::native == std::endian::little,
              "the binary trace is little-endian; add byte swapping for this host");

// Feeds the lines of `text` to the parser.
void feed_text(TraceParser& parser, std::string_view text) {
  const char* data = text.data();
  const std::size_t n = text.size();
  std::size_t pos = 0;
  while (pos < n) {
    const void* nl = std::memchr(data + pos, '\n', n - pos);
    const std::size_t stop = nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - data) : n;
    parser.line(std::string_view(data + pos, stop - pos));
    pos = stop + 1;
  }
}

std::size_t estimate_rows(std::string_view data) {
  const std::string_view sample = data.substr(0, std::size_t{1} << 16);
  const auto lines = static_cast<std::size_t>(std::count(sample.begin(), sample.end(), '\n'));
  if (lines == 0 || sample.empty()) return 0;
  const double per_line = static_cast<double>(sample.size()) / static_cast<double>(lines);
  return static_cast<std::size_t>(static_cast<double>(data.size()) / per_line * 1.02) + 16;
}

unsigned worker_count(const TraceReadOptions& options, std::size_t bytes) {
  ThreadCountRequest request;
  request.asked = options.threads;
  request.work = bytes;
  request.min_work = options.parallel_min_bytes;
  request.asked_within_cores = false;  // tests ask for more stretches than cores
  // One per idle core: on a machine already busy, threads only fight over the cores (measured:
  // twice the CPU time for no gain at a load of 4 per core).
  request.idle_cores_only = true;
  return thread_count(request);
}

// Threads for a text trace of `bytes` in memory: stretches only when two or more are asked for
// (nothing in circtest reads a large text from memory).
unsigned text_workers(const TraceReadOptions& options, std::size_t bytes) {
  return options.threads >= 2 ? worker_count(options, bytes) : 1;
}

// The rows of a text in `parts` stretches parsed side by side, after `parser` has read the
// metadata and header: count(k) gives stretch k's lines, feed(k, p) gives its lines to p, and
// sequential() parses the whole text again on one thread. Any error sends the whole text back
// through that one parser, so the message and line are the ones a sequential read gives (the
// first problem in file order).
template <class Count, class Feed, class Sequential>
Trace parse_stretches(TraceParser& parser, std::size_t parts, unsigned workers, Count&& count,
                      Feed&& feed, Sequential&& sequential) {
  // Each stretch's rows are written in place into columns sized for the whole file: at most a
  // row per line, so the lines are counted first. No copy of the rows afterwards but to close
  // the gaps comment and blank lines leave (round 4's stretches parsed into their own columns
  // and appended them, which made two threads slower than one).
  std::vector<std::size_t> lines(parts);
  std::vector<std::exception_ptr> errors(parts);
  run_tasks(parts, workers, [&](std::size_t k) {
    try {
      lines[k] = count(k);
    } catch (...) {
      errors[k] = std::current_exception();
    }
  });
  for (const auto& e : errors) {
    if (e) return sequential();
  }
  std::vector<std::size_t> first_row(parts + 1, 0);
  for (std::size_t k = 0; k < parts; ++k) first_row[k + 1] = first_row[k] + lines[k];
  const std::size_t room = first_row[parts];
  Trace& trace = parser.trace();
  // The zero fill of each column is its first touch: shared out among the threads too.
  const std::size_t ncols = trace.values.size();
  run_tasks(ncols + 1, workers, [&](std::size_t c) {
    if (c == ncols) {
      trace.line_of_row.resize(room);
    } else {
      trace.values[c].resize(room);
    }
  });
  std::vector<TraceParser> parsers;
  parsers.reserve(parts);
  for (std::size_t k = 0; k < parts; ++k) {
    TraceParser::Slots slots;
    for (auto& column : trace.values) slots.columns.push_back(column.data() + first_row[k]);
    slots.lines = trace.line_of_row.data() + first_row[k];
    slots.capacity = lines[k];
    slots.line_base = parser.lines() + first_row[k];
    parsers.push_back(parser.fork(std::move(slots)));
  }
  run_tasks(parts, workers, [&](std::size_t k) {
    try {
      feed(k, parsers[k]);
    } catch (...) {
      errors[k] = std::current_exception();  // reported by the sequential pass below
    }
  });
  // Any error, or time going back across a seam: again in one pass, which reports the first
  // problem in file order with its line, exactly as one thread does.
  for (const auto& e : errors) {
    if (e) return sequential();
  }
  std::size_t kept = 0;
  const std::optional<std::size_t> time_column = parser.time_column();
  for (std::size_t k = 0; k < parts; ++k) {
    const std::size_t n = parsers[k].rows();
    if (n > 0 && kept > 0 && time_column) {
      const auto& t = trace.values[*time_column];
      if (t[first_row[k]] < t[kept - 1]) return sequential();
    }
    if (kept != first_row[k] && n > 0) {
      for (auto& column : trace.values) {
        std::memmove(column.data() + kept, column.data() + first_row[k], n * sizeof(double));
      }
      std::memmove(trace.line_of_row.data() + kept, trace.line_of_row.data() + first_row[k],
                   n * sizeof(std::uint32_t));
    }
    kept += n;
    parser.absorb(parsers[k]);
  }
  for (auto& column : trace.values) column.resize(kept);
  trace.line_of_row.resize(kept);
  return parser.finish();
}

// Text after the metadata and header, in stretches parsed side by side when the text is
// large.
Trace parse_text(std::string_view text, const std::string& source, const TraceReadOptions& options,
                 unsigned workers) {
  auto sequential = [&] {
    TraceParser p(source, options);
    p.reserve_rows(estimate_rows(text));
    feed_text(p, text);
    return p.finish();
  };
  TraceParser parser(source, options);
  std::size_t pos = 0;
  while (pos < text.size() && !parser.has_header()) {
    const auto nl = text.find('\n', pos);
    const std::size_t stop = nl == std::string_view::npos ? text.size() : nl;
    parser.line(text.substr(pos, stop - pos));
    pos = stop + 1;
  }
  const std::string_view rows = pos < text.size() ? text.substr(pos) : std::string_view();
  if (workers < 2 || !parser.has_header()) {
    parser.reserve_rows(estimate_rows(rows));
    feed_text(parser, rows);
    return parser.finish();
  }
  // Stretches end just after a newline, so each starts at the beginning of a line.
  std::vector<std::size_t> bounds{0};
  for (unsigned k = 1; k < workers; ++k) {
    const std::size_t at = rows.size() / workers * k;
    const auto nl = rows.find('\n', std::max(at, bounds.back()));
    if (nl == std::string_view::npos || nl + 1 >= rows.size()) break;
    if (nl + 1 > bounds.back()) bounds.push_back(nl + 1);
  }
  bounds.push_back(rows.size());
  auto stretch = [&](std::size_t k) { return rows.substr(bounds[k], bounds[k + 1] - bounds[k]); };
  return parse_stretches(
      parser, bounds.size() - 1, workers,
      [&](std::size_t k) {
        const std::string_view part = stretch(k);
        return static_cast<std::size_t>(std::count(part.begin(), part.end(), '\n')) +
               (!part.empty() && part.back() != '\n' ? 1 : 0);
      },
      [&](std::size_t k, TraceParser& p) { feed_text(p, stretch(k)); }, sequential);
}

std::size_t read_exact(int fd, void* dst, std::size_t n, std::uint64_t offset,
                       const std::string& path) {
  auto* p = static_cast<char*>(dst);
  std::size_t got = 0;
  while (got < n) {
    const ssize_t r = ::pread(fd, p + got, n - got, static_cast<off_t>(offset + got));
    if (r < 0) {
      if (errno == EINTR) continue;
      throw IoError(path, std::string("read failed: ") + std::strerror(errno));
    }
    if (r == 0) break;
    got += static_cast<std::size_t>(r);
  }
  return got;
}

// Rows read at once from a binary trace of `width` columns: about 1 MiB, at least one row,
// at most `rows`.
std::size_t binary_block_rows(std::size_t width, std::size_t rows) {
  constexpr std::size_t kBlockBytes = std::size_t{1} << 20;
  const std::size_t fit = kBlockBytes / (std::max<std::size_t>(width, 1) * sizeof(double));
  return std::max<std::size_t>(1, std::min(fit, rows));
}

// Field `field` of rows [0, n) of a block of binary rows `stride` bytes apart, as a
// random-access range: vector::insert() then copies it into reserved room without first
// zeroing the column (resize() wrote every column twice). Values are read with memcpy: rows
// start at any byte offset of the file.
auto field_range(const char* block, std::size_t field, std::size_t stride, std::size_t n) {
  const auto read = [at = block + field * sizeof(double), stride](std::size_t row) {
    double v;
    std::memcpy(&v, at + row * stride, sizeof v);
    return v;
  };
  const boost::counting_iterator<std::size_t> first(0), last(n);
  return std::pair(boost::make_transform_iterator(first, read),
                   boost::make_transform_iterator(last, read));
}

// The rows of a binary trace straight into the columns. The rows are shared out among the
// workers, each reading its own part of the file once in blocks that stay in cache while it
// copies every column out of them (sharing out columns instead made every worker read the
// whole file). False if a value is not finite or time goes back; nothing is reported here
// (see binary_rows()).
bool read_binary_rows(TraceParser& parser, int fd, std::uint64_t rows_at, std::size_t rows,
                      const TraceReadOptions& options, const std::string& path) {
  Trace& trace = parser.trace();
  const std::size_t width = parser.field_count();
  const std::size_t stride = width * sizeof(double);
  const auto& targets = parser.targets();
  std::vector<std::pair<std::size_t, std::size_t>> kept;  // (field, column)
  for (std::size_t f = 0; f < width; ++f) {
    if (targets[f] >= 0) kept.emplace_back(f, static_cast<std::size_t>(targets[f]));
  }
  const std::size_t columns = trace.values.size();
  const auto workers = static_cast<unsigned>(std::clamp<std::size_t>(
      std::min<std::size_t>(worker_count(options, rows * stride), rows / 4096), 1, 64));
  const std::optional<std::size_t> time_column = parser.time_column();
  auto first_row = [&](unsigned w) { return rows / workers * w; };
  std::vector<char> ok(workers, 1);
  // Each column's zero fill is its first touch: shared out too.
  run_tasks(columns + 1, workers, [&](std::size_t c) {
    if (c == columns) {
      trace.line_of_row.resize(rows);
    } else {
      trace.values[c].resize(rows);
    }
  });
  run_tasks(workers, workers, [&](std::size_t task) {
    const auto w = static_cast<unsigned>(task);
    const std::size_t lo = first_row(w), hi = w + 1 == workers ? rows : first_row(w + 1);
    const std::size_t block_rows = binary_block_rows(width, rows) / 4 + 1;  // ~256 KiB
    std::vector<char> block(block_rows * stride);
    bool good = true;
    for (std::size_t r = lo; r < hi; r += block_rows) {
      const std::size_t n = std::min(block_rows, hi - r);
      if (read_exact(fd, block.data(), n * stride, rows_at + r * stride, path) != n * stride) {
        throw IoError(path, "binary trace shrank while being read");
      }
      for (const auto& [f, c] : kept) {
        const auto [from, to] = field_range(block.data(), f, stride, n);
        double* dst = trace.values[c].data() + r;
        std::copy(from, to, dst);
        bool finite = true;
        for (std::size_t i = 0; i < n; ++i) finite &= std::isfinite(dst[i]);
        good &= finite;
      }
      // The record numbers r + 1, r + 2, ...
      const boost::counting_iterator<std::uint32_t> one(static_cast<std::uint32_t>(r + 1));
      std::copy(one, one + static_cast<std::ptrdiff_t>(n), trace.line_of_row.data() + r);
    }
    if (time_column) {
      const double* t = trace.values[*time_column].data();
      bool forward = true;
      for (std::size_t i = lo + 1; i < hi; ++i) forward &= !(t[i] < t[i - 1]);
      good &= forward;
    }
    ok[w] = good;
  });
  // Time across the seams between the workers' rows.
  for (unsigned w = 1; w < workers && time_column; ++w) {
    const double* t = trace.values[*time_column].data();
    if (first_row(w) > 0 && first_row(w) < rows && t[first_row(w)] < t[first_row(w) - 1]) {
      return false;
    }
  }
  return std::all_of(ok.begin(), ok.end(), [](char g) { return g != 0; });
}

// Layout: magic, u32 header bytes, header text (metadata lines and the header row), rows of
// float64, trailer text, footer (u64 rows, u32 trailer bytes, "CTBE").
Trace read_binary_trace(const InputFile& in, const TraceReadOptions& options) {
  const std::string& path = in.path();
  const int fd = in.fd();
  const std::uint64_t size = in.size();
  auto truncated = [&](const char* what) {
    return ParseError(path, 0, fmt::format("binary trace truncated: {}", what));
  };
  if (size < sizeof kBinaryMagic + 4 + kFooterBytes) throw truncated("shorter than its frame");
  std::uint32_t header_bytes = 0;
  read_exact(fd, &header_bytes, 4, sizeof kBinaryMagic, path);
  char footer[kFooterBytes];
  read_exact(fd, footer, kFooterBytes, size - kFooterBytes, path);
  if (std::memcmp(footer + 12, kBinaryEnd, 4) != 0) {
    throw truncated("no footer (expected it to end with \"CTBE\")");
  }
  std::uint64_t rows = 0;
  std::uint32_t trailer_bytes = 0;
  std::memcpy(&rows, footer, 8);
  std::memcpy(&trailer_bytes, footer + 8, 4);
  const std::uint64_t header_at = sizeof kBinaryMagic + 4;
  // u32 lengths and a small frame: no overflow in 64 bits.
  if (header_at + header_bytes + trailer_bytes + kFooterBytes > size) {
    throw truncated("header and trailer longer than the file");
  }
  TraceParser parser(path, options);
  parser.metadata_only("binary trace header text");
  std::string text(header_bytes, '\0');
  read_exact(fd, text.data(), header_bytes, header_at, path);
  feed_text(parser, text);
  if (!parser.has_header()) throw ParseError(path, 0, "binary trace without a header row");
  const std::uint64_t width = parser.field_count() * sizeof(double);
  const std::uint64_t rows_at = header_at + header_bytes;
  // The room for rows is known; the row count is checked against it by division, so a
  // footer claiming 2^59 + 1 rows cannot wrap the product into a plausible size.
  const std::uint64_t room = size - rows_at - trailer_bytes - kFooterBytes;
  if (rows > room / width || rows * width != room) {
    throw ParseError(path, 0,
                     fmt::format("binary trace: {} rows of {} columns do not fill the file", rows,
                                 parser.field_count()));
  }
  const auto n = static_cast<std::size_t>(rows);
  if (!read_binary_rows(parser, fd, rows_at, n, options, path)) {
    // Something to report: again, value by value, to name the first bad record.
    TraceParser checked(path, options);
    feed_text(checked, text);
    const std::size_t block_rows = binary_block_rows(parser.field_count(), n);
    std::vector<double> block(block_rows * parser.field_count());
    for (std::size_t r = 0; r < n; r += block_rows) {
      const std::size_t m = std::min(block_rows, n - r);
      read_exact(fd, block.data(), m * width, rows_at + r * width, path);
      checked.binary_rows(block.data(), m, r + 1);
    }
    throw Error(ExitCode::internal, path + ": binary rows refused in bulk but not one by one");
  }
  std::string trailer(trailer_bytes, '\0');
  read_exact(fd, trailer.data(), trailer_bytes, rows_at + rows * width, path);
  parser.metadata_only("binary trace trailer text");
  feed_text(parser, trailer);
  return parser.finish();
}

constexpr std::size_t kTextBlock = std::size_t{4} << 20;  // more than a line may hold
static_assert(kTextBlock > kMaxInputLineBytes + 1);

struct LineTooLong {};

// The lines of a text read in blocks into `buf` (kTextBlock bytes): fill(dst, room) puts up to
// `room` bytes at dst and returns how many (0 at the end); f(line) is called for each line until
// it returns false. Returns the bytes taken, through the last line given to f. A line longer
// than kMaxInputLineBytes throws LineTooLong before it fills memory.
template <class Fill, class F>
std::uint64_t split_lines(char* buf, Fill&& fill, F&& f) {
  std::uint64_t at = 0;  // the bytes before buf[0]
  std::size_t have = 0;
  while (true) {
    const std::size_t got = fill(buf + have, kTextBlock - have);
    have += got;
    std::size_t pos = 0;
    while (pos < have) {
      const void* nl = std::memchr(buf + pos, '\n', have - pos);
      if (!nl) break;
      const auto stop = static_cast<std::size_t>(static_cast<const char*>(nl) - buf);
      const bool more = f(std::string_view(buf + pos, stop - pos));
      pos = stop + 1;
      if (!more) return at + pos;
    }
    if (got == 0) {
      if (pos < have) f(std::string_view(buf + pos, have - pos));
      return at + have;
    }
    if (have - pos > kMaxInputLineBytes) throw LineTooLong{};
    std::memmove(buf, buf + pos, have - pos);
    have -= pos;
    at += pos;
  }
}

// A pipe, or a file on one thread, is read in blocks from its current offset.
Trace read_stream_text(const InputFile& in, const TraceReadOptions& options,
                       std::uint64_t size_hint = 0) {
  const std::string& path = in.path();
  TraceParser parser(path, options);
  bool reserved = size_hint == 0;
  const auto buf = std::make_unique_for_overwrite<char[]>(kTextBlock);
  auto fill = [&](char* dst, std::size_t room) -> std::size_t {
    ssize_t n = 0;
    while ((n = ::read(in.fd(), dst, room)) < 0) {
      if (errno != EINTR) throw IoError(path, std::string("read failed: ") + std::strerror(errno));
    }
    if (!reserved) {
      // A regular file's size and its first block's lines: room for all its rows at once.
      reserved = true;
      const auto first = static_cast<std::size_t>(n);
      const std::size_t sample_rows = estimate_rows(std::string_view(buf.get(), first));
      if (sample_rows > 0 && first > 0) {
        parser.reserve_rows(static_cast<std::size_t>(static_cast<double>(sample_rows) *
                                                     static_cast<double>(size_hint) /
                                                     static_cast<double>(first)));
      }
    }
    return static_cast<std::size_t>(n);
  };
  try {
    split_lines(buf.get(), fill, [&](std::string_view line) {
      parser.line(line);
      return true;
    });
  } catch (const LineTooLong&) {
    throw ParseError(path, parser.lines() + 1, detail::line_too_long_message());
  }
  return parser.finish();
}

// A regular text file parsed in stretches, each thread reading its own stretch in blocks
// (pread into a buffer of its own) twice: once to count its lines, once to parse them. No copy
// of the whole text is held (round 5 read it whole into memory first: 71 MB more to touch,
// which on a virtual machine with costly page faults made two threads slower than one). The
// file's size at opening bounds what is read.

// f(line) for each line of the file's bytes [lo, hi) as split_lines gives them; returns the
// offset after the last line given to f.
template <class F>
std::uint64_t for_each_line(const InputFile& in, std::uint64_t lo, std::uint64_t hi, char* buf,
                            F&& f) {
  std::uint64_t next = lo;
  auto fill = [&](char* dst, std::size_t room) -> std::size_t {
    const auto want = static_cast<std::size_t>(std::min<std::uint64_t>(room, hi - next));
    if (read_exact(in.fd(), dst, want, next, in.path()) != want) {
      throw IoError(in.path(), "file shrank while being read");
    }
    next += want;
    return want;
  };
  return lo + split_lines(buf, fill, std::forward<F>(f));
}

// Lines in the file's bytes [lo, hi): its newlines, and one more for a last line without one.
std::size_t count_lines(const InputFile& in, std::uint64_t lo, std::uint64_t hi, char* buf) {
  std::size_t lines = 0;
  char last = '\n';
  for (std::uint64_t at = lo; at < hi;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(kTextBlock, hi - at));
    if (read_exact(in.fd(), buf, n, at, in.path()) != n) {
      throw IoError(in.path(), "file shrank while being read");
    }
    lines += static_cast<std::size_t>(std::count(buf, buf + n, '\n'));
    last = buf[n - 1];
    at += n;
  }
  return lines + (last != '\n' ? 1 : 0);
}

// The offset just after the first newline in the file's bytes [from, hi), or hi.
std::uint64_t after_newline(const InputFile& in, std::uint64_t from, std::uint64_t hi) {
  char window[std::size_t{1} << 16];
  for (std::uint64_t at = from; at < hi;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(sizeof window, hi - at));
    const std::size_t got = read_exact(in.fd(), window, n, at, in.path());
    if (const void* nl = std::memchr(window, '\n', got)) {
      return at + static_cast<std::uint64_t>(static_cast<const char*>(nl) - window) + 1;
    }
    if (got < n) break;
    at += n;
  }
  return hi;
}

Trace read_text_stretches(const InputFile& in, const TraceReadOptions& options, unsigned workers) {
  const std::string& path = in.path();
  const auto size = static_cast<std::uint64_t>(in.size());
  // pread only, so the file offset is still 0 for the one-thread reader.
  auto sequential = [&] { return read_stream_text(in, options, size); };
  std::vector<std::unique_ptr<char[]>> buffers;
  buffers.push_back(std::make_unique_for_overwrite<char[]>(kTextBlock));
  TraceParser parser(path, options);
  std::uint64_t rows_at = 0;
  try {
    rows_at = for_each_line(in, 0, size, buffers[0].get(), [&](std::string_view line) {
      parser.line(line);
      return !parser.has_header();
    });
  } catch (const LineTooLong&) {
    return sequential();  // which refuses the line where one thread does
  }
  if (!parser.has_header() || rows_at >= size) return parser.finish();
  // Stretches end just after a newline, so each starts at the beginning of a line.
  std::vector<std::uint64_t> bounds{rows_at};
  for (unsigned k = 1; k < workers; ++k) {
    const std::uint64_t at = rows_at + (size - rows_at) / workers * k;
    const std::uint64_t cut = after_newline(in, std::max(at, bounds.back()), size);
    if (cut >= size) break;
    if (cut > bounds.back()) bounds.push_back(cut);
  }
  bounds.push_back(size);
  const std::size_t parts = bounds.size() - 1;
  while (buffers.size() < parts)
    buffers.push_back(std::make_unique_for_overwrite<char[]>(kTextBlock));
  return parse_stretches(
      parser, parts, workers,
      [&](std::size_t k) { return count_lines(in, bounds[k], bounds[k + 1], buffers[k].get()); },
      [&](std::size_t k, TraceParser& p) {
        for_each_line(in, bounds[k], bounds[k + 1], buffers[k].get(), [&](std::string_view line) {
          p.line(line);
          return true;
        });
      },
      sequential);
}

}  // namespace

Trace parse_trace(std::string_view text, const std::string& source,
                  const TraceReadOptions& options) {
  return parse_text(text, source, options, text_workers(options, text.size()));
}

Trace read_trace(const std::string& path, const TraceReadOptions& options) {
  const InputFile in(path);
  if (!in.regular()) return read_stream_text(in, options);
  char magic[sizeof kBinaryMagic] = {};
  if (in.size() >= sizeof magic &&
      read_exact(in.fd(), magic, sizeof magic, 0, path) == sizeof magic &&
      std::memcmp(magic, kBinaryMagic, sizeof magic) == 0) {
    return read_binary_trace(in, options);
  }
  if (in.size() == 0) return parse_text({}, path, options, 1);
  // One thread per idle core (or as asked) once the file is large. Idle, on 2 cores, a 1e6-row
  // CSV (71 MB) took 0.10-0.11 s in two streamed stretches against 0.16-0.19 s on one thread
  // (the floor of parsing every number on one thread: 0.16 s).
  const unsigned workers = worker_count(options, in.size());
  if (workers < 2) return read_stream_text(in, options, in.size());
  return read_text_stretches(in, options, workers);
}

// ---------------------------------------------------------------- writer

namespace {
std::string one_line(std::string_view s) {
  std::string out(s);
  std::replace(out.begin(), out.end(), '\n', ' ');
  std::replace(out.begin(), out.end(), '\r', ' ');
  return out;
}
}  // namespace

TraceWriter::TraceWriter(std::string path, const TraceMetadata& header,
                         std::vector<TraceColumn> columns)
    : path_(std::move(path)),
      out_(std::make_unique<AtomicOutput>(path_)),
      columns_(std::move(columns)) {
  binary_ = path_.size() > 4 && path_.compare(path_.size() - 4, 4, ".ctb") == 0;
  std::string text;
  auto out = std::back_inserter(text);
  for (const auto& [k, v] : header.entries()) fmt::format_to(out, "# {}: {}\n", k, one_line(v));
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    fmt::format_to(out, "{}{}", i ? "," : "", columns_[i].name);
  }
  text += '\n';
  buffer_.reserve(1u << 20);
  if (binary_) {
    const auto bytes = static_cast<std::uint32_t>(text.size());
    buffer_.append(kBinaryMagic, sizeof kBinaryMagic);
    buffer_.append(reinterpret_cast<const char*>(&bytes), sizeof bytes);
  }
  buffer_ += text;
}

TraceWriter::~TraceWriter() = default;

void TraceWriter::write_row(const double* values) {
  if (binary_) {
    buffer_.append(reinterpret_cast<const char*>(values), columns_.size() * sizeof(double));
    ++rows_;
    if (buffer_.size() >= (1u << 20)) flush_buffer();
    return;
  }
  auto out = std::back_inserter(buffer_);
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    if (i) buffer_ += ',';
    // An integer column holding something no integer can say (a glitch on a HAL pin) is
    // written as it is rather than as a made-up integer.
    if (columns_[i].kind == ColumnKind::integer && std::abs(values[i]) < 0x1p53) {
      fmt::format_to(out, "{}", static_cast<long long>(std::llround(values[i])));
    } else if (columns_[i].kind == ColumnKind::integer) {
      fmt::format_to(out, "{}", values[i]);
    } else {
      fmt::format_to(out, "{:.{}f}", values[i], columns_[i].decimals);
    }
  }
  buffer_ += '\n';
  ++rows_;
  if (buffer_.size() >= (1u << 20)) flush_buffer();
}

void TraceWriter::add_trailer(std::string key, std::string value) {
  trailer_.set(std::move(key), std::move(value));
}

void TraceWriter::flush_buffer() {
  if (buffer_.empty()) return;
  out_->write(buffer_);
  buffer_.clear();
}

void TraceWriter::commit() {
  if (committed_) return;
  const std::size_t trailer_at = buffer_.size();
  auto out = std::back_inserter(buffer_);
  for (const auto& [k, v] : trailer_.entries()) fmt::format_to(out, "# {}: {}\n", k, one_line(v));
  if (binary_) {
    const std::uint64_t rows = rows_;
    const auto trailer_bytes = static_cast<std::uint32_t>(buffer_.size() - trailer_at);
    buffer_.append(reinterpret_cast<const char*>(&rows), sizeof rows);
    buffer_.append(reinterpret_cast<const char*>(&trailer_bytes), sizeof trailer_bytes);
    buffer_.append(kBinaryEnd, sizeof kBinaryEnd);
  }
  flush_buffer();
  out_->commit();
  committed_ = true;
}

void write_trace(const std::string& path, const Trace& trace) {
  std::vector<TraceColumn> cols;
  for (const auto& name : trace.columns) {
    TraceColumn c{name};
    if (column_name::is_integer(name)) c.kind = ColumnKind::integer;
    cols.push_back(c);
  }
  TraceWriter w(path, trace.metadata, cols);
  std::vector<double> row(cols.size());
  for (std::size_t r = 0; r < trace.rows(); ++r) {
    for (std::size_t c = 0; c < cols.size(); ++c) row[c] = trace.values[c][r];
    w.write_row(row.data());
  }
  w.commit();
}

}  // namespace circtest
