// Reading a text (CSV) trace: from memory, from a stream in blocks, or a large file in
// stretches parsed side by side.
#include "trace_parser.hpp"

namespace circtest::trace_detail {

namespace {

std::size_t estimate_rows(std::string_view data) {
  const std::string_view sample = data.substr(0, std::size_t{1} << 16);
  const auto lines = static_cast<std::size_t>(std::count(sample.begin(), sample.end(), '\n'));
  if (lines == 0 || sample.empty()) return 0;
  const double per_line = static_cast<double>(sample.size()) / static_cast<double>(lines);
  return static_cast<std::size_t>(static_cast<double>(data.size()) / per_line * 1.02) + 16;
}

}  // namespace

// Threads for a text trace of `bytes` in memory: stretches only when two or more are asked for
// (nothing in circtest reads a large text from memory).
unsigned text_workers(const TraceReadOptions& options, std::size_t bytes) {
  return options.threads >= 2 ? worker_count(options, bytes) : 1;
}

namespace {

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
  // the gaps comment and blank lines leave (stretches parsed into their own columns and
  // appended make two threads slower than one).
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

}  // namespace

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

namespace {

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

}  // namespace

// A pipe, or a file on one thread, is read in blocks from its current offset.
Trace read_stream_text(const InputFile& in, const TraceReadOptions& options,
                       std::uint64_t size_hint) {
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

namespace {

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

}  // namespace

// A regular text file parsed in stretches, each thread reading its own stretch in blocks
// (pread into a buffer of its own) twice: once to count its lines, once to parse them. No copy
// of the whole text is held (reading it whole into memory first is 71 MB more to touch, which
// on a virtual machine with costly page faults makes two threads slower than one). The file's
// size at opening bounds what is read.
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

}  // namespace circtest::trace_detail
