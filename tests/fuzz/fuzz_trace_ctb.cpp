// The binary trace reader (.ctb): the input follows the magic, read through a file
// descriptor as circana reads a file.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "circtest/core/trace.hpp"
#include "fuzz_main_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const int fd = ::memfd_create("fuzz.ctb", 0);
  if (fd < 0) std::abort();
  static const std::string path = "/proc/self/fd/" + std::to_string(fd);
  if (::ftruncate(fd, 0) != 0 || ::lseek(fd, 0, SEEK_SET) != 0) std::abort();
  static const char magic[8] = {'C', 'T', 'R', 'A', 'C', 'E', 'B', '1'};
  if (::write(fd, magic, sizeof magic) != sizeof magic) std::abort();
  if (size > 0 && ::write(fd, data, size) != static_cast<ssize_t>(size)) std::abort();
  circtest::fuzz::expect_documented_outcome([&] {
    const circtest::Trace t = circtest::read_trace(path);
    for (const auto& column : t.values) {
      if (column.size() != t.rows()) std::abort();
    }
  });
  return 0;
}
