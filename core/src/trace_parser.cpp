// The trace parser's out-of-line parts and the helpers the readers share.
#include "trace_parser.hpp"

namespace circtest::trace_detail {

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

}  // namespace circtest::trace_detail
