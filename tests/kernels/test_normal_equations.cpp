// reduce_normal_equations: every variant the CPU can run equals the scalar reference bit for bit
// (sizes around the lane, group and block boundaries, zero weights, huge and tiny magnitudes, strides
// and unaligned pointers); the reference agrees with a direct double-precision sum on realistic ICP
// rows within the documented bound; and a fixed input gives the same bits on every architecture.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/normal_equations.h"
#include "kernels/reduce_normal_equations_variants.h"

namespace ef::kernels {
namespace {

// SoA rows in a buffer that ends exactly where component 7 of row n-1 ends, `offset` floats into the
// allocation (so over-reads are heap overflows under ASan and pointers are not vector-aligned).
struct NeRows {
  std::size_t n = 0, stride = 0, offset = 0;
  std::vector<float> buf;
  NeRows(std::size_t n_, std::size_t stride_, std::size_t offset_) : n(n_), stride(stride_), offset(offset_) {
    buf.assign(offset + 7 * stride + n, -12345.0f);  // poison the gaps between streams
    for (int k = 0; k < kNeComponents; ++k)
      for (std::size_t i = 0; i < n; ++i) at(k, i) = 0.0f;
  }
  float& at(int k, std::size_t i) { return buf[offset + k * stride + i]; }
  const float* data() const { return buf.data() + offset; }
};

std::string first_difference(const NormalEquations& a, const NormalEquations& b) {
  for (int o = 0; o < kNeOutputs; ++o)
    if (std::memcmp(&a.upper[o], &b.upper[o], sizeof(double)) != 0) {
      char msg[160];
      std::snprintf(msg, sizeof msg, "output %d: %.17g vs %.17g", o, a.upper[o], b.upper[o]);
      return msg;
    }
  if (a.inliers != b.inliers) return "inliers " + std::to_string(a.inliers) + " vs " + std::to_string(b.inliers);
  return "";
}

void expect_variants_equal_reference(const NeRows& rows, const std::string& what) {
  NormalEquations want;
  reduce_normal_equations_ref(rows.data(), rows.stride, rows.n, &want);
  for (const auto& v : kReduceNormalEquationsVariants) {
    if (!isa_available(v.isa, detected_cpu_features())) continue;
    NormalEquations got;
    got.upper[3] = 99;  // outputs are overwritten, not accumulated
    got.inliers = -7;
    v.fn(rows.data(), rows.stride, rows.n, &got);
    const std::string diff = first_difference(got, want);
    EXPECT_TRUE(diff.empty()) << v.name << " differs from the reference (" << what << ", n=" << rows.n
                              << ", stride=" << rows.stride << ", offset=" << rows.offset << "): " << diff;
  }
}

// Random rows: J ~ scale * N(0,1), r ~ scale * N(0,1), w uniform in [0,1) with ~10% exact zeros.
NeRows random_rows(std::size_t n, std::size_t stride, std::size_t offset, float scale, uint32_t seed) {
  NeRows rows(n, stride, offset);
  std::mt19937 rng(seed);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 7; ++k) rows.at(k, i) = scale * gauss(rng);
    const float u = unit(rng);
    rows.at(7, i) = u < 0.1f ? 0.0f : unit(rng);
  }
  return rows;
}

// Point-to-plane ICP rows as the tracker will write them (KinectFusion, Newcombe et al. 2011, eq. 2
// linearised): J = (n^T, (p x n)^T), r = n . (q - p) for camera points p up to 4 m, unit normals n,
// residuals of a few millimetres, Huber-like weights; 20% of the rows invalid (w = 0).
NeRows icp_rows(std::size_t n, uint32_t seed) {
  NeRows rows(n, n, 0);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.004);
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 0.6 + 1.7 * (u(rng) + 1.0);
    const double p[3] = {z * 0.55 * u(rng), z * 0.41 * u(rng), z};
    double nn[3] = {0.6 * u(rng), 0.6 * u(rng), -1.0};
    const double len = std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    for (double& c : nn) c /= len;
    const double pxn[3] = {p[1] * nn[2] - p[2] * nn[1], p[2] * nn[0] - p[0] * nn[2], p[0] * nn[1] - p[1] * nn[0]};
    const double r = noise(rng);
    const bool valid = u(rng) > -0.6;
    const double w = !valid ? 0.0 : std::fabs(r) < 0.01 ? 1.0 : 0.01 / std::fabs(r);
    for (int k = 0; k < 3; ++k) rows.at(k, i) = static_cast<float>(nn[k]);
    for (int k = 0; k < 3; ++k) rows.at(3 + k, i) = static_cast<float>(pxn[k]);
    rows.at(6, i) = static_cast<float>(r);
    rows.at(7, i) = static_cast<float>(w);
  }
  return rows;
}

