#include "circtest/core/memory.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>

namespace circtest {

void advise_huge_pages(const void* data, std::size_t bytes) noexcept {
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  if (bytes < 2 * kHuge) return;
  const auto a = reinterpret_cast<std::uintptr_t>(data);
  std::uintptr_t lo = (a + kHuge - 1) & ~(kHuge - 1);
  std::uintptr_t hi = (a + bytes) & ~(kHuge - 1);
  if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#ifdef MADV_POPULATE_WRITE
  const auto page = static_cast<std::uintptr_t>(::sysconf(_SC_PAGESIZE));
  lo = (a + page - 1) & ~(page - 1);
  hi = (a + bytes) & ~(page - 1);
  if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_POPULATE_WRITE);
#endif
}

}  // namespace circtest
