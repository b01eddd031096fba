// A trace's metadata (its key index and typed look-ups) and its columns by name.
#include <fmt/format.h>

#include <algorithm>
#include <string>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace.hpp"
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

std::optional<double> TraceMetadata::number(std::string_view key, const std::string& source) const {
  const std::string* v = find(key);
  if (!v) return std::nullopt;
  const auto out = parse_finite(*v);
  if (!out) {
    throw ParseError(
        source, line_of(key),
        fmt::format("metadata '{}': expected a finite number, got '{}'", key, detail::shorten(*v)));
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
}  // namespace circtest
