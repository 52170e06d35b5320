// Every depth_u16_to_metres variant the CPU can run against the scalar reference: bit-identical
// floats (compared as bits, so +0/-0 and NaN payloads count), the valid-range edges, every length
// around the SIMD step sizes, unaligned pointers, and no write past n.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/depth_convert.h"
#include "kernels/depth_u16_to_metres_variants.h"

namespace ef::kernels {
namespace {

constexpr std::size_t kGuard = 67;          // floats after dst[n-1] that must stay untouched
constexpr uint32_t kSentinelBits = 0x7FC0BEEFu;  // a NaN no variant produces

uint32_t bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

void expect_all_variants_match(const std::vector<uint16_t>& raw, float scale, uint16_t max_valid,
                               const std::string& what) {
  const std::size_t n = raw.size();
  std::vector<float> want(n);
  depth_u16_to_metres_ref(raw.data(), want.data(), n, scale, max_valid);
  float sentinel;
  std::memcpy(&sentinel, &kSentinelBits, sizeof sentinel);
  for (const auto& v : kDepthU16ToMetresVariants) {
    if (!isa_available(v.isa, detected_cpu_features())) continue;
    for (std::size_t src_off : {0u, 1u, 5u}) {
      const std::size_t dst_off = (src_off * 3) % 4;
      // The source ends exactly at the allocation's end: reads past n are heap overflows for ASan.
      std::vector<uint16_t> src(src_off + n);
      std::copy(raw.begin(), raw.end(), src.begin() + static_cast<std::ptrdiff_t>(src_off));
      std::vector<float> dst(dst_off + n + kGuard, sentinel);
      v.fn(src.data() + src_off, dst.data() + dst_off, n, scale, max_valid);
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(bits(dst[dst_off + i]), bits(want[i]))
            << v.name << " differs from depth_u16_to_metres_ref at i=" << i << " raw=" << raw[i] << " (" << what
            << ", n=" << n << ", scale=" << scale << ", max_valid_raw=" << max_valid << ", src offset " << src_off
            << ")";
      }
      for (std::size_t i = 0; i < dst_off; ++i) ASSERT_EQ(bits(dst[i]), kSentinelBits) << v.name << " wrote before dst";
      for (std::size_t i = dst_off + n; i < dst.size(); ++i)
        ASSERT_EQ(bits(dst[i]), kSentinelBits) << v.name << " wrote past n=" << n << " at " << i - dst_off;
    }
  }
}

const std::size_t kLengths[] = {0, 1, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 32, 33, 63, 64, 65, 100, 640 * 3 + 5};

// TUM (1/5000 m, all values valid), 7-Scenes (1/1000 m, 65535 invalid), and odd settings.
struct Setting {
  float scale;
  uint16_t max_valid;
};
const Setting kSettings[] = {{1.0f / 5000.0f, 65535}, {1.0f / 1000.0f, 65534}, {0.001f, 5000},
                             {1.0f, 1},               {3.3e-4f, 0},           {-0.25f, 40000}};

TEST(DepthU16ToMetres, ReportVariants) {
  const auto ran = ef::test::runnable_variants(kDepthU16ToMetresVariants, "depth_u16_to_metres");
  EXPECT_FALSE(ran.empty());
}

TEST(DepthU16ToMetres, RandomEveryLength) {
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> value(0, 65535);
  for (const Setting& s : kSettings) {
    for (std::size_t n : kLengths) {
      std::vector<uint16_t> raw(n);
      for (auto& r : raw) r = static_cast<uint16_t>(value(rng));
      expect_all_variants_match(raw, s.scale, s.max_valid, "random");
    }
  }
}

TEST(DepthU16ToMetres, ValidRangeEdges) {
  for (const Setting& s : kSettings) {
    const uint16_t m = s.max_valid;
    // Zero, the bounds of the valid range and the largest raw values, cycled through every lane.
    const uint16_t edges[] = {0, 1, static_cast<uint16_t>(m - 1), m, static_cast<uint16_t>(m + 1), 65534, 65535,
                              32768, 32767};
    for (std::size_t n : kLengths) {
      std::vector<uint16_t> raw(n);
      for (std::size_t i = 0; i < n; ++i) raw[i] = edges[(i * 5 + n) % (sizeof edges / sizeof edges[0])];
      expect_all_variants_match(raw, s.scale, s.max_valid, "edges");
    }
  }
}

TEST(DepthU16ToMetres, ReferenceSemantics) {
  const uint16_t raw[] = {0, 1, 5000, 65534, 65535};
  float out[5];
  depth_u16_to_metres_ref(raw, out, 5, 1.0f / 1000.0f, 65534);
  EXPECT_EQ(bits(out[0]), 0u);  // invalid -> +0.0f
  EXPECT_EQ(out[1], 1.0f * (1.0f / 1000.0f));
  EXPECT_EQ(out[2], 5000.0f * (1.0f / 1000.0f));
  EXPECT_EQ(out[3], 65534.0f * (1.0f / 1000.0f));
  EXPECT_EQ(bits(out[4]), 0u);  // above max_valid_raw
}

TEST(DepthU16ToMetres, DispatchedMatchesReference) {
  std::vector<uint16_t> raw(640 + 3);
  for (std::size_t i = 0; i < raw.size(); ++i) raw[i] = static_cast<uint16_t>(i * 97);
  std::vector<float> want(raw.size()), got(raw.size());
  depth_u16_to_metres_ref(raw.data(), want.data(), raw.size(), 1.0f / 5000.0f, 60000);
  depth_u16_to_metres(raw.data(), got.data(), raw.size(), 1.0f / 5000.0f, 60000);
  EXPECT_EQ(0, std::memcmp(want.data(), got.data(), want.size() * sizeof(float)));
}

}  // namespace
}  // namespace ef::kernels
