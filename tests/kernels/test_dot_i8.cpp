// Every dot_i8 variant the CPU can run against the scalar reference: exact int32 equality on random
// data, every length around the SIMD step sizes (16/32/64), int8 extremes, unaligned pointers and a
// sum that wraps past int32.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/dot_i8.h"
#include "kernels/dot_i8_variants.h"

namespace ef::kernels {
namespace {

// Copies `a`,`b` into buffers that end exactly where the data ends and start `offset` bytes into the
// allocation, so reads past n are heap overflows (caught by ASan) and pointers are not vector-aligned.
struct Placed {
  std::vector<int8_t> a, b;
  Placed(const std::vector<int8_t>& src_a, const std::vector<int8_t>& src_b, std::size_t offset)
      : a(offset + src_a.size()), b(offset + src_b.size()) {
    std::copy(src_a.begin(), src_a.end(), a.begin() + static_cast<std::ptrdiff_t>(offset));
    std::copy(src_b.begin(), src_b.end(), b.begin() + static_cast<std::ptrdiff_t>(offset));
  }
};

void expect_all_variants_match(const std::vector<int8_t>& a, const std::vector<int8_t>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size());
  const int32_t want = dot_i8_ref(a.data(), b.data(), a.size());
  for (const auto& v : kDotI8Variants) {
    if (!isa_available(v.isa, detected_cpu_features())) continue;
    for (std::size_t offset : {0u, 1u, 3u}) {
      Placed p(a, b, offset);
      const int32_t got = v.fn(p.a.data() + offset, p.b.data() + offset, a.size());
      ASSERT_EQ(got, want) << v.name << " differs from dot_i8_ref: " << what << ", n=" << a.size()
                           << ", pointer offset " << offset;
    }
  }
}

const std::size_t kDotLengths[] = {0,  1,  2,  3,  7,  8,  15, 16,  17,  31,  32,  33,  47,   48,  49,
                                63, 64, 65, 95, 96, 97, 127, 128, 129, 191, 255, 256, 257, 1000, 4099};

TEST(DotI8, ReportVariants) {
  const auto ran = ef::test::runnable_variants(kDotI8Variants, "dot_i8");
  EXPECT_FALSE(ran.empty());
}

TEST(DotI8, RandomInputsEveryLength) {
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> byte(-128, 127);
  for (std::size_t n : kDotLengths) {
    for (int rep = 0; rep < 3; ++rep) {
      std::vector<int8_t> a(n), b(n);
      for (auto& x : a) x = static_cast<int8_t>(byte(rng));
      for (auto& x : b) x = static_cast<int8_t>(byte(rng));
      expect_all_variants_match(a, b, "random rep " + std::to_string(rep));
    }
  }
}

TEST(DotI8, Extremes) {
  const int8_t values[] = {-128, -127, -1, 0, 1, 127};
  for (std::size_t n : kDotLengths) {
    for (int8_t x : values) {
      for (int8_t y : values) {
        expect_all_variants_match(std::vector<int8_t>(n, x), std::vector<int8_t>(n, y),
                                  "all a=" + std::to_string(x) + " b=" + std::to_string(y));
      }
    }
    // Alternating extremes, so neighbouring products of opposite sign meet in one lane.
    std::vector<int8_t> a(n), b(n);
    for (std::size_t i = 0; i < n; ++i) {
      a[i] = (i % 2) ? int8_t{127} : int8_t{-128};
      b[i] = (i % 3) ? int8_t{-128} : int8_t{127};
    }
    expect_all_variants_match(a, b, "alternating extremes");
  }
}

TEST(DotI8, MatchesExactSumUpToInt32Limit) {
  // n = 131071 of (-128)*(-128) = 131071 * 16384 = 2147467264, the largest sum the contract calls exact.
  const std::size_t n = 131071;
  const std::vector<int8_t> a(n, -128);
  EXPECT_EQ(dot_i8_ref(a.data(), a.data(), n), 2147467264);
  expect_all_variants_match(a, a, "largest exact sum");
}

TEST(DotI8, WrapsModulo2To32IdenticallyPastInt32) {
  // 200003 * 16384 = 3276849152 > INT32_MAX: every variant must give the same value mod 2^32.
  const std::size_t n = 200003;
  const std::vector<int8_t> a(n, -128);
  EXPECT_EQ(dot_i8_ref(a.data(), a.data(), n), static_cast<int32_t>(3276849152u - 4294967296ll));
  expect_all_variants_match(a, a, "wrapping sum");
}

TEST(DotI8, DispatchedMatchesReference) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(-128, 127);
  std::vector<int8_t> a(1031), b(1031);
  for (auto& x : a) x = static_cast<int8_t>(byte(rng));
  for (auto& x : b) x = static_cast<int8_t>(byte(rng));
  EXPECT_EQ(dot_i8(a.data(), b.data(), a.size()), dot_i8_ref(a.data(), b.data(), a.size()));
  EXPECT_EQ(dot_i8(a.data(), b.data(), 0), 0);
}

}  // namespace
}  // namespace ef::kernels