const std::size_t kNeSizes[] = {0,   1,   2,   3,   7,   8,    9,    15,   16,   17,   31,    33,    63,   64,
                              65,  127, 511, 512, 513, 519,  520,  1023, 1024, 1025, 1031,  4097,  76800, 76801};

TEST(NormalEquations, ReportVariants) {
  const auto ran = ef::test::runnable_variants(kReduceNormalEquationsVariants, "reduce_normal_equations");
  EXPECT_FALSE(ran.empty());
  std::printf("[ variants ] reduce_normal_equations dispatches to %s\n", reduce_normal_equations_selected());
}

TEST(NormalEquations, OneRowIsTheOuterProduct) {
  NeRows rows(1, 1, 0);
  const float a[7] = {1, 2, 3, 4, 5, 6, 7};
  for (int k = 0; k < 7; ++k) rows.at(k, 0) = a[k];
  rows.at(7, 0) = 2.0f;
  NormalEquations ne;
  reduce_normal_equations_ref(rows.data(), 1, 1, &ne);
  for (int p = 0; p < 7; ++p)
    for (int q = p; q < 7; ++q) EXPECT_EQ(ne.upper[ne_index(p, q)], 2.0 * a[p] * a[q]) << p << "," << q;
  EXPECT_EQ(ne.jtj(4, 1), 2.0 * 5 * 2);
  EXPECT_EQ(ne.jtr(2), 2.0 * 3 * 7);
  EXPECT_EQ(ne.r2(), 2.0 * 49);
  EXPECT_EQ(ne.inliers, 1);
  expect_variants_equal_reference(rows, "one row");
}

TEST(NormalEquations, IndexCoversTheTriangleOnce) {
  int expected = 0;
  for (int p = 0; p < 7; ++p)
    for (int q = p; q < 7; ++q) EXPECT_EQ(ne_index(p, q), expected++);
  EXPECT_EQ(expected, kNeOutputs);
}

TEST(NormalEquations, EmptyInputGivesZeros) {
  for (const auto& v : kReduceNormalEquationsVariants) {
    if (!isa_available(v.isa, detected_cpu_features())) continue;
    NormalEquations ne;
    ne.upper[0] = 5;
    ne.inliers = 3;
    v.fn(nullptr, 0, 0, &ne);
    for (double x : ne.upper) EXPECT_EQ(x, 0.0) << v.name;
    EXPECT_EQ(ne.inliers, 0) << v.name;
  }
}

TEST(NormalEquations, RandomRowsEverySizeBitIdentical) {
  uint32_t seed = 1;
  for (std::size_t n : kNeSizes) {
    expect_variants_equal_reference(random_rows(n, n, 0, 1.0f, seed++), "random, packed");
    expect_variants_equal_reference(random_rows(n, n + 5, 1, 1.0f, seed++), "random, stride n+5, offset 1");
  }
}

TEST(NormalEquations, ZeroWeightsAddNothing) {
  for (std::size_t n : {std::size_t{9}, std::size_t{517}, std::size_t{76800}}) {
    NeRows rows = random_rows(n, n, 0, 3.0f, 77);
    for (std::size_t i = 0; i < n; ++i) rows.at(7, i) = 0.0f;
    NormalEquations ne;
    reduce_normal_equations_ref(rows.data(), rows.stride, n, &ne);
    for (double x : ne.upper) EXPECT_EQ(x, 0.0);
    EXPECT_EQ(ne.inliers, 0);
    expect_variants_equal_reference(rows, "all weights zero");
    // Zero-weight rows interleaved with live ones change nothing versus leaving those rows' J and r at 0.
    NeRows half = random_rows(n, n, 0, 1.0f, 78);
    NeRows cleared = half;
    for (std::size_t i = 0; i < n; i += 3) {
      half.at(7, i) = 0.0f;
      for (int k = 0; k < kNeComponents; ++k) cleared.at(k, i) = 0.0f;
    }
    NormalEquations a, b;
    reduce_normal_equations_ref(half.data(), n, n, &a);
    reduce_normal_equations_ref(cleared.data(), n, n, &b);
    EXPECT_EQ(first_difference(a, b), "");
    expect_variants_equal_reference(half, "every third weight zero");
  }
}

