// The floors for `circana analyze`, measured side by side in one process:
//   from_chars  read a trace CSV in blocks and parse every number with std::from_chars,
//               nothing else (the floor for the text form);
//   bytes       read the file in blocks and touch nothing (the floor for the binary form);
//   read_trace  circtest's reader on the same file, with all cores and with one thread.
// Rounds interleave the variants so that a busy machine slows them alike; the best of the
// rounds is printed as wall time and CPU time. bench/analyze-cli.sh compares circana to these.
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"

namespace {

double cpu_seconds() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double checksum = 0.0;

// Every number of the file through std::from_chars; returns how many.
std::size_t from_chars_floor(const char* path) {
  const int fd = ::open(path, O_RDONLY);
  if (fd < 0) {
    std::perror(path);
    std::exit(3);
  }
  std::string buf(4u << 20, '\0');
  std::size_t have = 0, numbers = 0;
  bool header_seen = false;
  while (true) {
    const ssize_t n = ::read(fd, buf.data() + have, buf.size() - have);
    if (n < 0) std::exit(3);
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
  return numbers;
}

std::size_t bytes_floor(const char* path) {
  const int fd = ::open(path, O_RDONLY);
  if (fd < 0) std::exit(3);
  std::vector<char> buf(4u << 20);
  std::size_t total = 0;
  while (true) {
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n <= 0) break;
    total += static_cast<std::size_t>(n);
    checksum += buf[0];
  }
  ::close(fd);
  return total;
}

// The file's bytes read into memory that holds them all, fresh for each round (its own
// mapping in huge pages, given back after): what any reader that keeps every sample pays at
// least, the page faults of that memory included. The 4 MiB floor above reuses one buffer that
// stays in cache.
std::size_t bytes_fresh(const char* path) {
  const int fd = ::open(path, O_RDONLY);
  if (fd < 0) std::exit(3);
  const off_t size = ::lseek(fd, 0, SEEK_END);
  if (size <= 0) std::exit(3);
  const auto n = static_cast<std::size_t>(size);
  void* map = ::mmap(nullptr, n, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (map == MAP_FAILED) std::exit(3);
  // In 2 MiB pages where the kernel allows, as circana's allocator asks for its columns.
  ::madvise(map, n, MADV_HUGEPAGE);
  auto* p = static_cast<char*>(map);
  std::size_t total = 0;
  while (total < n) {
    const ssize_t r = ::pread(fd, p + total, n - total, static_cast<off_t>(total));
    if (r <= 0) break;
    total += static_cast<std::size_t>(r);
  }
  checksum += p[total / 2];
  ::munmap(map, n);
  ::close(fd);
  return total;
}

// What circana analyze keeps of a trace.
std::size_t reader(const char* path, unsigned threads) {
  circtest::TraceReadOptions o;
  o.keep = {"t", "marker", "segment", "x", "y", "z", "x_cmd", "y_cmd", "z_cmd"};
  o.threads = threads;
  const circtest::Trace t = circtest::read_trace(path, o);
  checksum += t.values[0].back();
  return t.rows();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: parse_baseline TRACE [rounds] [csv|binary]\n");
    return 2;
  }
  const char* path = argv[1];
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 5;
  const bool binary = argc > 3 && std::strcmp(argv[3], "binary") == 0;
  struct Variant {
    const char* name;
    std::function<std::size_t()> run;
    double wall = 1e9, cpu = 1e9;
    std::size_t count = 0;
  };
  std::vector<Variant> variants;
  if (binary) {
    variants.push_back({"bytes floor (read in 4 MiB blocks)", [&] { return bytes_floor(path); }});
    variants.push_back({"bytes into fresh memory", [&] { return bytes_fresh(path); }});
  } else {
    variants.push_back({"from_chars floor", [&] { return from_chars_floor(path); }});
  }
  const std::size_t readers = variants.size();
  variants.push_back({"read_trace, all cores", [&] { return reader(path, 0); }});
  variants.push_back({"read_trace, 1 thread", [&] { return reader(path, 1); }});
  try {
    for (int r = 0; r < rounds; ++r) {
      for (auto& v : variants) {
        const double c0 = cpu_seconds();
        const auto t0 = std::chrono::steady_clock::now();
        v.count = v.run();
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        v.wall = std::min(v.wall, s);
        v.cpu = std::min(v.cpu, cpu_seconds() - c0);
      }
    }
  } catch (const circtest::Error& e) {
    std::fprintf(stderr, "parse_baseline: %s\n", e.what());
    return 4;
  }
  for (const auto& v : variants) {
    std::printf("%-36s best of %d: %.3f s wall, %.3f s CPU (%zu %s)\n", v.name, rounds, v.wall,
                v.cpu, v.count, &v < &variants[readers] ? (binary ? "bytes" : "numbers") : "rows");
  }
  std::printf(
      "floor_wall_s=%.4f reader_wall_s=%.4f reader1_wall_s=%.4f floor_cpu_s=%.4f "
      "reader1_cpu_s=%.4f fresh_wall_s=%.4f (checksum %g)\n",
      variants[0].wall, variants[readers].wall, variants[readers + 1].wall, variants[0].cpu,
      variants[readers + 1].cpu, binary ? variants[1].wall : 0.0, checksum);
  return 0;
}
