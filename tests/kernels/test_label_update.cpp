// Every label_update variant the CPU can run against the scalar reference: byte-identical stores on
// random stores, random observations (spare bytes 255, as the observation builder writes them),
// counts around every vector width, surfels repeated within a group (the order must be the
// reference's), saturation, and no write to surfels no pair names.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/label_update.h"
#include "kernels/label_update_variants.h"

namespace ef::kernels {
namespace {

struct Case {
  std::vector<uint8_t> store, obs;
  std::vector<LabelUpdatePair> pairs;
};

// pool surfels, obs_count vectors, n pairs; ids drawn from 0..id_range-1 (small ranges repeat ids).
Case random_case(std::mt19937& rng, int pool, int obs_count, std::size_t n, int id_range, bool extreme) {
  Case c;
  c.store.resize(std::size_t(pool) * kLabelUpdateBytes);
  c.obs.resize(std::size_t(obs_count) * kLabelUpdateBytes);
  std::uniform_int_distribution<int> byte(0, 255), small(0, 40), pick(0, 3);
  auto draw = [&]() { return extreme ? (pick(rng) == 0 ? 255 : byte(rng)) : (pick(rng) == 0 ? byte(rng) : small(rng)); };
  for (std::size_t s = 0; s < c.store.size(); s += kLabelUpdateBytes) {
    for (int k = 0; k < kLabelUpdateClasses; ++k) c.store[s + k] = static_cast<uint8_t>(draw());
    c.store[s + 14] = c.store[s + 15] = 0;
  }
  for (std::size_t s = 0; s < c.obs.size(); s += kLabelUpdateBytes) {
    for (int k = 0; k < kLabelUpdateClasses; ++k) c.obs[s + k] = static_cast<uint8_t>(draw());
    c.obs[s + std::size_t(std::uniform_int_distribution<int>(0, 13)(rng))] = 0;  // its best class
    c.obs[s + 14] = c.obs[s + 15] = 255;
  }
  std::uniform_int_distribution<int> id(0, id_range - 1), ob(0, obs_count - 1);
  for (std::size_t i = 0; i < n; ++i) c.pairs.push_back({id(rng), ob(rng)});
  return c;
}

void expect_variants_match(const Case& c, const std::string& what) {
  std::vector<uint8_t> want = c.store;
  label_update_ref(want.data(), c.obs.data(), c.pairs.data(), c.pairs.size());
  for (const auto* v : test::runnable_variants(kLabelUpdateVariants, "label_update")) {
    std::vector<uint8_t> got = c.store;
    v->fn(got.data(), c.obs.data(), c.pairs.data(), c.pairs.size());
    for (std::size_t b = 0; b < want.size(); ++b)
      ASSERT_EQ(int(got[b]), int(want[b])) << v->name << " " << what << ": first mismatch at surfel "
                                           << b / kLabelUpdateBytes << " byte " << b % kLabelUpdateBytes;
  }
}

TEST(LabelUpdateVariants, MatchReferenceOnRandomCounts) {
  std::mt19937 rng(6);
  for (std::size_t n = 0; n <= 40; ++n)
    for (bool extreme : {false, true})
      expect_variants_match(random_case(rng, 97, 31, n, 97, extreme), "n=" + std::to_string(n));
  expect_variants_match(random_case(rng, 5000, 300, 4099, 5000, false), "n=4099");
}

TEST(LabelUpdateVariants, MatchReferenceWithRepeatedSurfels) {
  std::mt19937 rng(7);
  for (int range : {1, 2, 3, 5})
    for (std::size_t n : {2u, 3u, 4u, 7u, 8u, 9u, 33u, 257u})
      expect_variants_match(random_case(rng, 8, 11, n, range, false), "range=" + std::to_string(range));
}

TEST(LabelUpdateVariants, SaturationAndRenormalisation) {
  // old = {0, 200, 255, ...}, obs = {100, 0, 200, ...}: sums {100, 200, 255(sat)}, min 100.
  std::vector<uint8_t> store(16, 0), obs(16, 0);
  store[1] = 200;
  store[2] = 255;
  obs[0] = 100;
  obs[2] = 200;
  for (int k = 3; k < 14; ++k) obs[k] = 255;  // classes 3..13: 0 + 255 = 255
  obs[14] = obs[15] = 255;
  const LabelUpdatePair pair{0, 0};
  for (const auto* v : test::runnable_variants(kLabelUpdateVariants, "label_update")) {
    std::vector<uint8_t> s = store;
    v->fn(s.data(), obs.data(), &pair, 1);
    EXPECT_EQ(s[0], 0) << v->name;
    EXPECT_EQ(s[1], 100) << v->name;
    EXPECT_EQ(s[2], 155) << v->name;  // 255 (saturated) - 100
    for (int k = 3; k < 14; ++k) EXPECT_EQ(s[k], 155) << v->name;
    EXPECT_EQ(s[14], 0) << v->name;
    EXPECT_EQ(s[15], 0) << v->name;
  }
}

TEST(LabelUpdateVariants, UntouchedSurfelsStayUntouched) {
  std::mt19937 rng(8);
  Case c = random_case(rng, 64, 9, 0, 64, false);
  for (int i = 0; i < 64; i += 3) c.pairs.push_back({i, i % 9});
  for (const auto* v : test::runnable_variants(kLabelUpdateVariants, "label_update")) {
    std::vector<uint8_t> s = c.store;
    v->fn(s.data(), c.obs.data(), c.pairs.data(), c.pairs.size());
    for (int i = 0; i < 64; ++i) {
      if (i % 3 == 0) continue;
      for (int b = 0; b < 16; ++b) {
        ASSERT_EQ(s[std::size_t(i) * 16 + b], c.store[std::size_t(i) * 16 + b]) << v->name;
      }
    }
  }
  std::printf("[ variants ] dispatch: label_update -> %s\n", label_update_selected());
}

}  // namespace
}  // namespace ef::kernels
