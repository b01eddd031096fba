#pragma once
// Large buffers of the reader and the analysis (columns and profiles of a 1e6-row trace).
#include <cstddef>
#include <vector>

namespace circtest {

// Asks for huge pages over [data, data + bytes) and maps the pages in one call. A 1e6-row
// column otherwise takes a page fault per 4 KiB, which on a virtual machine costs more than
// filling it. Both are hints: an older kernel ignores them; buffers under 4 MiB are left alone.
void advise_huge_pages(const void* data, std::size_t bytes) noexcept;

// v.reserve(n), the new room advised as above.
template <class T>
void reserve_huge(std::vector<T>& v, std::size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}

}  // namespace circtest
