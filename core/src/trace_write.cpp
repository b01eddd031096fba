// Writing a trace, text or binary (.ctb), through an atomic output.
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <memory>
#include <string>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"
#include "circtest/core/trace_keys.hpp"
#include "trace_binary.hpp"

namespace circtest {

using trace_detail::kBinaryEnd;
using trace_detail::kBinaryMagic;

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
  header_text_ = text;
  buffer_.reserve(1u << 20);
  if (binary_) {
    const auto bytes = static_cast<std::uint32_t>(text.size());
    buffer_.append(kBinaryMagic, sizeof kBinaryMagic);
    buffer_.append(reinterpret_cast<const char*>(&bytes), sizeof bytes);
  }
  buffer_ += text;
}

TraceWriter::~TraceWriter() {
  if (live_fd_ >= 0) ::close(live_fd_);
}

void TraceWriter::append_text_row(std::string& to, const double* values) const {
  auto out = std::back_inserter(to);
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    if (i) to += ',';
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
  to += '\n';
}

void TraceWriter::write_row(const double* values) {
  if (binary_) {
    buffer_.append(reinterpret_cast<const char*>(values), columns_.size() * sizeof(double));
    if (live_fd_ >= 0) append_text_row(live_buffer_, values);
  } else {
    const std::size_t at = buffer_.size();
    append_text_row(buffer_, values);
    // The live copy takes the same text, formatted once.
    if (live_fd_ >= 0) live_buffer_.append(buffer_, at, std::string::npos);
  }
  ++rows_;
  if (buffer_.size() >= (1u << 20)) flush_buffer();
}

void TraceWriter::live_copy(const std::string& live_path) {
  if (rows_ > 0 || live_fd_ >= 0) {
    throw IoError(live_path, "a live copy is started before the first row, once");
  }
  const std::string target = checked_output_target(live_path);
  const int fd =
      ::open(target.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd < 0) throw IoError(live_path, std::string("cannot open: ") + std::strerror(errno));
  live_fd_ = fd;
  live_path_ = live_path;
  write_live(header_text_);
}

void TraceWriter::write_live(std::string_view bytes) {
  while (live_fd_ >= 0 && !bytes.empty()) {
    const ssize_t n = ::write(live_fd_, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      live_error_ =
          fmt::format("{}: write failed ({}): the live copy stops here, the trace goes on",
                      live_path_, n < 0 ? std::strerror(errno) : "nothing written");
      ::close(live_fd_);
      live_fd_ = -1;
      live_buffer_.clear();
      return;
    }
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
}

void TraceWriter::flush_live() {
  if (live_fd_ < 0 || live_buffer_.empty()) return;
  write_live(live_buffer_);
  live_buffer_.clear();
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
  std::string trailer;
  auto out = std::back_inserter(trailer);
  for (const auto& [k, v] : trailer_.entries()) fmt::format_to(out, "# {}: {}\n", k, one_line(v));
  buffer_ += trailer;
  if (binary_) {
    const std::uint64_t rows = rows_;
    const auto trailer_bytes = static_cast<std::uint32_t>(trailer.size());
    buffer_.append(reinterpret_cast<const char*>(&rows), sizeof rows);
    buffer_.append(reinterpret_cast<const char*>(&trailer_bytes), sizeof trailer_bytes);
    buffer_.append(kBinaryEnd, sizeof kBinaryEnd);
  }
  flush_buffer();
  out_->commit();
  committed_ = true;
  if (live_fd_ >= 0) {
    live_buffer_ += trailer;
    flush_live();
    if (live_fd_ >= 0) ::close(live_fd_);
    live_fd_ = -1;
  }
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