#include "circtest/core/trace.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>
#include <sys/stat.h>
#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <iterator>
#include <string>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"

namespace circtest {

// ---------------------------------------------------------------- metadata

void TraceMetadata::set(std::string key, std::string value) {
  entries_.emplace_back(std::move(key), std::move(value));
  lines_.push_back(0);
}

void TraceMetadata::set_line(std::size_t index, std::size_t line) {
  if (index < lines_.size()) lines_[index] = line;
}

const std::string* TraceMetadata::find(std::string_view key) const {
  for (auto it = entries_.rbegin(); it != entries_.rend(); ++it) {
    if (it->first == key) return &it->second;
  }
  return nullptr;
}

std::size_t TraceMetadata::line_of(std::string_view key) const {
  for (std::size_t i = entries_.size(); i-- > 0;) {
    if (entries_[i].first == key) return lines_[i];
  }
  return 0;
}

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

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

int Trace::column_index(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return static_cast<int>(i);
  }
  return -1;
}

const std::vector<double>* Trace::column(std::string_view name) const {
  const int i = column_index(name);
  return i < 0 ? nullptr : &values[static_cast<std::size_t>(i)];
}

// ---------------------------------------------------------------- reader

namespace {

class TraceParser {
 public:
  TraceParser(std::string source, const TraceReadOptions& options) : options_(options) {
    trace_.source = std::move(source);
  }

  void reserve_rows(std::size_t n) {
    reserve_hint_ = n;
    if (!have_header_) return;
    for (auto& v : trace_.values) v.reserve(n);
    trace_.line_of_row.reserve(n);
  }
  std::size_t lines() const { return line_no_; }

  void line(std::string_view text) {
    ++line_no_;
    if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
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
    row(text);
  }

  Trace finish() {
    if (!have_header_) {
      throw ParseError(trace_.source, line_no_ == 0 ? 1 : line_no_,
                       line_no_ == 0 ? "empty file: expected a header row of column names"
                                     : "no header row: expected a line of column names");
    }
    return std::move(trace_);
  }

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
      while (i < n && (text[i] == ' ' || text[i] == '\t')) ++i;
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
        while (i < n && (text[i] == ' ' || text[i] == '\t')) ++i;
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
    std::vector<std::string> names;
    split_quoted(text, names);
    const std::size_t n = names.size();
    target_.assign(n, -1);
    for (std::size_t i = 0; i < n; ++i) {
      if (names[i].empty()) fail(fmt::format("header: column {} has no name", i + 1));
      for (std::size_t j = 0; j < i; ++j) {
        if (names[j] == names[i]) fail(fmt::format("header: duplicate column '{}'", names[i]));
      }
      bool keep = options_.keep.empty() || std::find(options_.keep.begin(), options_.keep.end(),
                                                     names[i]) != options_.keep.end();
      if (keep) {
        target_[i] = static_cast<int>(trace_.columns.size());
        trace_.columns.push_back(names[i]);
      }
    }
    for (const std::string& req : options_.required) {
      if (std::find(names.begin(), names.end(), req) == names.end()) {
        std::string have;
        for (const auto& nm : names) have += (have.empty() ? "" : ",") + nm;
        fail(fmt::format("missing column '{}': expected it in the header (found: {})", req, have));
      }
    }
    field_count_ = n;
    header_names_ = std::move(names);
    trace_.values.assign(trace_.columns.size(), {});
    if (reserve_hint_ > 0) {
      for (auto& v : trace_.values) v.reserve(reserve_hint_);
      trace_.line_of_row.reserve(reserve_hint_);
    }
    trace_.header_line = line_no_;
    const int ti = trace_.column_index("t");
    time_column_ = options_.check_time_monotonic ? ti : -1;
    have_header_ = true;
  }

  void row(std::string_view text) {
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
    trace_.line_of_row.push_back(static_cast<std::uint32_t>(line_no_));
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
    const int col = target_[field];
    auto& dst = trace_.values[static_cast<std::size_t>(col)];
    if (col == time_column_ && !dst.empty() && v < dst.back()) {
      throw DataError(trace_.source, binary_ ? 0 : line_no_,
                      fmt::format("{}time goes backwards: t = {} after t = {}; expected "
                                  "non-decreasing time",
                                  record_prefix(), v, dst.back()));
    }
    dst.push_back(v);
  }

 public:
  // Binary rows (docs/trace-format.md): record numbers stand in for line numbers.
  void binary_rows(const double* values, std::size_t rows, std::size_t first_record) {
    if (!have_header_) fail("no header row: expected a line of column names");
    binary_ = true;
    for (std::size_t r = 0; r < rows; ++r) {
      record_ = first_record + r;
      const double* row = values + r * field_count_;
      for (std::size_t i = 0; i < field_count_; ++i) {
        if (target_[i] >= 0) store_value(i, row[i], {});
      }
      trace_.line_of_row.push_back(static_cast<std::uint32_t>(record_));
    }
  }
  std::size_t field_count() const { return field_count_; }
  bool has_header() const { return have_header_; }

 private:
  std::string record_prefix() const {
    return binary_ ? fmt::format("record {}: ", record_) : std::string();
  }

