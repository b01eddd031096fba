#pragma once
// Internal: medians of many values without sorting them all (the outlier check of every run).
#include <algorithm>
#include <cstddef>
#include <vector>

namespace circtest::detail {

// The upper median (v[n/2] once ordered); reorders v, so a caller can reuse it as scratch.
inline double median_in_place(std::vector<double>& v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The upper median of value(i), i < n (the element of rank n/2 once ordered, exactly what
// median_in_place gives), without an array of all n values: on a 1e6-sample trace that array
// and nth_element over it were most of the outlier check. A strided sample brackets the
// median, one pass counts the values below the bracket and keeps those inside it, and the rank
// is found among those. When the bracket misses (values arranged against the stride) or a
// value is not a number, all values are taken after all.
template <class Value>
double median_of(std::size_t n, const Value& value) {
  constexpr std::size_t kSample = 4096;
  auto all = [&] {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = value(i);
    return median_in_place(v);
  };
  if (n < 16 * kSample) return all();
  const std::size_t stride = n / kSample;
  std::vector<double> sample;
  sample.reserve(n / stride + 1);
  for (std::size_t i = 0; i < n; i += stride) sample.push_back(value(i));
  std::sort(sample.begin(), sample.end());
  // The median's rank in a random sample of m is m/2 give or take sqrt(m)/2; the bracket is
  // 8 of those either side (about 1/8 of the values fall inside it).
  const std::size_t m = sample.size(), margin = m / 16;
  const double lo = sample[m / 2 - margin], hi = sample[m / 2 + margin];
  // Without branches (a value falls below or above the bracket about as often): each value is
  // written at the end of `inside`, which only grows when it was inside.
  std::size_t below = 0, nan = 0, count = 0;
  constexpr std::size_t kChunk = 1024;
  std::vector<double> inside(n / 4 + kChunk);
  double chunk[kChunk];
  for (std::size_t c0 = 0; c0 < n; c0 += kChunk) {
    const std::size_t c1 = std::min(n, c0 + kChunk);
    for (std::size_t i = c0; i < c1; ++i) chunk[i - c0] = value(i);
    if (inside.size() < count + kChunk) inside.resize(2 * inside.size());
    for (std::size_t k = 0; k < c1 - c0; ++k) {
      const double v = chunk[k];
      below += v < lo ? 1 : 0;
      nan += v != v ? 1 : 0;
      inside[count] = v;
      count += (v >= lo && v <= hi) ? 1 : 0;
    }
  }
  inside.resize(count);
  const std::size_t rank = n / 2;
  if (nan > 0 || rank < below || rank >= below + count) return all();
  const auto mid = inside.begin() + static_cast<std::ptrdiff_t>(rank - below);
  std::nth_element(inside.begin(), mid, inside.end());
  return *mid;
}

}  // namespace circtest::detail
