#include "circtest/core/memory.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>

namespace circtest {

namespace {
constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
}  // namespace

void advise_huge_pages_only(const void* data, std::size_t bytes) noexcept {
  if (bytes < 2 * kHuge) return;
  const auto a = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t lo = (a + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t hi = (a + bytes) & ~(kHuge - 1);
  if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
}

void populate_pages(const void* data, std::size_t bytes) noexcept {
#ifdef MADV_POPULATE_WRITE
  const auto a = reinterpret_cast<std::uintptr_t>(data);
  const auto page = static_cast<std::uintptr_t>(::sysconf(_SC_PAGESIZE));
  const std::uintptr_t lo = (a + page - 1) & ~(page - 1);
  const std::uintptr_t hi = (a + bytes) & ~(page - 1);
  if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_POPULATE_WRITE);
#else
  (void)data;
  (void)bytes;
#endif
}

void advise_huge_pages(const void* data, std::size_t bytes) noexcept {
  if (bytes < 2 * kHuge) return;
  advise_huge_pages_only(data, bytes);
  populate_pages(data, bytes);
}

}  // namespace circtest
