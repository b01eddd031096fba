// Reading a binary trace (.ctb): its header and trailer text through the parser, its rows in
// blocks.
#include "trace_parser.hpp"

namespace circtest::trace_detail {

namespace {

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

}  // namespace

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

}  // namespace circtest::trace_detail
