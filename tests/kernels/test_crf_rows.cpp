// Every crf_rows variant the CPU can run against the scalar reference, byte for byte: slice, splat
// and blur on random rows (mixed signs, -0, subnormals, large magnitudes), weights 0, 65535 and
// random, vertices repeated within a point and across neighbouring points (a splat must accumulate in
// the reference's order), point counts around every vector and prefetch width, sub-ranges of the
// blur, and no write outside what each function's contract names.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/crf_rows.h"
#include "kernels/crf_rows_variants.h"

namespace ef::kernels {
namespace {

constexpr int V = kCrfRowFloats;
constexpr int K = kCrfSimplex;

float random_value(std::mt19937& rng) {
  std::uniform_int_distribution<int> pick(0, 15);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  switch (pick(rng)) {
    case 0: return 0.0f;
    case 1: return -0.0f;
    case 2: return std::numeric_limits<float>::denorm_min() * float(1 + pick(rng));
    case 3: return unit(rng) * 1e30f;
    case 4: return unit(rng) * 1e-30f;
    case 5: return float(pick(rng));  // small integers: exact sums, ties in rounding
    default: return unit(rng) * 65535.0f;
  }
}

std::vector<float> random_rows(std::mt19937& rng, std::size_t rows) {
  std::vector<float> r(rows * V);
  for (float& x : r) x = random_value(rng);
  return r;
}

struct Points {
  std::vector<uint32_t> vertices;
  std::vector<uint16_t> weights;
};

// n points over `rows` rows; vertex ids from 0..id_range-1 (small ranges repeat ids within a point).
Points random_points(std::mt19937& rng, std::size_t n, uint32_t id_range) {
  Points p;
  std::uniform_int_distribution<uint32_t> id(0, id_range - 1);
  std::uniform_int_distribution<int> pick(0, 5), any(0, 65535);
  for (std::size_t i = 0; i < n * K; ++i) {
    p.vertices.push_back(id(rng));
    const int kind = pick(rng);
    p.weights.push_back(uint16_t(kind == 0 ? 0 : kind == 1 ? 65535 : any(rng)));
  }
  return p;
}

std::string first_mismatch(const std::vector<float>& got, const std::vector<float>& want) {
  for (std::size_t i = 0; i < want.size(); ++i)
    if (std::memcmp(&got[i], &want[i], sizeof(float)) != 0)
      return "row " + std::to_string(i / V) + " lane " + std::to_string(i % V) + ": got " + std::to_string(got[i]) +
             ", want " + std::to_string(want[i]);
  return "";
}

void expect_slice_matches(std::mt19937& rng, std::size_t rows, std::size_t n, uint32_t id_range, const std::string& what) {
  const std::vector<float> table = random_rows(rng, rows);
  const Points p = random_points(rng, n, id_range);
  std::vector<float> want(n * V + V, 7.0f);  // one guard row past the end
  crf_rows_ref.slice(table.data(), p.vertices.data(), p.weights.data(), n, want.data());
  for (const auto* v : test::runnable_variants(kCrfRowsVariants, "crf_rows slice")) {
    std::vector<float> got(n * V + V, 7.0f);
    v->fn->slice(table.data(), p.vertices.data(), p.weights.data(), n, got.data());
    ASSERT_EQ(first_mismatch(got, want), "") << v->name << " slice " << what;
  }
}

void expect_splat_matches(std::mt19937& rng, std::size_t rows, std::size_t n, uint32_t id_range, const std::string& what) {
  const std::vector<float> start = random_rows(rng, rows);
  const std::vector<float> in = random_rows(rng, n);
  const Points p = random_points(rng, n, id_range);
  std::vector<float> want = start;
  crf_rows_ref.splat(want.data(), p.vertices.data(), p.weights.data(), n, in.data());
  for (const auto* v : test::runnable_variants(kCrfRowsVariants, "crf_rows splat")) {
    std::vector<float> got = start;
    v->fn->splat(got.data(), p.vertices.data(), p.weights.data(), n, in.data());
    ASSERT_EQ(first_mismatch(got, want), "") << v->name << " splat " << what;
  }
}

void expect_blur_matches(std::mt19937& rng, std::size_t rows, std::size_t begin, std::size_t end, const std::string& what) {
  // rows vertices plus the all-zero row that stands for a missing neighbour.
  std::vector<float> in = random_rows(rng, rows + 1);
  std::fill(in.end() - V, in.end(), 0.0f);
  std::uniform_int_distribution<uint32_t> id(0, uint32_t(rows));  // rows = the zero row
  std::vector<uint32_t> neighbours(2 * rows);
  for (auto& n : neighbours) n = id(rng);
  const std::vector<float> start = random_rows(rng, rows + 1);
  std::vector<float> want = start;
  crf_rows_ref.blur(in.data(), want.data(), neighbours.data(), begin, end);
  for (const auto* v : test::runnable_variants(kCrfRowsVariants, "crf_rows blur")) {
    std::vector<float> got = start;
    v->fn->blur(in.data(), got.data(), neighbours.data(), begin, end);
    ASSERT_EQ(first_mismatch(got, want), "") << v->name << " blur " << what;
  }
}

TEST(CrfRowsVariants, SliceMatchesReference) {
  std::mt19937 rng(61);
  for (std::size_t n = 0; n <= 20; ++n) expect_slice_matches(rng, 50, n, 50, "n=" + std::to_string(n));
  for (uint32_t range : {1u, 2u, 3u, 8u}) expect_slice_matches(rng, 8, 33, range, "range=" + std::to_string(range));
  expect_slice_matches(rng, 30000, 4099, 30000, "n=4099");
}

TEST(CrfRowsVariants, SplatMatchesReferenceWithRepeatedVertices) {
  std::mt19937 rng(62);
  for (std::size_t n = 0; n <= 20; ++n) expect_splat_matches(rng, 50, n, 50, "n=" + std::to_string(n));
  // Few rows: every point names some rows several times, and consecutive points share them.
  for (uint32_t range : {1u, 2u, 3u, 8u})
    for (std::size_t n : {1u, 2u, 5u, 33u, 257u})
      expect_splat_matches(rng, 8, n, range, "range=" + std::to_string(range) + " n=" + std::to_string(n));
  expect_splat_matches(rng, 30000, 4099, 30000, "n=4099");
}

TEST(CrfRowsVariants, BlurMatchesReferenceOnRanges) {
  std::mt19937 rng(63);
  for (std::size_t rows = 1; rows <= 20; ++rows) expect_blur_matches(rng, rows, 0, rows, "rows=" + std::to_string(rows));
  expect_blur_matches(rng, 100, 0, 0, "empty");
  expect_blur_matches(rng, 100, 17, 61, "17..61");
  expect_blur_matches(rng, 5000, 0, 5000, "rows=5000");
}

TEST(CrfRowsVariants, ZeroWeightsAddZeroProducts) {
  // Weight 0 still takes part in the sum (0 x -0 = -0, 0 + -0 = +0): the slice of rows of -0 is +0.
  const std::vector<float> table(2 * V, -0.0f);
  const std::vector<uint32_t> vertices(K, 1);
  const std::vector<uint16_t> weights(K, 0);
  for (const auto* v : test::runnable_variants(kCrfRowsVariants, "crf_rows zero weights")) {
    std::vector<float> out(V, 1.0f);
    v->fn->slice(table.data(), vertices.data(), weights.data(), 1, out.data());
    for (int c = 0; c < V; ++c) {
      EXPECT_EQ(out[std::size_t(c)], 0.0f) << v->name;
      EXPECT_FALSE(std::signbit(out[std::size_t(c)])) << v->name << " lane " << c;
    }
  }
}

TEST(CrfRowsVariants, DispatchUsesTheBestAvailable) {
  EXPECT_EQ(kCrfRowsVariants[0].isa, Isa::scalar);
  EXPECT_STREQ(crf_rows_selected(), best_variant(kCrfRowsVariants, cpu_features()).name);
  // The dispatched entry points give the reference's bits too.
  std::mt19937 rng(64);
  const std::vector<float> table = random_rows(rng, 40);
  const Points p = random_points(rng, 9, 40);
  std::vector<float> want(9 * V), got(9 * V);
  crf_rows_ref.slice(table.data(), p.vertices.data(), p.weights.data(), 9, want.data());
  crf_slice_rows(table.data(), p.vertices.data(), p.weights.data(), 9, got.data());
  EXPECT_EQ(first_mismatch(got, want), "");
}

}  // namespace
}  // namespace ef::kernels
