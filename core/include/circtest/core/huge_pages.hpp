#pragma once
// Large buffers asked for huge pages before they are first written. On the virtual machines
// the tools run on, a page fault costs tens of microseconds, so filling a fresh 8 MB array
// page by page costs more than the arithmetic done on it; with 2 MiB pages it is a few
// faults. Both calls are hints: an older kernel, or one with transparent huge pages off,
// ignores them and the buffer works as before.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace circtest {

// Advises huge pages for the 2 MiB-aligned part of [data, data + bytes) and populates the
// range for writing (MADV_POPULATE_WRITE, Linux 5.14), so that threads writing it later do
// not fault. Call it on memory not yet written (reserved or uninitialised): populating keeps
// what is there, but a page already touched stays a small page.
inline void advise_huge_pages(const void* data, std::size_t bytes) {
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

// v.reserve(n) with the new capacity advised as above (only when it grew).
template <class T, class A>
void reserve_huge(std::vector<T, A>& v, std::size_t n) {
  if (n <= v.capacity()) return;
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}

}  // namespace circtest