TEST(NormalEquations, HugeTinyAndMixedMagnitudes) {
  uint32_t seed = 100;
  for (std::size_t n : {std::size_t{17}, std::size_t{1031}, std::size_t{76800}}) {
    expect_variants_equal_reference(random_rows(n, n, 0, 1e12f, seed++), "huge (1e12)");
    expect_variants_equal_reference(random_rows(n, n, 0, 1e-19f, seed++), "tiny (subnormal products)");
    NeRows mixed = random_rows(n, n, 3, 1.0f, seed++);
    const float scales[] = {1e-18f, 1e-3f, 1.0f, 1e4f, 1e13f};
    for (std::size_t i = 0; i < n; ++i)
      for (int k = 0; k < 7; ++k) mixed.at(k, i) *= scales[(i * 7 + k) % 5];
    expect_variants_equal_reference(mixed, "mixed magnitudes");
    // Overflow to infinity happens identically too.
    NeRows over = random_rows(n, n, 0, 3e19f, seed++);
    expect_variants_equal_reference(over, "overflowing products");
  }
}

TEST(NormalEquations, DispatchedMatchesReference) {
  const NeRows rows = icp_rows(20011, 5);
  NormalEquations a, b;
  reduce_normal_equations(rows.data(), rows.stride, rows.n, &a);
  reduce_normal_equations_ref(rows.data(), rows.stride, rows.n, &b);
  EXPECT_EQ(first_difference(a, b), "");
}

// Against a direct double-precision sum of the same float inputs (products in double, one running
// double sum): the error of the float lanes, relative to sum |term| of each output.
TEST(NormalEquations, ReferenceAgreesWithDoubleOnRealisticRows) {
  const std::size_t n = 76800;  // one 320x240 frame
  const NeRows rows = icp_rows(n, 42);
  NormalEquations ne;
  reduce_normal_equations_ref(rows.data(), rows.stride, n, &ne);
  expect_variants_equal_reference(rows, "realistic ICP rows");
  double direct[kNeOutputs] = {}, magnitude[kNeOutputs] = {};
  int64_t inliers = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = rows.data()[7 * n + i];
    inliers += w > 0;
    for (int p = 0; p < 7; ++p)
      for (int q = p; q < 7; ++q) {
        const double t = w * rows.data()[p * n + i] * rows.data()[q * n + i];
        direct[ne_index(p, q)] += t;
        magnitude[ne_index(p, q)] += std::fabs(t);
      }
  }
  EXPECT_EQ(ne.inliers, inliers);
  double worst = 0, worst_plain = 0;
  for (int o = 0; o < kNeOutputs; ++o) {
    const double rel = std::fabs(ne.upper[o] - direct[o]) / magnitude[o];
    worst = std::max(worst, rel);
    if (std::fabs(direct[o]) > 0.01 * magnitude[o])
      worst_plain = std::max(worst_plain, std::fabs(ne.upper[o] - direct[o]) / std::fabs(direct[o]));
    EXPECT_LT(rel, 1e-6) << "output " << o << ": " << ne.upper[o] << " vs " << direct[o];
  }
  // Diagonal of J^T W J: sums of non-negative terms, so the plain relative error is the bound above.
  std::printf("[ precision ] 76800 ICP rows: worst |float lanes - double| / sum|term| = %.3g; "
              "worst plain relative error (outputs not cancelling below 1%%) = %.3g\n",
              worst, worst_plain);
}

// The same fixed input must give the same bits on x86-64 and AArch64 (FNV-1a of the 28 doubles and
// the count). Inputs come from integer arithmetic only, so they are identical everywhere.
TEST(NormalEquations, SameBitsOnEveryArchitecture) {
  const std::size_t n = 4099;
  NeRows rows(n, n, 0);
  uint32_t state = 2463534242u;
  auto next = [&state] {  // xorshift32
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    return state;
  };
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 7; ++k) rows.at(k, i) = static_cast<float>(static_cast<int32_t>(next())) * 4.656613e-10f;
    rows.at(7, i) = (next() % 8 == 0) ? 0.0f : static_cast<float>(next() % 1000) * 0.001f;
  }
  NormalEquations ne;
  reduce_normal_equations_ref(rows.data(), n, n, &ne);
  expect_variants_equal_reference(rows, "fixed integer-generated rows");
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* p, std::size_t bytes) {
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ static_cast<const unsigned char*>(p)[i]) * 1099511628211ull;
  };
  mix(ne.upper, sizeof ne.upper);
  mix(&ne.inliers, sizeof ne.inliers);
  std::printf("[ bits ] fixed-input hash %016llx (inliers %lld)\n", static_cast<unsigned long long>(h),
              static_cast<long long>(ne.inliers));
  EXPECT_EQ(h, 0xc08ae961f5de506full) << "hash of the reference's output bits changed";
}

}  // namespace
}  // namespace ef::kernels
