#pragma once
// Large buffers of the reader and the analysis (columns and profiles of a 1e6-row trace).
#include <cstddef>
#include <vector>

namespace circtest {

// Asks for huge pages over [data, data + bytes) and maps the pages in one call. A 1e6-row
// column otherwise takes a page fault per 4 KiB, which on a virtual machine costs more than
// filling it. Both are hints: an older kernel ignores them; buffers under 4 MiB are left alone.
void advise_huge_pages(const void* data, std::size_t bytes) noexcept;

// The huge-page hint alone; the pages are mapped on first touch or by populate_pages.
void advise_huge_pages_only(const void* data, std::size_t bytes) noexcept;

// Maps the pages of [data, data + bytes) (zero-filled by the kernel) without changing what
// is in them: pages already written keep their contents, so another thread may be writing
// the range meanwhile. A range no longer mapped is skipped.
void populate_pages(const void* data, std::size_t bytes) noexcept;

// v.reserve(n), the new room advised as above.
template <class T>
void reserve_huge(std::vector<T>& v, std::size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}

}  // namespace circtest
