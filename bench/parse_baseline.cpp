// The floor for `circana analyze`: read a trace CSV in blocks and parse every number on
// it with std::from_chars, nothing else. bench/analyze-cli.sh compares circana against it.
#include <fcntl.h>
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: parse_baseline TRACE.csv [repeats]\n");
    return 2;
  }
  const int repeats = argc > 2 ? std::atoi(argv[2]) : 5;
  double best = 1e9;
  double checksum = 0.0;
  std::size_t numbers = 0;
  for (int rep = 0; rep < repeats; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    const int fd = ::open(argv[1], O_RDONLY);
    if (fd < 0) {
      std::perror(argv[1]);
      return 3;
    }
    std::string buf(4u << 20, '\0');
    std::size_t have = 0;
    bool header_seen = false;
    numbers = 0;
    checksum = 0.0;
    while (true) {
      const ssize_t n = ::read(fd, buf.data() + have, buf.size() - have);
      if (n < 0) return 3;
      have += static_cast<std::size_t>(n);
      std::size_t pos = 0;
      while (true) {
        const char* nl = static_cast<const char*>(std::memchr(buf.data() + pos, '\n', have - pos));
        if (!nl && n > 0) break;
        const char* p = buf.data() + pos;
        const char* end = nl ? nl : buf.data() + have;
        if (p < end && *p != '#') {
          if (!header_seen) {
            header_seen = true;
          } else {
            while (p < end) {
              double v = 0.0;
              const auto r = std::from_chars(p, end, v);
              checksum += v;
              ++numbers;
              p = r.ptr + 1;  // past the comma
            }
          }
        }
        if (!nl) {
          pos = have;
          break;
        }
        pos = static_cast<std::size_t>(nl - buf.data()) + 1;
      }
      if (n == 0) break;
      std::memmove(buf.data(), buf.data() + pos, have - pos);
      have -= pos;
    }
    ::close(fd);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (s < best) best = s;
  }
  std::printf("from_chars baseline: %zu numbers, best of %d: %.3f s (checksum %g)\n", numbers,
              repeats, best, checksum);
  return 0;
}