  const TraceReadOptions& options_;
  Trace trace_;
  std::size_t line_no_ = 0;
  bool have_header_ = false;
  std::size_t field_count_ = 0;
  std::vector<int> target_;
  std::vector<std::string> header_names_;
  std::vector<std::string> scratch_;
  int time_column_ = -1;
  std::size_t reserve_hint_ = 0;
  bool binary_ = false;
  std::size_t record_ = 0;
};

constexpr char kBinaryMagic[8] = {'C', 'T', 'R', 'A', 'C', 'E', 'B', '1'};
constexpr char kBinaryEnd[4] = {'C', 'T', 'B', 'E'};
constexpr std::size_t kFooterBytes = 8 + 4 + 4;  // rows (u64), trailer bytes (u32), end magic

static_assert(std::endian::native == std::endian::little,
              "the binary trace is little-endian; add byte swapping for this host");

void feed_text(TraceParser& parser, std::string_view text) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    const auto nl = text.find('\n', pos);
    const std::size_t stop = nl == std::string_view::npos ? text.size() : nl;
    parser.line(text.substr(pos, stop - pos));
    pos = stop + 1;
  }
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

// Layout: magic, u32 header bytes, header text (metadata lines and the header row), rows of
// float64, trailer text, footer (u64 rows, u32 trailer bytes, "CTBE").
Trace read_binary_trace(int fd, std::uint64_t size, const std::string& path,
                        const TraceReadOptions& options) {
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
  if (header_at + header_bytes + trailer_bytes + kFooterBytes > size) {
    throw truncated("header and trailer longer than the file");
  }
  TraceParser parser(path, options);
  std::string text(header_bytes, '\0');
  read_exact(fd, text.data(), header_bytes, header_at, path);
  feed_text(parser, text);
  if (!parser.has_header()) throw ParseError(path, 0, "binary trace without a header row");
  const std::size_t width = parser.field_count() * sizeof(double);
  const std::uint64_t rows_at = header_at + header_bytes;
  if (rows_at + rows * width + trailer_bytes + kFooterBytes != size) {
    throw ParseError(path, 0,
                     fmt::format("binary trace: {} rows of {} columns do not fill the file", rows,
                                 parser.field_count()));
  }
  parser.reserve_rows(static_cast<std::size_t>(rows));
  constexpr std::size_t kBlockRows = 32768;
  std::vector<double> block(kBlockRows * parser.field_count());
  for (std::uint64_t r = 0; r < rows; r += kBlockRows) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(kBlockRows, rows - r));
    read_exact(fd, block.data(), n * width, rows_at + r * width, path);
    parser.binary_rows(block.data(), n, static_cast<std::size_t>(r) + 1);
  }
  std::string trailer(trailer_bytes, '\0');
  read_exact(fd, trailer.data(), trailer_bytes, rows_at + rows * width, path);
  feed_text(parser, trailer);
  return parser.finish();
}

}  // namespace

Trace parse_trace(std::string_view text, const std::string& source,
                  const TraceReadOptions& options) {
  TraceParser parser(source, options);
  feed_text(parser, text);
  return parser.finish();
}

Trace read_trace(const std::string& path, const TraceReadOptions& options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw IoError(path, std::string("cannot open: ") + std::strerror(errno));
  struct FdCloser {
    int fd;
    ~FdCloser() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) throw IoError(path, "is a directory");
  char magic[sizeof kBinaryMagic] = {};
  if (st.st_size >= static_cast<off_t>(sizeof magic) &&
      read_exact(fd, magic, sizeof magic, 0, path) == sizeof magic &&
      std::memcmp(magic, kBinaryMagic, sizeof magic) == 0) {
    return read_binary_trace(fd, static_cast<std::uint64_t>(st.st_size), path, options);
  }

  TraceParser parser(path, options);
  // Streamed in blocks so that memory stays at the parsed columns, not the file size.
  constexpr std::size_t kBlock = 4u << 20;
  std::string buf;
  buf.resize(kBlock);
  std::size_t have = 0;
  bool hinted = false;
  while (true) {
    if (have == buf.size()) buf.resize(buf.size() * 2);  // a line longer than a block
    const ssize_t n = ::read(fd, buf.data() + have, buf.size() - have);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw IoError(path, std::string("read failed: ") + std::strerror(errno));
    }
    const bool eof = n == 0;
    have += static_cast<std::size_t>(n);
    std::size_t pos = 0;
    const char* data = buf.data();
    while (pos < have) {
      const void* nl = std::memchr(data + pos, '\n', have - pos);
      if (!nl) break;
      const std::size_t stop = static_cast<const char*>(nl) - data;
      parser.line(std::string_view(data + pos, stop - pos));
      pos = stop + 1;
    }
    if (!hinted && pos > 0 && st.st_size > 0 && parser.lines() > 0) {
      // Reserve the columns once from the first block's bytes per line: no regrowth copies.
      hinted = true;
      const double per_line = static_cast<double>(pos) / static_cast<double>(parser.lines());
      parser.reserve_rows(
          static_cast<std::size_t>(static_cast<double>(st.st_size) / per_line * 1.02) + 16);
    }
    if (eof) {
      if (pos < have) parser.line(std::string_view(data + pos, have - pos));
      break;
    }
    std::memmove(buf.data(), data + pos, have - pos);
    have -= pos;
  }
  return parser.finish();
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
    if (name == "marker" || name == "segment" || name == "period") c.kind = ColumnKind::integer;
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
