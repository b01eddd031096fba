// detail::median_of (analysis/src/evaluation/median.hpp): the upper median found from a sample's
// bracket must be exactly the element nth_element puts at rank n/2, whatever the order of the
// values: random, sorted, reversed, arranged against the sample's stride, with ties, and with a
// value that is not a number (then the whole array is taken, as before).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <random>
#include <vector>

#include "median.hpp"

using circtest::detail::median_of;

namespace {

double reference_median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double bracketed(const std::vector<double>& v) {
  return median_of(v.size(), [&](std::size_t i) { return v[i]; });
}

TEST(MedianOf, EqualsTheElementOfRankHalfNForRandomValues) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(75.0, 0.002);
  for (const std::size_t n : {std::size_t{10}, std::size_t{65535}, std::size_t{65536},
                              std::size_t{100001}, std::size_t{426000}}) {
    std::vector<double> v(n);
    for (double& x : v) x = noise(rng);
    EXPECT_EQ(bracketed(v), reference_median(v)) << n << " values";
  }
}

TEST(MedianOf, EqualsItForSortedReversedAndTiedValues) {
  const std::size_t n = 200000;
  std::vector<double> up(n), ties(n);
  for (std::size_t i = 0; i < n; ++i) {
    up[i] = static_cast<double>(i) * 1e-6;
    ties[i] = static_cast<double>(i % 3);  // a third each of 0, 1, 2
  }
  std::vector<double> down(up.rbegin(), up.rend());
  EXPECT_EQ(bracketed(up), reference_median(up));
  EXPECT_EQ(bracketed(down), reference_median(down));
  EXPECT_EQ(bracketed(ties), 1.0);
}

TEST(MedianOf, EqualsItWhenTheValuesDefeatTheSample) {
  // Every value the strided sample reads is far below the rest: the bracket misses the median
  // and the whole array is taken.
  const std::size_t n = 300000;
  const std::size_t stride = n / 4096;
  std::vector<double> v(n);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(10.0, 11.0);
  for (std::size_t i = 0; i < n; ++i) v[i] = i % stride == 0 ? -1.0 : u(rng);
  EXPECT_EQ(bracketed(v), reference_median(v));
}

TEST(MedianOf, TakesEveryValueWhenOneIsNotANumber) {
  std::vector<double> v(100000);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<double>((i * 7919) % 100000);
  const double clean = bracketed(v);
  EXPECT_EQ(clean, reference_median(v));
  v[12345] = std::numeric_limits<double>::quiet_NaN();
  // nth_element's answer with a NaN present is whatever it is; median_of must give the same.
  EXPECT_EQ(bracketed(v), reference_median(v));
}

}  // namespace
