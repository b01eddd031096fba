#pragma once
// The trace parser: metadata lines, the header row and the rows of a text trace (or the rows of
// a binary one), checked as they come; and the helpers the text and binary readers share.
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
#include "trace_binary.hpp"

namespace circtest::trace_detail {

using detail::shorten;

constexpr char kBom[] = "\xEF\xBB\xBF";

inline bool blank(char c) {
  return c == ' ' || c == '\t';
}

// Whether a line where the header row belongs is a line of a G-code program (what circgen
// writes, or any RS274 text): `%`, a `(comment)` or `; comment` line, or words of a letter
// and a number (`N10 G1 X5 F300`, comments allowed) with at least one G, M or N word, or an
// O-code (`o100 sub`). A header row is column names separated by commas, none of which reads
// like that.
bool gcode_line(std::string_view text);

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

// Feeds the lines of `text` to the parser.
void feed_text(TraceParser& parser, std::string_view text);
// The threads for reading `bytes`: one per idle core, or as the options ask.
unsigned worker_count(const TraceReadOptions& options, std::size_t bytes);
// Reads n bytes at offset of fd into dst, fewer only at the end of the file.
std::size_t read_exact(int fd, void* dst, std::size_t n, std::uint64_t offset,
                       const std::string& path);

// trace_read_ctb.cpp: a binary trace.
Trace read_binary_trace(const InputFile& in, const TraceReadOptions& options);
// trace_read_csv.cpp: a text trace in memory, from a stream, or a file in stretches.
unsigned text_workers(const TraceReadOptions& options, std::size_t bytes);
Trace parse_text(std::string_view text, const std::string& source, const TraceReadOptions& options,
                 unsigned workers);
Trace read_stream_text(const InputFile& in, const TraceReadOptions& options,
                       std::uint64_t size_hint = 0);
Trace read_text_stretches(const InputFile& in, const TraceReadOptions& options, unsigned workers);

}  // namespace circtest::trace_detail
