#pragma once
// The trace: what circlog-record writes and circana reads (docs/trace-format.md).
// Text form: "# key: value" metadata lines, a header row of comma-separated column names,
// then one comma-separated row per sample; mm and s.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "circtest/core/atomic_file.hpp"

namespace circtest {

// Ordered key/value pairs; a key given twice keeps both, and lookups return the last one
// (so trailer metadata written at the end of a recording overrides the header). Every
// operation is constant time per key (an index of each key's last entry), so a trace of
// 200,000 keys is read, reported and written in linear time.
class TraceMetadata {
 public:
  void set(std::string key, std::string value);
  const std::string* find(std::string_view key) const;
  // Each key once, where it first appears, as the index of its last entry (the value a
  // lookup gives): the conditions as a report lists them.
  std::vector<std::size_t> distinct() const;
  // The value as a number; nullopt if absent. Throws ParseError (naming `source` and the
  // metadata line) if present but not a finite number.
  std::optional<double> number(std::string_view key, const std::string& source = {}) const;
  std::size_t line_of(std::string_view key) const;                        // 0 if unknown
  std::size_t line_at(std::size_t index) const { return lines_[index]; }  // of entries()[index]
  const std::vector<std::pair<std::string, std::string>>& entries() const { return entries_; }
  void set_line(std::size_t index, std::size_t line);

 private:
  struct KeyHash {
    using is_transparent = void;
    std::size_t operator()(std::string_view key) const noexcept {
      return std::hash<std::string_view>{}(key);
    }
  };
  std::optional<std::size_t> last_index(std::string_view key) const;

  std::vector<std::pair<std::string, std::string>> entries_;
  std::vector<std::size_t> lines_;
  // The index into entries_ of each key's last entry.
  std::unordered_map<std::string, std::size_t, KeyHash, std::equal_to<>> last_;
};

// The values of the metadata keys the tools interpret (radius_mm, centre_mm, plane, units,
// arc_deg, temperatures, ...: docs/trace-format.md) against their format and plausible range.
// Throws ParseError naming `source` and the line of the first bad value. The readers call it.
void check_metadata(const TraceMetadata& metadata, const std::string& source);

struct Trace {
  std::string source;  // file name, for messages
  TraceMetadata metadata;
  std::vector<std::string> columns;         // kept columns, in file order
  std::vector<std::vector<double>> values;  // values[column][row]
  std::vector<std::uint32_t> line_of_row;   // 1-based file line of each row
  std::size_t header_line = 0;

  std::size_t rows() const { return line_of_row.size(); }
  // Index into columns/values; none when the trace has no such column.
  std::optional<std::size_t> column_index(std::string_view name) const;
  const std::vector<double>* column(std::string_view name) const;
};

struct TraceReadOptions {
  std::vector<std::string> keep;  // columns to keep (empty: keep all)
  // When set, called at the header row with the metadata read so far; its result replaces
  // `keep` (e.g. only the columns of the plane the metadata names).
  using KeepFor = std::function<std::vector<std::string>(const TraceMetadata&)>;
  KeepFor keep_for;
  std::vector<std::string> required;  // columns that must exist (else ParseError at the header)
  // When the trace has a `t` column: reject time going backwards (DataError at that row).
  bool check_time_monotonic = true;
  // Threads for a large trace (0: one per idle core). A binary trace's rows are shared out
  // among them. A text file of at least parallel_min_bytes is parsed in stretches, each thread
  // reading its own stretch and writing its rows in place into the columns; a text in memory
  // (parse_trace) only when two or more are asked for. Results and errors are the same as with
  // one thread.
  unsigned threads = 0;
  std::size_t parallel_min_bytes = std::size_t{4} << 20;
};

// Reads a text trace (or a binary one, see docs/trace-format.md; detected by its magic) from
// a regular file or a pipe ("-" is standard input; see InputFile for what is refused).
// Throws IoError, ParseError or DataError with the file and line.
Trace read_trace(const std::string& path, const TraceReadOptions& options = {});
Trace parse_trace(std::string_view text, const std::string& source,
                  const TraceReadOptions& options = {});

enum class ColumnKind { real, integer };

struct TraceColumn {
  std::string name;
  ColumnKind kind = ColumnKind::real;
  int decimals = 6;  // for real columns: 6 decimals of mm is 1 nm
};

// Streams a trace to an unnamed temporary (core/atomic_file) that appears at <path> on
// commit(), after fsync, so a reader never sees a half-written trace and a killed recorder
// leaves nothing behind. <path> follows the output-path rules of atomic_file.hpp. A path ending in
// ".ctb" gets the binary form (float64 rows), else text.
class TraceWriter {
 public:
  TraceWriter(std::string path, const TraceMetadata& header, std::vector<TraceColumn> columns);
  ~TraceWriter();
  TraceWriter(const TraceWriter&) = delete;
  TraceWriter& operator=(const TraceWriter&) = delete;

  // One value per column, in column order.
  void write_row(const double* values);
  // Metadata written after the last row (counts known only at the end of a recording).
  void add_trailer(std::string key, std::string value);
  void commit();
  std::size_t rows_written() const { return rows_; }
  const std::string& path() const { return path_; }

  // A live copy for a reader that follows the recording as it goes (the QtVCP panel's live
  // plot): the text form of the trace, header first, at LIVE_PATH (an output path by the rules
  // of atomic_file.hpp, but written in place, not atomically: it grows). Rows reach it at each
  // flush_live(); commit() adds the trailer. The trace itself is still the committed output.
  // A write to the live copy that fails stops the live copy, never the trace: live_error()
  // says why (empty while it works). Call before the first row.
  void live_copy(const std::string& live_path);
  void flush_live();
  const std::string& live_error() const { return live_error_; }

 private:
  void flush_buffer();
  void append_text_row(std::string& to, const double* values) const;
  void write_live(std::string_view bytes);
  std::string path_;
  std::unique_ptr<AtomicOutput> out_;  // nothing at path_ until commit()
  std::vector<TraceColumn> columns_;
  TraceMetadata trailer_;
  std::string buffer_;
  std::size_t rows_ = 0;
  bool committed_ = false;
  bool binary_ = false;
  std::string header_text_;  // the text form's header: metadata lines and the column names
  int live_fd_ = -1;
  std::string live_buffer_;  // rows not yet in the live copy
  std::string live_path_, live_error_;
};

// Writes a whole trace with TraceWriter.
void write_trace(const std::string& path, const Trace& trace);

}  // namespace circtest
