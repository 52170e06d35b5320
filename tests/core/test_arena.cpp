#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

#include "core/arena.h"

namespace ef {
namespace {

std::uintptr_t addr(const void* p) { return reinterpret_cast<std::uintptr_t>(p); }

TEST(Arena, AllocationsAreAlignedAndDisjoint) {
  Arena arena(4096);
  EXPECT_EQ(arena.capacity(), 4096u);
  EXPECT_EQ(arena.used(), 0u);
  char* c = arena.allocate<char>(3);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(addr(c) % Arena::kMaxAlign, 0u) << "the block itself is cache-line aligned";
  double* d = arena.allocate<double>(5);
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(addr(d) % alignof(double), 0u);
  EXPECT_GE(addr(d), addr(c + 3));
  float* f = arena.allocate<float>(7, 32);
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(addr(f) % 32, 0u);
  EXPECT_GE(addr(f), addr(d + 5));
  void* line = arena.allocate_bytes(1, 64);
  ASSERT_NE(line, nullptr);
  EXPECT_EQ(addr(line) % 64, 0u);
  EXPECT_GE(addr(line), addr(f + 7));
  // An alignment request below alignof(T) is raised to alignof(T).
  arena.allocate<char>(1);
  std::uint64_t* u = arena.allocate<std::uint64_t>(1, 1);
  ASSERT_NE(u, nullptr);
  EXPECT_EQ(addr(u) % alignof(std::uint64_t), 0u);
  // Every byte handed out is inside the block and writable (ASan checks the bounds).
  for (int i = 0; i < 3; ++i) c[i] = 'x';
  for (int i = 0; i < 5; ++i) d[i] = 1.0;
  for (int i = 0; i < 7; ++i) f[i] = 2.0f;
  *u = 3;
  EXPECT_EQ(arena.failures(), 0u);
}

TEST(Arena, BadAlignmentIsRefusedAndCounted) {
  Arena arena(256);
  EXPECT_EQ(arena.allocate_bytes(8, 0), nullptr);
  EXPECT_EQ(arena.allocate_bytes(8, 3), nullptr);
  EXPECT_EQ(arena.allocate_bytes(8, 128), nullptr);  // above kMaxAlign: cannot be honoured
  EXPECT_EQ(arena.failures(), 3u);
  EXPECT_EQ(arena.used(), 0u);
}

TEST(Arena, ExhaustionReturnsNullAndCountsFailures) {
  Arena arena(100);
  ASSERT_NE(arena.allocate_bytes(60, 1), nullptr);
  EXPECT_EQ(arena.used(), 60u);
  EXPECT_EQ(arena.allocate_bytes(41, 1), nullptr);
  EXPECT_EQ(arena.failures(), 1u);
  EXPECT_EQ(arena.used(), 60u) << "a refused allocation takes nothing";
  // 40 bytes at 64-byte alignment would need [64, 104): past the end of the block.
  EXPECT_EQ(arena.allocate<std::uint32_t>(10, 64), nullptr);
  EXPECT_EQ(arena.failures(), 2u);
  void* last = arena.allocate_bytes(40, 1);  // exactly fills the block
  ASSERT_NE(last, nullptr);
  EXPECT_EQ(arena.used(), 100u);
  EXPECT_EQ(arena.allocate_bytes(1, 1), nullptr);
  EXPECT_EQ(arena.failures(), 3u);
  EXPECT_EQ(arena.allocate<double>(1), nullptr);  // alignment padding would pass the end
  EXPECT_EQ(arena.failures(), 4u);
}

TEST(Arena, HugeCountsDoNotWrapAround) {
  Arena arena(1024);
  // n * sizeof(T) overflows size_t: 2^61 + 1 doubles would wrap to 8 bytes.
  const std::size_t n = std::numeric_limits<std::size_t>::max() / sizeof(double) + 2;
  EXPECT_EQ(arena.allocate<double>(n), nullptr);
  EXPECT_EQ(arena.allocate<std::uint32_t>(std::numeric_limits<std::size_t>::max()), nullptr);
  EXPECT_EQ(arena.allocate_bytes(std::numeric_limits<std::size_t>::max(), 1), nullptr);
  EXPECT_EQ(arena.failures(), 3u);
  EXPECT_EQ(arena.used(), 0u);
}

TEST(Arena, ResetReusesTheBlockAndKeepsHighWater) {
  Arena arena(1000);
  void* first = arena.allocate_bytes(300, 16);
  ASSERT_NE(first, nullptr);
  ASSERT_NE(arena.allocate_bytes(200, 16), nullptr);  // starts at 304
  EXPECT_EQ(arena.used(), 504u);
  EXPECT_EQ(arena.high_water(), 504u);
  arena.reset();
  EXPECT_EQ(arena.used(), 0u);
  EXPECT_EQ(arena.high_water(), 504u);
  EXPECT_EQ(arena.allocate_bytes(10, 16), first) << "after reset allocation starts at the block again";
  EXPECT_EQ(arena.high_water(), 504u);
  ASSERT_NE(arena.allocate_bytes(700, 8), nullptr);
  EXPECT_EQ(arena.used(), 16u + 700u);
  EXPECT_EQ(arena.high_water(), 716u);
  arena.reset();
  EXPECT_EQ(arena.allocate_bytes(1000, 1), first);
  EXPECT_EQ(arena.high_water(), 1000u);
  EXPECT_EQ(arena.failures(), 0u);
  // Failures are a lifetime count, not reset per frame.
  EXPECT_EQ(arena.allocate_bytes(1, 1), nullptr);
  arena.reset();
  EXPECT_EQ(arena.failures(), 1u);
}

TEST(Arena, ZeroCapacity) {
  Arena arena(0);
  EXPECT_EQ(arena.allocate_bytes(1, 1), nullptr);
  EXPECT_EQ(arena.failures(), 1u);
}

}  // namespace
}  // namespace ef
