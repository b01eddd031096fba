// Writing a trace, text or binary (.ctb), through an atomic output.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <memory>
#include <string>

#include "circtest/core/atomic_file.hpp"
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