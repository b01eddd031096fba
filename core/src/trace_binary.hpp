#pragma once
// The binary trace (.ctb) layout: magic, u32 header bytes, header text (metadata lines and the
// header row), rows of float64, trailer text, footer (u64 rows, u32 trailer bytes, "CTBE").
#include <bit>
#include <cstddef>

namespace circtest::trace_detail {

constexpr char kBinaryMagic[8] = {'C', 'T', 'R', 'A', 'C', 'E', 'B', '1'};
constexpr char kBinaryEnd[4] = {'C', 'T', 'B', 'E'};
constexpr std::size_t kFooterBytes = 8 + 4 + 4;  // rows (u64), trailer bytes (u32), end magic

static_assert(std::endian::native == std::endian::little,
              "the binary trace is little-endian; add byte swapping for this host");

}  // namespace circtest::trace_detail
